//! The demo's output into a file or a pipe (a log): plain lines, no carriage
//! returns that would collapse its status lines into one.

mod common;

use std::process::Command;

use common::live::{TestDomain, workspace_bin};
use fusion_shared::service::DOMAIN_ENV;

#[test]
fn into_a_pipe_the_demo_writes_plain_lines() {
    let domain = TestDomain::new("demo-log");
    workspace_bin("fusiond");
    workspace_bin("fusion-sim");
    workspace_bin("fusionctl");
    let out = Command::new(workspace_bin("fusion-demo"))
        .args(["--duration", "6"])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(!stdout.contains('\r'), "{stdout:?}");
    let status: Vec<&str> = stdout.lines().filter(|l| l.starts_with("  t ")).collect();
    assert!(status.len() >= 2 && status.iter().all(|l| l.len() < 200), "{status:?}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// `./demo` says what it builds before cargo starts (a first build takes
/// minutes), lets cargo show its progress (no `--quiet`), and builds the four
/// binaries it runs and nothing else. A stand-in `cargo` on the PATH records
/// its arguments; the demo binary is not run.
#[test]
fn the_demo_script_says_what_it_builds_and_shows_cargos_progress() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("checkout");
    std::fs::create_dir_all(&root).unwrap();
    std::fs::copy(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../demo"), root.join("demo")).unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let args = dir.path().join("args");
    let fake = format!("#!/bin/sh\necho \"$@\" > {}\nexit 7\n", args.display());
    std::fs::write(bin.join("cargo"), fake).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(bin.join("cargo"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let out = Command::new("sh").arg(root.join("demo")).env("PATH", path).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(7), "cargo's failure is the demo's: {stdout}");
    assert!(stdout.starts_with("demo: building fusiond and its tools") && stdout.contains("minutes"), "{stdout}");
    let args = std::fs::read_to_string(args).unwrap();
    assert!(args.starts_with("build --release") && !args.contains("--quiet"), "{args}");
    for bin in ["fusiond", "fusion-demo", "fusion-sim", "fusionctl"] {
        assert!(args.contains(&format!("--bin {bin}")), "{args}");
    }
    assert_eq!(args.matches("--bin").count(), 4, "{args}");
}
