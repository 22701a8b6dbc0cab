//! Lock-out recovery in the real daemon over real iceoryx2: a filter whose fixes
//! are all gated for `[gating] lockout_ns` re-initialises from the fixes, says so
//! in the health, the snapshot and the log, and live equals replay.

mod common;

use common::live::{Daemon, TestDomain, publish_in_lockstep};
use fusion_shared::snapshot::health;
use fusion_shared::{ImuSample, PositionSample, Sample};

/// 5 s at rest: IMU at 100 Hz, fixes at 10 Hz at the origin, and from 2 s on
/// 500 m east (a jump the filter never saw).
fn jump_stream() -> Vec<Sample> {
    let mut v = Vec::new();
    for i in 0..500u64 {
        let t = 1_000_000_000 + i * 10_000_000;
        v.push(Sample::Imu(ImuSample::new(t, 0, i, [0.0; 3], [0.0; 3])));
        if i % 10 == 5 {
            let x = if i >= 200 { 500.0 } else { 0.0 };
            let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.25];
            v.push(Sample::Position(PositionSample::new(t, 1, i / 10, [x, 0.0, 0.0], cov)));
        }
    }
    v
}

fn config() -> String {
    common::linear_config(Some(0.999)) + "lockout_ns = 1_000_000_000\nlockout_fixes = 5\n"
}

#[test]
fn a_locked_out_filter_reinitialises_from_the_fixes_says_so_and_live_equals_replay() {
    let domain = TestDomain::new("lockout");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let samples = jump_stream();
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    let last = snaps.last().unwrap();
    assert_eq!(last.reinitialisations, 1);
    assert!((last.state()[0] - 500.0).abs() < 0.5, "{:?}", last.state());
    // Fixes 2.05 s to 3.05 s are gated; the one at 3.05 s re-initialises.
    let first_reinit = snaps.iter().position(|s| s.reinitialisations == 1).unwrap();
    assert_eq!(samples[first_reinit].t_ns(), 4_050_000_000);
    assert!(snaps[..first_reinit].iter().all(|s| s.health_reasons & health::REINITIALISED == 0));
    let after = &snaps[first_reinit];
    assert_eq!(after.health, health::DEGRADED);
    assert!(after.health_reason_names().any(|r| r == "re-initialised after a lock-out"), "{:?}", after.health_reasons);
    assert!(daemon.stderr().contains("filter re-initialised from the position fixes"), "{}", daemon.stderr());

    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.jsonl");
    let text: String = samples.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(&input, text).unwrap();
    let (lines, stderr) = common::run_replay(dir.path(), &config(), &input, false);
    let expected = lines.last().unwrap();
    assert_eq!(last.state()[..6], expected.x[..], "live equals replay");
    assert_eq!(last.covariance()[..36], expected.p[..]);
    assert!(stderr.contains("re-initialised 1 times after a lock-out"), "{stderr}");
    // Smoothing succeeds across the re-initialisation and ends where filtering does.
    let (smoothed, _) = common::run_replay(dir.path(), &config(), &input, true);
    assert_eq!(smoothed.last().unwrap().x, expected.x);
    assert!(daemon.terminate().success());
}
