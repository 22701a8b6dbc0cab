//! `fusion-sim run` does not wait silently or claim success: a file whose every
//! sample fusiond refuses ends in a bounded time with the reason and exit 1; a
//! file of garbage is an error; and a run with readers but no fusiond (a
//! recorder alone) is not taken for one that reached fusiond.

mod common;

use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::snapshot::rejection;
use fusion_shared::{ImuSample, Sample};

fn sim(domain: &TestDomain, args: &[&str]) -> Output {
    Command::new("timeout")
        .arg("60")
        .arg(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace])
        .args(args)
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap()
}

/// A file stamped on another clock (a recording's, from 1 ms of it): fusion-sim
/// moves its stamps onto this host's clock (fusiond would refuse them all as
/// too far in the past) and says so; every sample is taken. Its samples
/// beyond an IMU's range are all refused: fusion-sim stops within a few
/// seconds (not 50 ms per sample of the file), says why (from fusiond's
/// refusal counters) and exits 1; and every place a user looks says why: the
/// snapshot (published though no sample was processed), `fusionctl state`,
/// one warning in fusiond's log naming the setting, and the summary line.
#[test]
fn a_file_fusiond_refuses_entirely_ends_with_the_reason() {
    let domain = TestDomain::new("sim-refused");
    // The default validation (a [validation] table keeps the test harness from
    // opening the past-timestamp check up).
    let config = format!("{}\n[validation]\nmax_past_ns = 5_000_000_000\n", common::linear_config(Some(0.999)));
    let mut daemon = Daemon::start_with(&domain, &config, &["--wait", "event", "--summary-interval", "0.5"]);
    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str, n: u64, accel: f64| {
        let path = dir.path().join(name);
        let lines: String = (0..n)
            .map(|k| {
                let s = Sample::Imu(ImuSample::new(1_000_000 + k * 5_000_000, 0, k, [accel, 0.0, 0.0], [0.0; 3]));
                fusion_shared::jsonl::format_sample(&s) + "\n"
            })
            .collect();
        std::fs::write(&path, lines).unwrap();
        path
    };
    let good = file("recorded.jsonl", 100, 0.1);
    let out = sim(&domain, &["--input", good.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("is stamped on another clock") && stderr.contains("moved onto this host's clock"));
    assert!(stderr.contains("published 100 samples") && stderr.contains("0 without a snapshot"), "{stderr}");

    let path = file("beyond.jsonl", 2000, 1000.0);
    let started = Instant::now();
    let out = sim(&domain, &["--input", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(started.elapsed() < Duration::from_secs(20), "it gave up after {:?}", started.elapsed());
    assert!(stderr.contains("answered none") && stderr.contains("its refusal counters"), "{stderr}");
    assert!(stderr.contains("beyond the sensor range: ") && stderr.contains("accel_range_mps2"), "{stderr}");

    // The snapshot says how many and why (the last refusals' one within
    // REFUSAL_SNAPSHOT_NS).
    std::thread::sleep(Duration::from_millis(500));
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let snap = match reader.latest().unwrap() {
        Some(s) => *s,
        None => *reader.wait_next(Duration::from_secs(5)).unwrap().expect("a snapshot of the refusals"),
    };
    let refused = snap.rejections[rejection::OUT_OF_RANGE as usize];
    assert!(refused > 0 && snap.rejected() == refused, "{:?}", snap.rejections);
    drop((reader, client));
    let state = Command::new(workspace_bin("fusionctl"))
        .args(["state", "--namespace", &domain.namespace])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&state.stdout);
    assert!(state.status.success(), "{text}{}", String::from_utf8_lossy(&state.stderr));
    assert!(text.contains(&format!("refused in validation since start: {refused} samples")), "{text}");
    assert!(text.contains(&format!("{refused} beyond the sensor range (from imu 0): ")), "{text}");
    assert!(text.contains("accel_range_mps2"), "{text}");
    assert!(daemon.terminate().success());
    let log = daemon.stderr();
    let warnings: Vec<&str> = log.lines().filter(|l| l.contains("refusing samples of")).collect();
    assert_eq!(warnings.len(), 1, "one warning for imu 0 and its reason:\n{log}");
    assert!(warnings[0].contains("imu 0: beyond the sensor range") && warnings[0].contains("accel_range_mps2"));
    assert!(log.contains("(beyond the sensor range "), "the summary line names the reason:\n{log}");
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// A file stamped on another clock with two samples stamped no time among
/// its own (`u64::MAX`, an hour ahead: a driver's garbage): fusion-sim does
/// not sleep until them, it sends them at once, out of pace, and fusiond
/// refuses them by its clock. Nothing is counted lost: a sample withheld
/// would have been a gap in the IMU's sequence.
#[test]
fn samples_stamped_no_time_in_a_file_are_sent_for_fusiond_to_refuse_not_waited_for() {
    let domain = TestDomain::new("sim-notime");
    let config = format!("{}\n[validation]\nmax_past_ns = 5_000_000_000\n", common::linear_config(Some(0.999)));
    let mut daemon = Daemon::start_with(&domain, &config, &["--wait", "event"]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no-time.jsonl");
    let hour = 3_600_000_000_000;
    let lines: String = (0..200u64)
        .map(|k| {
            let t = match k {
                80 => u64::MAX,
                140 => 1_000_000 + k * 5_000_000 + hour,
                _ => 1_000_000 + k * 5_000_000,
            };
            fusion_shared::jsonl::format_sample(&Sample::Imu(ImuSample::new(t, 0, k, [0.1, 0.0, 0.0], [0.0; 3]))) + "\n"
        })
        .collect();
    std::fs::write(&path, lines).unwrap();
    let out = sim(&domain, &["--input", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("2 samples stamped more than [validation] max_jump_ns ahead of the others"), "{stderr}");
    assert!(stderr.contains("published 200 samples"), "{stderr}");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let snap = match reader.latest().unwrap() {
        Some(s) => *s,
        None => *reader.wait_next(Duration::from_secs(5)).unwrap().expect("a snapshot"),
    };
    let imu = snap.sensors[0].counts;
    assert_eq!((imu.received, imu.invalid, imu.lost), (200, 2, 0), "{imu:?}");
    assert_eq!(snap.rejections[rejection::FUTURE_TIMESTAMP as usize], 2, "{:?}", snap.rejections);
    drop((reader, client));
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// A file with no sample in it publishes nothing and says so: exit 1.
#[test]
fn a_file_of_garbage_is_an_error() {
    let domain = TestDomain::new("sim-garbage");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("garbage.jsonl");
    std::fs::write(&path, "not json\n{\"imu\": 3}\n\u{1}\u{2}\n").unwrap();
    let out = sim(&domain, &["--input", path.to_str().unwrap(), "--realtime", "--allow-no-daemon"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("none of its 3 lines is a sample"), "{stderr}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// Only a reader of the samples (a recorder) is there, no fusiond: the run is
/// not taken for one that reached fusiond.
#[test]
fn readers_without_fusiond_are_not_a_daemon() {
    let domain = TestDomain::new("sim-nodaemon");
    let client = domain.client();
    let mut recorder = client.sample_subscriber().unwrap();
    let mut sim = Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--duration", "3", "--imu-rate", "100"])
        .args(["--position-rate", "5"])
        .env(DOMAIN_ENV, &domain.domain)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Read as a recorder does, while it publishes.
    let (mut read, deadline) = (0u64, Instant::now() + Duration::from_secs(30));
    while sim.try_wait().unwrap().is_none() && Instant::now() < deadline {
        while recorder.try_next().unwrap().is_some() {
            read += 1;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = sim.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(read > 100, "the recorder read {read} samples (what the old check took for a daemon): {stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("no fusiond received the samples"), "{stderr}");
    drop((recorder, client));
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}
