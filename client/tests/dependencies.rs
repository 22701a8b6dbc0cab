//! Linking fusion-client must not pull command-line or logging-backend crates, nor
//! the simulators' random-number crates, into the user's process: its normal
//! dependency tree (default features) has none.

#[test]
fn the_library_pulls_no_cli_or_subscriber_crates() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["tree", "--offline", "-p", "fusion-client", "-e", "normal", "--prefix", "none", "--format", "{p}"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let tree = String::from_utf8(out.stdout).unwrap();
    assert!(tree.contains("iceoryx2 "), "the tree was read: {tree}");
    for forbidden in ["clap ", "anyhow ", "tracing-subscriber ", "signal-hook ", "rand_distr ", "rand_chacha "] {
        assert!(!tree.lines().any(|l| l.starts_with(forbidden)), "fusion-client depends on {forbidden}");
    }
}
