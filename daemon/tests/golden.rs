//! Golden outputs: `fusiond replay` of fixed inputs must write these files byte for
//! byte, filtered and smoothed, for both models. Any change of an estimate, however
//! small, shows up here as a failing test and, once regenerated, as a diff.
//!
//! Regenerate them (only for a change that is meant to move the estimates):
//!
//! ```sh
//! FUSION_BLESS=1 cargo test -p fusion-daemon --test golden
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs the real `fusiond replay` and compares its output with the golden file.
fn check(config: &str, input: &str, golden: &str, smooth: bool) {
    let root = root();
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.jsonl");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fusiond"));
    cmd.arg("replay").arg("--config").arg(root.join(config)).arg("--input").arg(root.join(input));
    cmd.arg("--output").arg(&output);
    if smooth {
        cmd.arg("--smooth");
    }
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "fusiond replay failed: {}", String::from_utf8_lossy(&out.stderr));
    let got = std::fs::read_to_string(&output).unwrap();
    let golden_path = root.join(golden);
    if std::env::var_os("FUSION_BLESS").is_some() {
        std::fs::write(&golden_path, &got).unwrap();
        return;
    }
    let expected = std::fs::read_to_string(&golden_path)
        .unwrap_or_else(|e| panic!("{}: {e} (FUSION_BLESS=1 writes it)", golden_path.display()));
    if got == expected {
        return;
    }
    let (g, e): (Vec<&str>, Vec<&str>) = (got.lines().collect(), expected.lines().collect());
    let first = g.iter().zip(&e).position(|(a, b)| a != b).unwrap_or(g.len().min(e.len()));
    panic!(
        "{golden}: output differs from line {} on ({} lines written, {} expected)\n got: {}\nwant: {}",
        first + 1,
        g.len(),
        e.len(),
        g.get(first).copied().unwrap_or("<end>").chars().take(400).collect::<String>(),
        e.get(first).copied().unwrap_or("<end>").chars().take(400).collect::<String>(),
    );
}

#[test]
fn linear_drive_filtered() {
    check("examples/linear.toml", "examples/drive.jsonl", "daemon/tests/golden/linear.filtered.jsonl", false);
}

#[test]
fn linear_drive_smoothed() {
    check("examples/linear.toml", "examples/drive.jsonl", "daemon/tests/golden/linear.smoothed.jsonl", true);
}

#[test]
fn ins_drive_filtered() {
    check(
        "daemon/tests/golden/ins.toml",
        "daemon/tests/golden/ins_drive.jsonl",
        "daemon/tests/golden/ins.filtered.jsonl",
        false,
    );
}

#[test]
fn ins_drive_smoothed() {
    check(
        "daemon/tests/golden/ins.toml",
        "daemon/tests/golden/ins_drive.jsonl",
        "daemon/tests/golden/ins.smoothed.jsonl",
        true,
    );
}
