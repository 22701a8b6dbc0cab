//! The permission model against a second Unix user: only the daemon's user may
//! create, read, write or break fusiond's shared memory and iceoryx2 files.
//!
//! Adding a user needs root. As another user the tests that need one say so and
//! return, unless `FUSION_REQUIRE_ROOT_TESTS` is set (CI sets it), when they fail.

mod common;

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_shared::ImuSample;
use fusion_shared::service::DOMAIN_ENV;

const PEER: &str = "fusion-peer";

/// The second user's uid, created if needed; `None` (test skipped) when this
/// process cannot add users.
fn peer_uid() -> Option<u32> {
    if fusion_shared::permissions::euid() != 0 {
        assert!(std::env::var_os("FUSION_REQUIRE_ROOT_TESTS").is_none(), "this test needs root to add a Unix user");
        eprintln!("skipped: adding a second Unix user needs root");
        return None;
    }
    let id = |out: Output| String::from_utf8_lossy(&out.stdout).trim().parse::<u32>().ok();
    if let Some(uid) = id(Command::new("id").args(["-u", PEER]).output().unwrap()) {
        return Some(uid);
    }
    let added = Command::new("useradd")
        .args(["--system", "--no-create-home", "--shell", "/usr/sbin/nologin", PEER])
        .output()
        .unwrap();
    // A parallel test may have added it first.
    let uid = id(Command::new("id").args(["-u", PEER]).output().unwrap());
    assert!(uid.is_some(), "useradd failed: {}", String::from_utf8_lossy(&added.stderr));
    uid
}

/// Runs `args` as the second user, killed after 20 s (the hang this guards against).
fn as_peer(args: &[&str]) -> Output {
    Command::new("timeout").args(["20", "runuser", "-u", PEER, "--"]).args(args).output().unwrap()
}

/// A copy of a tool the second user may run (the build tree may be closed to it).
fn peer_copy(dir: &Path, name: &str) -> PathBuf {
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    let to = dir.join(name);
    std::fs::copy(workspace_bin(name), &to).unwrap();
    std::fs::set_permissions(&to, std::fs::Permissions::from_mode(0o755)).unwrap();
    to
}

fn node_counter(domain: &TestDomain) -> PathBuf {
    let files = domain.files();
    let counter =
        files.iter().find(|f| f.starts_with("/dev/shm/") && f.contains("_node.") && f.ends_with("global_mgmt"));
    PathBuf::from(counter.unwrap_or_else(|| panic!("no node counter among {files:?}")))
}

fn config() -> String {
    common::linear_config(Some(0.999))
}

#[test]
fn another_user_can_neither_read_nor_break_the_shared_memory_nor_hang_new_processes() {
    let Some(_) = peer_uid() else { return };
    let domain = TestDomain::new("perm");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.set_wake(true);
    imu.publish_sample(ImuSample::new(1_000_000, 0, 0, [0.0; 3], [0.0; 3])).unwrap();

    // Every file of the domain is the daemon user's and closed to others.
    let files = domain.files();
    assert!(files.len() > 5, "{files:?}");
    for f in &files {
        let meta = std::fs::symlink_metadata(f).unwrap();
        assert_eq!(meta.uid(), 0, "{f}");
        if !meta.is_dir() {
            assert_eq!(meta.mode() & 0o077, 0, "{f} is open to others: {:o}", meta.mode());
        }
    }
    let counter = node_counter(&domain);
    let before = std::fs::read(&counter).unwrap();
    // The other user can neither write (truncate) nor read the node counter (the
    // hang of every new process came from truncating it), nor any segment, nor put
    // files into iceoryx2's directory.
    for f in files.iter().filter(|f| f.starts_with("/dev/shm/")) {
        // Opened for writing, never created: a file that went away since the
        // listing (a connection closed) must not come back as the other user's.
        let out = as_peer(&["dd", "if=/dev/null", &format!("of={f}"), "conv=nocreat,notrunc", "status=none"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{f} is writable by another user");
        assert!(stderr.contains("Permission denied") || !Path::new(f).exists(), "{f}: {stderr}");
        assert!(!as_peer(&["cat", f]).status.success(), "{f} read");
    }
    assert!(!as_peer(&["touch", "/tmp/iceoryx2/planted"]).status.success());
    assert_eq!(std::fs::read(&counter).unwrap(), before);

    // A fusion tool started by the other user fails at once, saying why.
    let dir = tempfile::tempdir().unwrap();
    let fusionctl = peer_copy(dir.path(), "fusionctl");
    let env = format!("{DOMAIN_ENV}={}", domain.domain);
    let started = Instant::now();
    let out = as_peer(&["env", &env, fusionctl.to_str().unwrap(), "state", "--namespace", &domain.namespace]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(started.elapsed() < Duration::from_secs(15), "it hung: {stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("belongs to uid 0") && stderr.contains("one user"), "{stderr}");

    // The daemon and this user's new processes are unaffected.
    let fresh = domain.client();
    let mut reader = fresh.state_subscriber().unwrap();
    assert!(reader.wait_next(Duration::from_secs(5)).unwrap().is_some() || reader.latest().unwrap().is_some());
    assert!(daemon.is_running());
    assert!(daemon.terminate().success());
}

#[test]
fn a_node_counter_planted_by_another_user_is_refused_with_its_owner_not_waited_on() {
    let Some(_) = peer_uid() else { return };
    // Learn the counter's name in one domain, then plant it in another.
    let probe = TestDomain::new("probe");
    let probe_client = probe.client();
    let name = node_counter(&probe).file_name().unwrap().to_string_lossy().into_owned();
    drop(probe_client);
    let target = TestDomain::new("planted");
    let planted = format!("/dev/shm/{}", name.replacen(&probe.prefix, &target.prefix, 1));
    drop(probe);
    let out = as_peer(&["truncate", "-s", "0", &planted]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // The owner as the file says, not as the user table said before: another
    // process on the machine may delete and re-create the user (a new uid) in
    // between, and what matters is that another user owns the file.
    let peer = std::fs::metadata(&planted).unwrap().uid();
    assert_ne!(peer, fusion_shared::permissions::euid(), "planted by another user");

    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("config.toml");
    std::fs::write(&config_path, config()).unwrap();
    let started = Instant::now();
    let out = Command::new("timeout")
        .args(["20", env!("CARGO_BIN_EXE_fusiond"), "run", "--namespace", &target.namespace, "--config"])
        .arg(&config_path)
        .env(DOMAIN_ENV, &target.domain)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(started.elapsed() < Duration::from_secs(15), "fusiond hung: {stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(&planted) && stderr.contains(&format!("belongs to uid {peer}")), "{stderr}");
    std::fs::remove_file(&planted).unwrap();
}

#[test]
fn a_node_counter_open_to_everyone_is_narrowed_to_its_owner() {
    // A plain iceoryx2 process (ipc::Service) makes the counter 0666.
    let domain = TestDomain::new("narrow");
    let config = fusion_shared::service::iceoryx_config(Some(&domain.domain)).unwrap();
    let node =
        iceoryx2::prelude::NodeBuilder::new().config(&config).create::<iceoryx2::prelude::ipc::Service>().unwrap();
    let counter = node_counter(&domain);
    assert_eq!(std::fs::metadata(&counter).unwrap().mode() & 0o777, 0o666);
    let client = domain.client();
    assert_eq!(std::fs::metadata(&counter).unwrap().mode() & 0o777, 0o600);
    drop((client, node));
}
