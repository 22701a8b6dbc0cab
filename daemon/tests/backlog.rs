//! A backlog is drained in timestamp order across the kinds: a daemon that was
//! stopped (SIGSTOP) while its publishers went on, and a burst of 15 s of
//! samples published at once, cost no rewind and lose nothing, and the
//! estimate is the one of processing the samples in time order (replay), bit
//! for bit, run after run. (The flooding test in `hostile_peers.rs` checks
//! that the per-publisher fairness still holds within a turn.)

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, snapshot_of, workspace_bin};
use fusion_client::SensorPublishers;
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{Sample, SampleKind, StateSnapshot};

/// A 15 s drive: an IMU at 100 Hz and fixes at 1 Hz (1501 and 16, both ends), in time order.
fn drive() -> Vec<Sample> {
    let mut c = ScenarioConfig { seed: 33, duration_s: 15.0, ..Default::default() };
    c.imu.rate_hz = 100.0;
    c.position.rate_hz = 1.0;
    let mut samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    samples.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    samples
}

/// Publishes `samples` all at once into a stopped fusiond, lets it go on, and
/// returns the snapshot of the last one.
fn burst(tag: &str, samples: &[Sample]) -> StateSnapshot {
    let domain = TestDomain::new(tag);
    let mut daemon = Daemon::start(&domain, &common::linear_config(Some(0.999)), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut publishers = SensorPublishers::all(&client).unwrap();
    daemon.signal("-STOP");
    for s in samples {
        publishers.publish(*s).unwrap().expect("a publisher of every kind");
    }
    daemon.signal("-CONT");
    let last = snapshot_of(&mut reader, samples.last().unwrap());
    drop((reader, publishers, client));
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
    last
}

#[test]
fn a_burst_is_fused_in_time_order_and_equals_replay_run_after_run() {
    let samples = drive();
    let count = |kind: u32| samples.iter().filter(|s| s.kind() as u32 == kind).count() as u64;
    assert!(count(SampleKind::Imu as u32) > 1500 && count(SampleKind::Position as u32) > 15);
    let first = burst("burst-a", &samples);
    assert_eq!(first.sensor_count, 2);
    for row in first.sensor_counters() {
        let n = row.counts;
        assert_eq!((n.received, n.processed), (count(row.kind), count(row.kind)), "{row:?}");
        assert_eq!((n.late, n.too_late, n.lost), (0, 0, 0), "a backlog costs no rewind: {row:?}");
    }
    assert_eq!(first.rewinds, 0);
    let second = burst("burst-b", &samples);
    assert_eq!(first.state(), second.state(), "two runs of the same burst");
    assert_eq!(first.covariance(), second.covariance());

    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("burst.jsonl");
    let text: String = samples.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(&input, text).unwrap();
    let (lines, _) = common::run_replay(dir.path(), &common::linear_config(Some(0.999)), &input, false);
    let expected = lines.last().unwrap();
    assert_eq!(first.state(), &expected.x[..], "live equals replay in time order");
    assert_eq!(first.covariance(), &expected.p[..]);
}

/// fusiond stopped for 1.5 s while `fusion-sim run` publishes at 400 Hz (fixes
/// without delay, so that only the backlog could make one late): when it goes
/// on, the backlog is fused in time order.
#[test]
fn a_stalled_daemon_drains_its_backlog_in_time_order() {
    let domain = TestDomain::new("stall");
    let config = format!("{}\n[validation]\nmax_past_ns = 5_000_000_000\n", common::linear_config(Some(0.999)));
    let mut daemon = Daemon::start(&domain, &config, "event");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let mut sim = Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--duration", "5", "--imu-rate", "400"])
        .args(["--position-rate", "10", "--position-delay-min-ms", "0", "--position-delay-max-ms", "0"])
        .env(DOMAIN_ENV, &domain.domain)
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    daemon.signal("-STOP");
    std::thread::sleep(Duration::from_millis(1500));
    daemon.signal("-CONT");
    assert!(sim.wait().unwrap().success());
    // Every sample is published; fusiond drains what waits at its own pace (on
    // a loaded machine, later): the snapshot of the last IMU sample is awaited,
    // not a time. The deadline only guards against a hang.
    let imu_of =
        |s: &StateSnapshot| s.sensor_counters().iter().find(|r| r.kind == SampleKind::Imu as u32).map(|r| r.counts);
    let deadline = Instant::now() + Duration::from_secs(60);
    let last = loop {
        let latest = reader.latest().unwrap().copied();
        if let Some(s) = latest.filter(|s| imu_of(s).is_some_and(|imu| imu.received >= 2001)) {
            break s;
        }
        assert!(Instant::now() < deadline, "the backlog was not drained: {:?}", latest.as_ref().and_then(imu_of));
        std::thread::sleep(Duration::from_millis(10));
    };
    let imu = imu_of(&last).unwrap();
    assert_eq!(imu.received, 2001, "5 s at 400 Hz, both ends: {imu:?}");
    for row in last.sensor_counters() {
        let n = row.counts;
        assert_eq!((n.late, n.too_late, n.lost), (0, 0, 0), "the backlog was fused in time order: {row:?}");
        assert_eq!(n.processed, n.received, "{row:?}");
    }
    assert_eq!(last.rewinds, 0);
    drop((reader, client));
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// A retransmitted IMU sample (a copy of seq 100, same time and content)
/// published after IMU 159 is late at the head of the IMU queue: it steps
/// aside, and the samples queued behind it are fused in time order (no
/// rewind, nothing late); the copy is dropped as a duplicate, and the estimate
/// is the clean burst's.
#[test]
fn a_late_head_does_not_hold_back_the_queue_behind_it() {
    let samples = drive();
    let is_imu = |s: &Sample, seq: u64| s.kind() == SampleKind::Imu && s.seq() == seq;
    let copy = *samples.iter().find(|s| is_imu(s, 100)).unwrap();
    let after = samples.iter().position(|s| is_imu(s, 159)).unwrap();
    let mut with_copy = samples.clone();
    with_copy.insert(after + 1, copy);
    let clean = burst("late-head-clean", &samples);
    let last = burst("late-head", &with_copy);
    assert_eq!(last.rewinds, 0, "in-order samples behind a late head were made late");
    for row in last.sensor_counters() {
        let n = row.counts;
        assert_eq!((n.late, n.too_late, n.lost), (0, 0, 0), "{row:?}");
        let duplicates = u64::from(row.kind == SampleKind::Imu as u32);
        assert_eq!(n.duplicate, duplicates, "{row:?}");
        assert_eq!(n.processed + n.duplicate, n.received, "{row:?}");
    }
    assert_eq!(last.state(), clean.state(), "the copy changes nothing");
    assert_eq!(last.covariance(), clean.covariance());
}
