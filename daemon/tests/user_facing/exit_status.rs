//! One exit-status policy for every binary (`fusion_shared::exit`): 0 when the
//! job was done, 1 when it failed (one line on stderr, each cause once), 2 for
//! invalid arguments refused before anything started, 3 for `fusionctl state`
//! on a daemon that has published nothing yet. Real binaries, real iceoryx2.

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use crate::common::live::{Daemon, TestDomain, workspace_bin};
use fusion_shared::exit::{FAILURE, NO_STATE_YET, SUCCESS, USAGE};
use fusion_shared::service::DOMAIN_ENV;

/// Runs `bin` with `args` in `domain`: its exit status, stdout and stderr.
fn run(domain: &TestDomain, bin: &PathBuf, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(bin).args(args).env(DOMAIN_ENV, &domain.domain).output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code().expect("exited, not killed"), text(&out.stdout), text(&out.stderr))
}

fn fusiond() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_fusiond"))
}

/// A usage error: status 2 and clap's `error: ...` naming `what`, nothing started.
fn assert_usage(domain: &TestDomain, bin: &PathBuf, args: &[&str], what: &str) {
    let (code, _, err) = run(domain, bin, args);
    assert_eq!(code, i32::from(USAGE), "{args:?}: {err}");
    assert!(err.starts_with("error: ") && err.lines().next().unwrap().contains(what), "{args:?}: {err}");
    assert!(domain.files().is_empty(), "{args:?} started something: {:?}", domain.files());
}

/// A failure: status 1 and exactly one line `<bin>: ...` holding `what` once.
fn assert_failure(out: (i32, String, String), bin: &str, what: &str) {
    let (code, _, err) = out;
    assert_eq!(code, i32::from(FAILURE), "{err}");
    let line = err.lines().last().unwrap_or_default();
    assert!(line.starts_with(&format!("{bin}: ")), "{err}");
    assert_eq!(line.matches(what).count(), 1, "{what:?} not once in {line:?}");
}

#[test]
fn path_like_namespaces_and_bad_values_are_usage_errors_of_every_binary() {
    let domain = TestDomain::new("exit-usage");
    let (sim, ctl, demo) = (workspace_bin("fusion-sim"), workspace_bin("fusionctl"), workspace_bin("fusion-demo"));
    let config = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(config.path(), crate::common::linear_config(None)).unwrap();
    let config = config.path().to_str().unwrap();
    for ns in [".", "..", "../x", ".hidden", "-x"] {
        assert_usage(&domain, &fusiond(), &["run", "--config", config, &format!("--namespace={ns}")], "namespace");
        assert_usage(&domain, &sim, &["run", &format!("--namespace={ns}")], "namespace");
        assert_usage(&domain, &ctl, &["state", &format!("--namespace={ns}")], "namespace");
        assert_usage(&domain, &ctl, &["echo", &format!("--namespace={ns}")], "namespace");
    }
    assert_usage(&domain, &fusiond(), &["run", "--config", config, "--summary-interval", "0"], "seconds");
    assert_usage(&domain, &fusiond(), &["run", "--config", config, "--wait", "busy"], "busy");
    assert_usage(&domain, &sim, &["run", "--imu-mount", "sideways"], "--imu-mount");
    assert_usage(
        &domain,
        &sim,
        &["run", "--magnetometer-rate", "20", "--magnetometer-mount", "up"],
        "--magnetometer-mount",
    );
    assert_usage(
        &domain,
        &sim,
        &["run", "--magnetometer-rate", "20", "--magnetic-disturbance", "3:x:1"],
        "--magnetic-disturbance",
    );
    assert_usage(&domain, &sim, &["run", "--twist-rate", "20", "--twist-noise", "0.1"], "--twist-noise");
    assert_usage(&domain, &sim, &["run", "--twist-rate", "20", "--twist-lever-arm", "1,2"], "--twist-lever-arm");
    assert_usage(&domain, &sim, &["run", "--magnetometer-rate", "20", "--magnetic-field", "3,64"], "--magnetic-field");
    assert_usage(&domain, &sim, &["run", "--pose-rate", "10", "--pose-frame", "30:1,2"], "--pose-frame");
    assert_usage(
        &domain,
        &sim,
        &["run", "--pose-rate", "10", "--localiser-reset", "soon:0:0,0,0"],
        "--localiser-reset",
    );
    assert_usage(&domain, &sim, &["run", "--pose-rate", "10", "--pose-noise", "0.1"], "--pose-noise");
    assert_usage(
        &domain,
        &sim,
        &["run", "--barometer-rate", "20", "--barometer-lever-arm", "1"],
        "--barometer-lever-arm",
    );
    assert_usage(&domain, &sim, &["run", "--imu-ids", "7"], "--imu-ids");
    assert_usage(&domain, &sim, &["record", "--output", "/dev/null", "--lever-arm", "1,2"], "--lever-arm");
    assert_usage(&domain, &ctl, &["record", "--output", "/dev/null", "--duration=-1"], "seconds");
    assert_usage(&domain, &ctl, &["state", "--wait", "soon"], "seconds");
    assert_usage(&domain, &demo, &["--wait", "busy"], "busy");
    assert_usage(&domain, &demo, &["--model", "kalman"], "kalman");
    assert_usage(&domain, &demo, &["--duration", "0"], "seconds");
}

