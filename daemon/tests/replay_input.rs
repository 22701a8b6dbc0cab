//! `fusiond replay` on input that is not what its name says.

mod common;

use std::process::Command;

/// Runs `fusiond replay` (the linear config) on a file `name` holding
/// `content`; its exit status and stderr.
fn replay_file(name: &str, content: &str) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.toml");
    std::fs::write(&config, common::linear_config(None)).unwrap();
    let input = dir.path().join(name);
    std::fs::write(&input, content).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(&config)
        .arg("--input")
        .arg(&input)
        .output()
        .unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// A file named `.mcap` that is not MCAP is refused as such, not read as JSON
/// lines (which reported every line invalid).
#[test]
fn a_garbage_mcap_is_refused_as_not_mcap() {
    let (code, stderr) = replay_file("run.mcap", "{\"imu\": {\"t_ns\": 1}}\ngarbage\n");
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("named .mcap but not an MCAP file"), "{stderr}");
    assert!(!stderr.contains("read 2 lines"), "{stderr}");
}

/// A JSON-lines file of nothing but garbage: every line's reason is shown (it
/// said only "no sample could be processed (3 lines read)").
#[test]
fn an_all_garbage_file_gets_every_lines_reason() {
    let (code, stderr) = replay_file("garbage.jsonl", "not json\n{\"imu\": 3}\n\u{1}\u{2}\n");
    assert_eq!(code, Some(1), "{stderr}");
    for line in ["line 1: expected value", "line 2: invalid type", "line 3: expected value"] {
        assert!(stderr.contains(line), "{line}: {stderr}");
    }
    assert!(stderr.contains("no sample could be processed (3 lines read; the reasons are above)"), "{stderr}");
}
