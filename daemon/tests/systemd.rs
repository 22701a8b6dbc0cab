//! fusiond as a systemd `Type=notify` service, against a fake service manager: a
//! Unix datagram socket passed as `NOTIFY_SOCKET`, as systemd does. READY once
//! the services are open, WATCHDOG from the turning fusion loop (and none once
//! it stalls), STOPPING on shutdown; `check-config`; logs fit for journald.

mod common;

use std::os::unix::net::UnixDatagram;
use std::process::Command;
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain};

/// The service manager's end of `NOTIFY_SOCKET`.
struct FakeManager {
    socket: UnixDatagram,
    path: std::path::PathBuf,
    _dir: tempfile::TempDir,
}

impl FakeManager {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notify");
        let socket = UnixDatagram::bind(&path).unwrap();
        Self { socket, path, _dir: dir }
    }

    /// The environment systemd gives a service with `WatchdogSec=` of `watchdog_ms`.
    fn env(&self, watchdog_ms: u64) -> Vec<(&'static str, String)> {
        vec![("NOTIFY_SOCKET", self.path.display().to_string()), ("WATCHDOG_USEC", (watchdog_ms * 1000).to_string())]
    }

    /// The next message, waiting at most `timeout`.
    fn recv(&self, timeout: Duration) -> Option<String> {
        self.socket.set_read_timeout(Some(timeout)).unwrap();
        let mut buf = [0u8; 4096];
        match self.socket.recv(&mut buf) {
            Ok(n) => Some(String::from_utf8(buf[..n].to_vec()).unwrap()),
            // A signal to this process (a child's end) interrupts the wait: none yet.
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) =>
            {
                None
            }
            Err(e) => panic!("notify socket: {e}"),
        }
    }

    /// Waits (at most 20 s) for a message with the line `line`; returns the
    /// messages before it.
    fn wait_for(&self, line: &str) -> Vec<String> {
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut before = Vec::new();
        while Instant::now() < deadline {
            if let Some(m) = self.recv(Duration::from_millis(100)) {
                if m.lines().any(|l| l == line) {
                    return before;
                }
                before.push(m);
            }
        }
        panic!("no {line} within 20 s; got {before:?}");
    }
}

fn start(domain: &TestDomain, manager: &FakeManager, watchdog_ms: u64, args: &[&str]) -> Daemon {
    let env = manager.env(watchdog_ms);
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    Daemon::start_with_env(domain, &common::linear_config(None), args, &env)
}

/// Publishes `n` IMU samples, 1 ms apart; the publisher stays connected while
/// the result lives (samples of a gone publisher may never be taken).
fn publish_imu(domain: &TestDomain, n: u64) -> fusion_client::ImuPublisher {
    let client = domain.client();
    let mut imu = client.imu_publisher(0).unwrap();
    for k in 0..n {
        imu.publish(1_000_000_000 + k * 1_000_000, [0.1, 0.0, 0.0], [0.0; 3]).unwrap();
    }
    imu
}

