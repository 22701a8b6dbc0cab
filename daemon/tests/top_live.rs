//! `fusionctl top` against a running fusiond, on a pseudo-terminal (`script`):
//! it shows the daemon's sensors and health, and quits on `q`; without a
//! terminal it says so in one line and exits 1.

mod common;

use std::io::{Read, Write};
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain, publish_in_lockstep, workspace_bin};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{ImuSample, PositionSample, Sample};

#[test]
fn the_dashboard_shows_a_running_daemon_and_quits_on_q() {
    let domain = TestDomain::new("top");
    let mut daemon = Daemon::start(&domain, &common::linear_config(Some(0.999)), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let mut samples = Vec::new();
    for k in 0..20u64 {
        samples.push(Sample::Imu(ImuSample::new(1_000_000_000 + k * 10_000_000, 0, k, [0.1, 0.0, 0.0], [0.0; 3])));
    }
    samples.push(Sample::Position(PositionSample::new(
        1_195_000_000,
        1,
        0,
        [0.0; 3],
        [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    )));
    publish_in_lockstep(&client, &mut reader, &samples);

    // A pseudo-terminal made without a terminal around it has no size.
    let command = format!(
        "stty rows 40 cols 160 && {} top --namespace {}",
        workspace_bin("fusionctl").display(),
        domain.namespace
    );
    // In a process group of its own, so that a failing test stops it and its child.
    let mut top = Running(
        Command::new("script")
            .process_group(0)
            .args(["-qfec", &command, "/dev/null"])
            .env(DOMAIN_ENV, &domain.domain)
            .env("TERM", "xterm")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    // The screen as it is drawn, read on a thread of its own.
    let mut stdout = top.0.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = stdout.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let mut screen = String::new();
    let deadline = Instant::now() + Duration::from_secs(20);
    // The terminal gets words with cursor moves between them.
    let expected = ["health", "degraded", "sensors", "imu", "position", "estimate", "p_x", "latency", "quit"];
    while !expected.iter().all(|e| screen.contains(e)) {
        assert!(Instant::now() < deadline, "the dashboard did not show {expected:?}:\n{screen}");
        if let Ok(bytes) = rx.recv_timeout(Duration::from_millis(100)) {
            screen.push_str(&String::from_utf8_lossy(&bytes));
        }
    }
    // fusiond stops while the dashboard and a reader hold its state service:
    // `fusionctl state` says it is not running, and the dashboard says stopped.
    assert!(daemon.terminate().success());
    let state = Command::new(workspace_bin("fusionctl"))
        .args(["state", "--namespace", &domain.namespace])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&state.stderr);
    assert_eq!(state.status.code(), Some(1), "{said}");
    assert!(said.contains("fusiond is not running in namespace"), "{said}");
    let deadline = Instant::now() + Duration::from_secs(20);
    while !screen.contains("STOPPED") {
        assert!(Instant::now() < deadline, "the dashboard did not say fusiond stopped:\n{screen}");
        if let Ok(bytes) = rx.recv_timeout(Duration::from_millis(100)) {
            screen.push_str(&String::from_utf8_lossy(&bytes));
        }
    }
    top.0.stdin.as_mut().unwrap().write_all(b"q").unwrap();
    let status = top.wait_for(Duration::from_secs(10)).expect("fusionctl top did not quit on q");
    assert!(status.success(), "fusionctl top failed: {status}");
    drop(reader);
    drop(client);
    assert!(domain.files().is_empty(), "left in /dev/shm: {:?}", domain.files());
}

/// Without a terminal (a pipe, as from a unit or ssh without `-t`) the dashboard
/// does not start: one line that says why and what to use, exit 1, no panic.
#[test]
fn without_a_terminal_it_says_so_in_one_line() {
    let domain = TestDomain::new("top-tty");
    let out = Command::new(workspace_bin("fusionctl"))
        .args(["top", "--namespace", &domain.namespace])
        .env(DOMAIN_ENV, &domain.domain)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("needs a terminal") && stderr.contains("fusionctl state"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}
