//! The estimator stays a library without IO: its dependencies are the wire
//! types (`fusion-shared`, without its JSON, MCAP and ROS features), linear
//! algebra, statistics, configuration reading and logging. Recording formats,
//! command lines, progress bars and the service manager are the daemon's.

use std::collections::BTreeSet;

/// Every dependency the estimator may have.
const ALLOWED: [&str; 8] =
    ["fusion-shared", "multiversion", "nalgebra", "serde", "statrs", "thiserror", "toml", "tracing"];

#[test]
fn the_estimator_depends_on_no_io_crate() {
    let manifest = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    let manifest: toml::Table = manifest.parse().unwrap();
    let deps = manifest["dependencies"].as_table().expect("a [dependencies] table");
    let names: BTreeSet<&str> = deps.keys().map(String::as_str).collect();
    let extra: Vec<&&str> = names.iter().filter(|n| !ALLOWED.contains(n)).collect();
    assert!(extra.is_empty(), "fusion-core depends on {extra:?}: IO belongs to fusion-daemon");
    for forbidden in ["mcap", "clap", "indicatif", "sd-notify", "iceoryx2", "memmap2", "serde_json"] {
        assert!(!names.contains(forbidden), "{forbidden}");
    }
    let shared = deps["fusion-shared"].as_table().expect("fusion-shared.workspace = true");
    assert!(shared.get("features").is_none(), "fusion-shared's JSON, MCAP and ROS features are the daemon's");
}
