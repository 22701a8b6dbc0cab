//! An application outside the workspace, built against `fusion-client` by path
//! as a user builds one (`tests/user_facing/app/`), reads a live fusiond's position,
//! velocity, attitude and health with the typed accessors only; what it prints
//! is the raw snapshot's entries, bit for bit.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::live::{Daemon, TestDomain, workspace_bin};
use fusion_shared::SampleKind;
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::snapshot::health;

const SEED: u64 = 5;

/// The application's project in `dir`: its manifest with the client's path,
/// its source, and the workspace's lock file (the same dependency versions, so
/// it builds offline from what the workspace fetched).
fn write_app(dir: &Path) {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = here.parent().unwrap();
    let manifest = std::fs::read_to_string(here.join("tests/user_facing/app/Cargo.toml.in")).unwrap();
    std::fs::write(dir.join("Cargo.toml"), manifest.replace("@CLIENT@", root.join("client").to_str().unwrap()))
        .unwrap();
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::copy(here.join("tests/user_facing/app/src/main.rs"), dir.join("src/main.rs")).unwrap();
    std::fs::copy(root.join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
}

/// Builds the application (cargo's output on the terminal, so the build is
/// seen, not a silent wait) into `target/external-app` (unoptimised, without
/// debug info: the quickest build of its dependencies); returns the binary.
fn build_app(dir: &Path) -> PathBuf {
    let target = PathBuf::from(env!("CARGO_BIN_EXE_fusiond")).parent().unwrap().parent().unwrap().join("external-app");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let _ = writeln!(std::io::stderr(), "external_app: building an application against fusion-client by path");
    let status = Command::new(cargo)
        .args(["build", "--offline", "--manifest-path"])
        .arg(dir.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", &target)
        // Cargo's settings for the workspace's own build do not apply here.
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .stdout(Stdio::inherit())
        .stderr(Stdio::inherit())
        .status()
        .unwrap();
    assert!(status.success(), "the application did not build");
    target.join("debug/fusion-reader-app")
}

/// `key value` lines.
fn field<'a>(out: &'a str, key: &str) -> &'a str {
    out.lines()
        .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix(' ')))
        .unwrap_or_else(|| panic!("no {key} in {out}"))
}

fn floats(text: &str) -> Vec<f64> {
    text.trim_matches(|c| c == '[' || c == ']').split(", ").map(|v| v.parse().unwrap()).collect()
}

#[test]
fn an_application_outside_the_workspace_reads_the_state_with_accessors() {
    let project = tempfile::tempdir().unwrap();
    write_app(project.path());
    let app = build_app(project.path());

    let domain = TestDomain::new("external-app");
    let mut daemon = Daemon::start(&domain, &crate::common::ins_config_at_truth(SEED), "event");
    let sim = Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--seed", &SEED.to_string(), "--duration", "2"])
        .args(["--imu-output", "body", "--imu-rate", "200", "--accel-noise", "0.283", "--gyro-noise", "0.0141"])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));

    // Once every stream is stale the daemon publishes nothing more: the latest
    // snapshot stays what the application will read.
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let stale = health::stale(SampleKind::Imu) | health::stale(SampleKind::Position);
    let deadline = Instant::now() + Duration::from_secs(20);
    let raw = loop {
        let s = match reader.wait_next(Duration::from_millis(100)).unwrap() {
            Some(s) => Some(*s),
            None => reader.latest().unwrap().copied(),
        };
        if let Some(s) = s.filter(|s| s.health_reasons & stale == stale) {
            break s;
        }
        assert!(Instant::now() < deadline, "the streams never went stale: {}", daemon.stderr());
    };

    let out = Command::new(&app).arg(&domain.namespace).env(DOMAIN_ENV, &domain.domain).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(field(&text, "seq"), raw.seq.to_string(), "{text}");
    assert_eq!(field(&text, "model"), "ins");
    assert_eq!(floats(field(&text, "position")), raw.x[0..3]);
    assert_eq!(floats(field(&text, "velocity")), raw.x[3..6]);
    assert_eq!(floats(field(&text, "attitude")), raw.x[6..10]);
    assert_eq!(floats(field(&text, "gyro_bias")), raw.x[13..16]);
    let sd = |i: usize| raw.cov[i * 15 + i].sqrt();
    assert_eq!(floats(field(&text, "position_std")), [sd(0), sd(1), sd(2)]);
    assert_eq!(floats(field(&text, "velocity_std")), [sd(3), sd(4), sd(5)]);
    // The drive is a car on a road: level within a few degrees.
    let rpy = floats(field(&text, "roll_pitch_yaw_deg"));
    assert!(rpy[0].abs() < 10.0 && rpy[1].abs() < 10.0 && rpy[2].abs() <= 180.0, "{rpy:?}");
    let reasons: Vec<&str> = raw.health_reason_names().collect();
    assert_eq!(field(&text, "health"), format!("degraded ({})", reasons.join(", ")));
    assert!(reasons.contains(&"imu stale") && reasons.contains(&"position stale"), "{reasons:?}");

    drop((reader, client));
    assert_eq!(daemon.terminate().code(), Some(0));
}