#[test]
fn ready_then_watchdog_from_the_loop_then_stopping() {
    let domain = TestDomain::new("systemd");
    let manager = FakeManager::new();
    let mut daemon = start(&domain, &manager, 100, &["--wait", "event"]);

    // READY first, once the services are open (the daemon's readers can connect).
    let first = manager.recv(Duration::from_secs(20)).expect("a message");
    assert!(first.lines().any(|l| l == "READY=1"), "{first:?}");
    assert!(first.contains(&format!("STATUS=fusing in namespace {}", domain.namespace)), "{first:?}");

    // WATCHDOG=1 keeps coming while the loop turns, idle or busy.
    for round in 0..2 {
        let _imu = (round == 1).then(|| publish_imu(&domain, 200));
        for _ in 0..5 {
            let before = manager.wait_for("WATCHDOG=1");
            assert!(before.is_empty(), "only watchdog messages while running: {before:?}");
        }
    }

    assert!(daemon.terminate().success());
    let before = manager.wait_for("STOPPING=1");
    assert!(before.iter().all(|m| m == "WATCHDOG=1\n"), "{before:?}");
    // stderr is a file here: plain lines, no colour escapes.
    let log = daemon.stderr();
    assert!(log.contains("fusiond running") && !log.contains('\x1b'), "{log}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

#[test]
fn a_stalled_loop_stops_the_watchdog() {
    let domain = TestDomain::new("systemd-stall");
    let manager = FakeManager::new();
    let mut daemon = start(&domain, &manager, 100, &["--wait", "event", "--fault-stall-after", "50"]);
    manager.wait_for("READY=1");
    manager.wait_for("WATCHDOG=1");

    let _imu = publish_imu(&domain, 100);
    let deadline = Instant::now() + Duration::from_secs(20);
    while !daemon.stderr().contains("fusion loop stalls") {
        assert!(Instant::now() < deadline, "the loop did not stall: {}", daemon.stderr());
        std::thread::sleep(Duration::from_millis(10));
    }
    // At most one message was on its way when the loop stalled; then silence
    // for 10 watchdog periods, while the process is up.
    while manager.recv(Duration::from_millis(300)).is_some() {}
    assert_eq!(manager.recv(Duration::from_secs(1)), None, "a stalled loop still pets the watchdog");
    assert!(daemon.is_running());

    // Shutdown still works and says so.
    assert!(daemon.terminate().success());
    manager.wait_for("STOPPING=1");
}

#[test]
fn check_config_validates_and_exits() {
    let dir = tempfile::tempdir().unwrap();
    let check = |text: &str| {
        let path = dir.path().join("fusiond.toml");
        std::fs::write(&path, text).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_fusiond")).arg("check-config").arg(&path).output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let default = Command::new(env!("CARGO_BIN_EXE_fusiond")).arg("print-config").output().unwrap().stdout;
    let default = String::from_utf8(default).unwrap();
    let (code, out, _) = check(&default);
    assert_eq!(code, Some(0));
    assert!(out.ends_with(": valid (model linear, form joseph)\n"), "{out}");

    let (code, out, err) = check(&default.replace("probability = 0.999", "probability = 1.5"));
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(out.is_empty() && err.starts_with("fusiond: ") && err.contains("probability"), "{err}");
}

/// The unit file of `deploy/systemd`: a notify service with a watchdog whose
/// commands work as written (with this build's fusiond and a config of its own
/// in place of the installed paths), and `systemd-analyze verify` has nothing
/// to say about it where systemd is installed.
#[test]
fn the_unit_file_runs_what_it_says() {
    let unit_path = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/systemd/fusiond.service");
    let unit = std::fs::read_to_string(unit_path).unwrap();
    for line in ["Type=notify", "NotifyAccess=main", "WatchdogSec=2s", "Restart=on-failure", "PrivateTmp=no"] {
        assert!(unit.lines().any(|l| l == line), "{line} missing");
    }
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("fusiond.toml");
    let default = Command::new(env!("CARGO_BIN_EXE_fusiond")).arg("print-config").output().unwrap().stdout;
    std::fs::write(&config, default).unwrap();
    let local = |l: &str| {
        l.replace("/usr/local/bin/fusiond", env!("CARGO_BIN_EXE_fusiond"))
            .replace("/etc/fusiond/fusiond.toml", config.to_str().unwrap())
    };
    let command = |key: &str| {
        let line = unit.lines().find_map(|l| l.strip_prefix(key)).unwrap_or_else(|| panic!("no {key}"));
        local(line).split_whitespace().map(str::to_string).collect::<Vec<_>>()
    };
    let pre = command("ExecStartPre=");
    let out = Command::new(&pre[0]).args(&pre[1..]).output().unwrap();
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("valid"), "{out:?}");
    let start = command("ExecStart=");
    assert_eq!(start[1..3], ["run".to_string(), "--config".to_string()]);

    let verify_dir = tempfile::tempdir().unwrap();
    let local_unit = verify_dir.path().join("fusiond.service");
    std::fs::write(&local_unit, local(&unit).replace("User=fusion\n", "").replace("Group=fusion\n", "")).unwrap();
    match Command::new("systemd-analyze").arg("verify").arg(&local_unit).output() {
        Ok(out) => {
            let said = String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
            assert!(out.status.success() && said.trim().is_empty(), "systemd-analyze verify: {said}");
        }
        Err(e) => eprintln!("systemd-analyze not installed ({e}): the unit's syntax is not verified here"),
    }
    // The sandbox: `systemd-analyze security` rates the unit safe (it rated it
    // 8.7 EXPOSED without one), and its documentation is a path the install
    // steps put there.
    if let Ok(out) = Command::new("systemd-analyze").args(["security", "--offline=yes"]).arg(&local_unit).output() {
        let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
        let level: f64 = said
            .lines()
            .find_map(|l| l.split("Overall exposure level for fusiond.service: ").nth(1))
            .and_then(|l| l.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no exposure level in: {said}"));
        assert!(level <= 2.0, "exposure {level}: {said}");
    }
    let docs = unit.lines().find_map(|l| l.strip_prefix("Documentation=file:")).expect("a Documentation= file");
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/systemd.md")).unwrap();
    assert!(guide.contains(&format!("docs/systemd.md {docs}")), "the guide installs {docs}");
    for line in ["RestrictAddressFamilies=AF_UNIX", "CapabilityBoundingSet=", "SystemCallFilter=@system-service"] {
        assert!(unit.lines().any(|l| l == line), "{line} missing");
    }
}
