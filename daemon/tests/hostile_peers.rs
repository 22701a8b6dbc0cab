//! Faulty and hostile peers against the real daemon over real iceoryx2: a sensor
//! process that restarts, invalid samples from many ids, a clock that was never
//! set, a publisher that floods; and bad lines in `fusiond replay`.

mod common;

use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use common::live::{Daemon, RECORDED_TIME, TestDomain, snapshot_of, workspace_bin};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{ImuSample, Sample, SampleKind, now_ns};

fn config() -> String {
    common::linear_config(Some(0.999)).replace("[100, 100, 100, 10, 10, 10]", "[100, 100, 100, 225, 225, 225]")
}

fn write_jsonl(path: &std::path::Path, samples: &[Sample]) {
    let text: String = samples.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(path, text).unwrap();
}

fn sim_input(domain: &TestDomain, input: &std::path::Path) {
    let out = Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--keep-stamps", "--namespace", &domain.namespace, "--input"])
        .arg(input)
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn a_sensor_process_that_restarts_has_every_sample_fused_and_live_equals_replay() {
    let domain = TestDomain::new("restart");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let mut c = ScenarioConfig { seed: 21, duration_s: 4.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    let mut samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    samples.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    // The sensor process is killed after 2 s and started again: its sequence
    // numbers start from 0 again, its clock goes on.
    let cut = samples.iter().position(|s| s.t_ns() >= 2_000_000_000).unwrap();
    let (first, second) = samples.split_at_mut(cut);
    let mut first_seq = [None; SampleKind::COUNT];
    for s in second.iter_mut() {
        let base = *first_seq[s.kind() as usize].get_or_insert(s.seq());
        s.header_mut().seq -= base;
    }
    let dir = tempfile::tempdir().unwrap();
    let (a, b, all) = (dir.path().join("a.jsonl"), dir.path().join("b.jsonl"), dir.path().join("all.jsonl"));
    write_jsonl(&a, first);
    write_jsonl(&b, second);
    write_jsonl(&all, &samples);

    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    sim_input(&domain, &a);
    sim_input(&domain, &b);
    let last = snapshot_of(&mut reader, samples.last().unwrap());
    let (lines, _) = common::run_replay(dir.path(), &config(), &all, false);
    let expected = lines.last().unwrap();
    assert_eq!(last.state()[..6], expected.x[..], "live after the restart equals replay");
    assert_eq!(last.covariance()[..36], expected.p[..]);
    for row in last.sensor_counters() {
        let n = row.counts;
        assert_eq!((n.restarts, n.duplicate, n.lost, n.too_late), (1, 0, 0, 0), "{row:?}");
        assert_eq!(n.processed, samples.iter().filter(|s| s.kind() as u32 == row.kind).count() as u64);
    }
    assert!(daemon.terminate().success());
}

#[test]
fn invalid_samples_from_many_ids_do_not_lock_out_the_real_imu() {
    let domain = TestDomain::new("slots");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut bad = client.imu_publisher(100).unwrap();
    let mut imu = client.imu_publisher(0).unwrap();
    bad.set_wake(true);
    imu.set_wake(true);
    // 20 NaN samples from 20 new ids; then, once the real IMU has its row, one
    // with an absurd sequence number from the real IMU's id.
    for id in 1..=20u32 {
        let mut s = ImuSample::new(1_000_000, id, u64::from(id), [f64::NAN, 0.0, 0.0], [0.0; 3]);
        s.header.sensor = id;
        bad.publish_sample(s).unwrap();
    }
    let mut last = None;
    for k in 0..50u64 {
        let s = ImuSample::new(2_000_000 + k * 5_000_000, 0, k, [0.1, 0.0, 0.0], [0.0; 3]);
        imu.publish_sample(s).unwrap();
        last = Some(snapshot_of(&mut reader, &Sample::Imu(s)));
        if k == 0 {
            let mut s = ImuSample::new(1_000_000, 0, u64::MAX, [f64::NAN, 0.0, 0.0], [0.0; 3]);
            s.header.sensor = 0;
            bad.publish_sample(s).unwrap();
        }
    }
    let last = last.unwrap();
    let rows = last.sensor_counters();
    assert_eq!(rows.len(), 1, "no row for an invalid sample: {rows:?}");
    assert_eq!((rows[0].kind, rows[0].sensor), (SampleKind::Imu as u32, 0));
    assert_eq!((rows[0].counts.processed, rows[0].counts.invalid, rows[0].counts.lost), (50, 1, 0));
    assert_eq!(last.unknown_sensor, 20);
    assert!(daemon.terminate().success());
}

#[test]
fn a_first_sample_from_an_unset_clock_is_refused() {
    let domain = TestDomain::new("clock0");
    // The default validation: timestamps must be near the daemon's clock.
    let mut daemon = Daemon::start(&domain, &format!("{}\n[validation]\n", config()), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.set_wake(true);
    imu.publish_sample(ImuSample::new(0, 0, 0, [0.1, 0.0, 0.0], [0.0; 3])).unwrap();
    let mut last = None;
    for k in 1..=20u64 {
        let s = ImuSample::new(now_ns(), 0, k, [0.1, 0.0, 0.0], [0.0; 3]);
        imu.publish_sample(s).unwrap();
        last = Some(snapshot_of(&mut reader, &Sample::Imu(s)));
    }
    let last = last.unwrap();
    // The refused sample came first: it takes no sensor row.
    let n = last.sensor_counters()[0].counts;
    assert_eq!((n.received, n.processed, n.invalid, last.unknown_sensor), (20, 20, 0, 1));
    // The filter's time is the clock's, not 0: the velocity variance grew over
    // 20 short steps, not over hours.
    assert!(last.covariance()[3 * 6 + 3] < 300.0, "P_vx = {}", last.covariance()[3 * 6 + 3]);
    assert!(daemon.terminate().success());
}

#[test]
fn a_flooding_publisher_does_not_starve_a_real_imu() {
    let domain = TestDomain::new("flood");
    let config = format!("{}\n{RECORDED_TIME}max_rate_hz = 2000.0\n", config());
    let mut daemon = Daemon::start(&domain, &config, "spin");
    let stop = Arc::new(AtomicBool::new(false));
    // The flooder connects first and sends as fast as it can, stamped now.
    let flooder = {
        let (client, stop) = (domain.client(), Arc::clone(&stop));
        std::thread::spawn(move || {
            let mut p = client.imu_publisher(9).unwrap();
            let mut seq = 0;
            while !stop.load(Ordering::Relaxed) {
                p.publish_sample(ImuSample::new(now_ns(), 9, seq, [0.0, 0.0, 0.0], [0.0; 3])).unwrap();
                seq += 1;
            }
            seq
        })
    };
    std::thread::sleep(Duration::from_millis(200));
    let client = domain.client();
    let mut imu = client.imu_publisher(0).unwrap();
    let n = 1000u64;
    let start = now_ns();
    for k in 0..n {
        let t = start + k * 1_000_000;
        while now_ns() < t {
            std::hint::spin_loop();
        }
        imu.publish_sample(ImuSample::new(t, 0, k, [0.1, 0.0, 0.0], [0.0; 3])).unwrap();
    }
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    let flooded = flooder.join().unwrap();
    let mut reader = client.state_subscriber().unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    let last = loop {
        assert!(Instant::now() < deadline, "no snapshot");
        if let Some(s) = reader.wait_next(Duration::from_secs(1)).unwrap() {
            break *s;
        }
    };
    let row = |id| last.sensor_counters().iter().find(|r| r.sensor == id).unwrap().counts;
    let (real, flood) = (row(0), row(9));
    assert_eq!((real.received, real.processed, real.too_late, real.lost), (n, n, 0, 0), "real IMU: {real:?}");
    assert!(flood.rate_limited > 0 && flood.received <= flooded, "flooder: {flood:?} of {flooded}");
    assert!(daemon.terminate().success());
}

#[test]
fn bad_lines_in_a_replay_are_counted_with_their_line_numbers_and_poison_nothing() {
    let mut c = ScenarioConfig { seed: 22, duration_s: 2.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    let scenario = Scenario::generate(&c);
    let dir = tempfile::tempdir().unwrap();
    let clean_path = dir.path().join("clean.jsonl");
    common::write_input(&clean_path, &scenario);
    let clean = std::fs::read(&clean_path).unwrap();
    let lines: Vec<&[u8]> = clean.split(|&b| b == b'\n').filter(|l| !l.is_empty()).collect();
    // Line 11: not UTF-8. Line 21: an IMU sample at t = u64::MAX.
    let mut far = serde_json::from_slice::<serde_json::Value>(lines[0]).unwrap();
    let kind = far.as_object().unwrap().keys().next().unwrap().clone();
    far[&kind]["t_ns"] = serde_json::json!(u64::MAX);
    let mut bad = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        if i == 10 {
            bad.extend_from_slice(b"{\"kind\":\"imu\",\xff\xfe}\n");
        }
        if i == 19 {
            bad.extend_from_slice(far.to_string().as_bytes());
            bad.push(b'\n');
        }
        bad.extend_from_slice(l);
        bad.push(b'\n');
    }
    let bad_path = dir.path().join("bad.jsonl");
    std::fs::write(&bad_path, bad).unwrap();

    for smooth in [false, true] {
        let (good, _) = common::run_replay(dir.path(), &config(), &clean_path, smooth);
        let (with_bad, stderr) = common::run_replay(dir.path(), &config(), &bad_path, smooth);
        assert_eq!(good, with_bad, "the bad lines change no estimate (smooth: {smooth})");
        assert!(stderr.contains("line 11") && stderr.contains("UTF-8"), "{stderr}");
        assert!(stderr.contains("line 21") && stderr.contains("jumps"), "{stderr}");
    }
}

#[test]
fn idle_readers_beyond_the_configured_slots_get_a_clear_error_and_are_counted() {
    for wait in ["event", "spin"] {
        let domain = TestDomain::new("readers");
        let mut daemon = Daemon::start(&domain, &format!("{}\n[ipc]\nmax_readers = 2\n", config()), wait);
        let client = domain.client();
        let mut first = client.state_subscriber().unwrap();
        let _second = client.state_subscriber().unwrap();
        for _ in 0..3 {
            let err = client.state_subscriber().err().expect("a third reader is refused").to_string();
            assert!(err.contains("all 2 reader slots") && err.contains("[ipc] max_readers"), "{err}");
        }
        // The daemon counts them, and says so in a snapshot even with no input.
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut imu = client.imu_publisher(0).unwrap();
        imu.set_wake(true);
        let sample = ImuSample::new(1_000_000, 0, 0, [0.0; 3], [0.0; 3]);
        imu.publish_sample(sample).unwrap();
        let mut refused = 0;
        while refused < 3 && Instant::now() < deadline {
            if let Some(s) = first.wait_next(Duration::from_millis(100)).unwrap() {
                refused = s.readers_refused;
            }
        }
        assert_eq!(refused, 3, "--wait {wait}");
        // A slot given back can be taken again.
        drop(first);
        assert!(client.state_subscriber().is_ok());
        assert!(daemon.terminate().success());
    }
}
