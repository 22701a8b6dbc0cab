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
