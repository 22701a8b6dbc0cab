//! Helpers shared by the client's integration tests.

use fusion_shared::service;

/// Removes what a test's private iceoryx2 domain left in `/dev/shm`.
pub fn remove_domain_files(domain: &str) {
    let prefix = service::domain_prefix(domain).unwrap();
    for e in std::fs::read_dir("/dev/shm").into_iter().flatten().flatten() {
        if e.file_name().to_string_lossy().starts_with(&prefix) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}