#[test]
fn a_missing_file_is_one_line_with_its_cause_once() {
    let domain = TestDomain::new("exit-missing");
    let os = std::io::Error::from_raw_os_error(2).to_string(); // "No such file or directory (os error 2)"
    let missing = "/nonexistent/fusion.toml";
    assert_failure(run(&domain, &fusiond(), &["run", "--config", missing]), "fusiond", &os);
    assert_failure(run(&domain, &fusiond(), &["check-config", missing]), "fusiond", &os);
    assert_failure(
        run(&domain, &fusiond(), &["replay", "--config", missing, "--input", "/nonexistent/x.jsonl"]),
        "fusiond",
        &os,
    );
    let ctl = workspace_bin("fusionctl");
    assert_failure(run(&domain, &ctl, &["plot", "--input", "/nonexistent/run.mcap"]), "fusionctl", &os);
    let sim = workspace_bin("fusion-sim");
    assert_failure(run(&domain, &sim, &["run", "--input", "/nonexistent/x.jsonl", "--realtime"]), "fusion-sim", &os);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// `fusion-sim run --input` on an empty file or a binary one fails with one
/// line that says so (it published nothing and exited 0, or named only UTF-8).
#[test]
fn an_empty_or_binary_input_is_an_error() {
    let domain = TestDomain::new("exit-empty");
    let dir = tempfile::tempdir().unwrap();
    let (empty, binary) = (dir.path().join("empty.jsonl"), dir.path().join("binary.jsonl"));
    std::fs::write(&empty, "\n\n").unwrap();
    std::fs::write(&binary, [0x89u8, b'M', b'C', b'A', b'P', 0xff, 0xfe, b'\n']).unwrap();
    let sim = workspace_bin("fusion-sim");
    for (file, what) in [(&empty, "no sample in it"), (&binary, "is not text")] {
        let file = file.to_str().unwrap();
        assert_failure(
            run(&domain, &sim, &["run", "--input", file, "--realtime", "--allow-no-daemon"]),
            "fusion-sim",
            what,
        );
    }
    // fusiond replay: an empty file, a magic-only MCAP file and a binary one
    // each say what they are, not "the reasons are above" with none above.
    let magic = dir.path().join("magic.mcap");
    std::fs::write(&magic, b"\x89MCAP0\r\n").unwrap();
    let config = dir.path().join("linear.toml");
    std::fs::write(&config, crate::common::linear_config(None)).unwrap();
    let config = config.to_str().unwrap();
    for (file, what) in [
        (empty.to_str().unwrap(), "the input holds no lines: an empty file"),
        (magic.to_str().unwrap(), "cut off before its first sample"),
        ("/bin/ls", "not a text file"),
    ] {
        let out = run(&domain, &fusiond(), &["replay", "--config", config, "--input", file]);
        assert!(!out.2.contains("reasons are above") && out.2.matches("not UTF-8").count() == 0, "{}", out.2);
        assert_failure(out, "fusiond", what);
    }
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// The same mistake, the same status in every tool: a ROS bag without the
/// configuration that maps its topics is a usage error (2) in `fusiond
/// replay` as in `fusion-sim run`.
#[test]
fn a_bag_without_its_topic_map_is_a_usage_error_in_every_tool() {
    let domain = TestDomain::new("exit-bag-usage");
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("robot.bag");
    std::fs::write(&bag, b"#ROSBAG V2.0\n").unwrap();
    let bag = bag.to_str().unwrap();
    assert_usage(&domain, &fusiond(), &["replay", "--input", bag], "--config");
    assert_usage(&domain, &workspace_bin("fusion-sim"), &["run", "--input", bag], "--config");
}

/// `fusion-sim run --help` names every kind `--position-only` publishes.
#[test]
fn position_only_names_every_kind_it_publishes() {
    let domain = TestDomain::new("exit-help");
    let (code, out, _) = run(&domain, &workspace_bin("fusion-sim"), &["run", "--help"]);
    assert_eq!(code, i32::from(SUCCESS));
    let help: String = out.split("--position-only").nth(1).unwrap().split("\n      --").next().unwrap().into();
    for kind in fusion_shared::SampleKind::ALL.iter().filter(|k| **k != fusion_shared::SampleKind::Imu) {
        assert!(help.contains(kind.name()), "{} not in {help:?}", kind.name());
    }
}

#[test]
fn a_publisher_that_reached_no_daemon_fails_unless_allowed() {
    let domain = TestDomain::new("exit-nodaemon");
    let sim = workspace_bin("fusion-sim");
    let ns = ["--namespace", domain.namespace.as_str()];
    let drive = ["--duration", "0.3", "--start-at-ns", "0"]; // starts at once, lasts 0.3 s
    let args = |extra: &[&'static str]| [&["run"][..], &ns, &drive, extra].concat();
    let out = run(&domain, &sim, &args(&[]));
    assert!(out.2.contains("reached no reader"), "{}", out.2);
    assert_failure(out, "fusion-sim", "--allow-no-daemon");
    let (code, _, err) = run(&domain, &sim, &args(&["--allow-no-daemon"]));
    assert_eq!(code, i32::from(SUCCESS), "{err}");
    // A file too, without --realtime (as the help says): published at its pace.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("few.jsonl");
    let now = fusion_shared::now_ns();
    let lines: String = (0..20u64)
        .map(|k| {
            let s = fusion_shared::ImuSample::new(now + k * 1_000_000, 0, k, [0.0; 3], [0.0; 3]);
            fusion_shared::jsonl::format_sample(&s.into()) + "\n"
        })
        .collect();
    std::fs::write(&file, lines).unwrap();
    let input = ["--input", file.to_str().unwrap()];
    let (code, _, err) = run(&domain, &sim, &[&["run"][..], &ns, &input, &["--allow-no-daemon"]].concat());
    assert_eq!(code, i32::from(SUCCESS), "{err}");
    assert!(err.contains("published 20 samples"), "{err}");
    assert_failure(run(&domain, &sim, &[&["run"][..], &ns, &input].concat()), "fusion-sim", "is not running");

    // With a daemon, the same run is done: every sample reached it.
    let mut daemon = Daemon::start(&domain, &crate::common::linear_config(None), "event");
    let (code, _, err) = run(&domain, &sim, &args(&[]));
    assert_eq!(code, i32::from(SUCCESS), "{err}");
    assert!(!err.contains("reached no reader"), "{err}");
    assert_eq!(daemon.terminate().code(), Some(0), "SIGTERM is a clean stop");
}

#[test]
fn fusionctl_state_tells_no_daemon_from_no_snapshot_yet() {
    let domain = TestDomain::new("exit-state");
    let ctl = workspace_bin("fusionctl");
    let state = ["state", "--namespace", domain.namespace.as_str(), "--wait", "0.2"];
    assert_failure(run(&domain, &ctl, &state), "fusionctl", "not running");

    let mut daemon = Daemon::start(&domain, &crate::common::linear_config(None), "event");
    let (code, out, err) = run(&domain, &ctl, &state);
    assert_eq!(code, i32::from(NO_STATE_YET), "{out}{err}");
    assert!(out.is_empty() && err.lines().count() == 1 && err.contains("no snapshot yet"), "{err}");
    // `echo` says so too, once, instead of waiting in silence; ended by its
    // --idle-timeout with no snapshot, it says that and exits 3 as `state`.
    let echo = ["echo", "--namespace", domain.namespace.as_str(), "--idle-timeout", "3"];
    let (code, out, err) = run(&domain, &ctl, &echo);
    assert_eq!(code, i32::from(NO_STATE_YET), "{err}");
    assert!(out.is_empty() && err.matches("has published no snapshot yet").count() == 1, "{err}");
    assert!(err.contains("published no snapshot in 3.0 s of --idle-timeout"), "{err}");
    let echo = ["echo", "--namespace", domain.namespace.as_str(), "--idle-timeout", "1"];
    let (code, _, err) = run(&domain, &ctl, &echo);
    assert_eq!(code, i32::from(NO_STATE_YET), "{err}");
    assert!(err.contains("published no snapshot in 1.0 s of --idle-timeout"), "{err}");

    // One sample: now there is a state to print.
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.publish(1_000_000, [0.0; 3], [0.0; 3]).unwrap();
    assert!(reader.wait_next(Duration::from_secs(5)).unwrap().is_some());
    let (code, out, err) = run(&domain, &ctl, &state);
    assert_eq!(code, i32::from(SUCCESS), "{err}");
    assert!(out.contains("model linear") && out.contains("health: initialising"), "{out}");
    drop((imu, reader, client));

    // SIGINT stops the event-mode daemon cleanly.
    assert_eq!(daemon.stop_with("-INT").code(), Some(0), "{}", daemon.stderr());
}

#[test]
fn the_demo_runs_and_reports_its_sensors_rates_and_latency() {
    let demo = workspace_bin("fusion-demo");
    let domain = TestDomain::new("exit-demo");
    let (code, out, err) = run(&domain, &demo, &["--duration", "1.5"]);
    assert_eq!(code, i32::from(SUCCESS), "{out}{err}");
    // The rates it prints are the ones it measured, and the IMU is not "fused".
    assert!(out.contains("fusion-sim --imu-only (400 Hz)"), "{out}");
    let imu = out.lines().find(|l| l.trim_start().starts_with("imu 0")).unwrap_or_else(|| panic!("{out}"));
    assert!(imu.contains("imu 0 (400 Hz)") && imu.contains("propagated") && !imu.contains("fused"), "{imu}");
    assert!(out.contains("position 1 (10 Hz)") && out.contains("velocity 2 (10 Hz)"), "{out}");
    assert!(out.contains("busy-polling reader"), "{out}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}
