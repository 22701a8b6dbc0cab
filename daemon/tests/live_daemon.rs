//! The real `fusiond run` over real iceoryx2, fed and read with the client crate.

mod common;

use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, publish_in_lockstep, snapshot_of, workspace_bin};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::snapshot::health;
use fusion_shared::{Sample, StateSnapshot};

fn scenario(seconds: f64, delay_ms: (u64, u64)) -> Vec<Sample> {
    let mut c = ScenarioConfig { seed: 4, duration_s: seconds, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.imu.jitter_ns = 500_000;
    c.position.delay_min_ns = delay_ms.0 * 1_000_000;
    c.position.delay_max_ns = delay_ms.1 * 1_000_000;
    Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect()
}

fn config() -> String {
    common::linear_config(Some(0.999)).replace("[100, 100, 100, 10, 10, 10]", "[100, 100, 100, 225, 225, 225]")
}

fn replay(samples: &[Sample], config: &str) -> Vec<fusion_daemon::replay::OutputLine> {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.jsonl");
    let text: String = samples.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(&input, text).unwrap();
    common::run_replay(dir.path(), config, &input, false).0
}

fn assert_same_estimate(snap: &StateSnapshot, line: &fusion_daemon::replay::OutputLine, what: &str) {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300);
    assert_eq!((snap.t_ns, snap.sample_seq), (line.t_ns, line.seq), "{what}: estimate of another sample");
    assert!(
        snap.state().iter().zip(&line.x).all(|(a, b)| close(*a, *b)),
        "{what}: x {:?} vs {:?}",
        snap.state(),
        line.x
    );
    let bad: Vec<_> = snap
        .covariance()
        .iter()
        .zip(&line.p)
        .enumerate()
        .filter(|(_, (a, b))| !close(**a, **b))
        .map(|(i, (a, b))| (i, *a, *b))
        .take(5)
        .collect();
    assert!(
        bad.is_empty(),
        "{what}: P differs {bad:?} (t {} kind {} input {} {})",
        snap.t_ns,
        snap.sample_kind,
        snap.input_kind,
        snap.input_seq
    );
    assert_eq!(snap.accepted(), line.accepted, "{what}");
}

#[test]
fn in_order_stream_gives_the_replay_estimates() {
    let domain = TestDomain::new("inorder");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut samples = scenario(3.0, (0, 0));
    samples.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    let lines = replay(&samples, &config());
    assert_eq!(snaps.len(), lines.len());
    for (i, (s, l)) in snaps.iter().zip(&lines).enumerate() {
        assert_same_estimate(s, l, &format!("sample {i}"));
        assert_eq!(s.input_replayed, 0);
    }
    let last = snaps.last().unwrap();
    assert_eq!(last.health, health::OK, "{:?}", last.health_reason_names().collect::<Vec<_>>());
    assert!(daemon.terminate().success());
}

#[test]
fn late_positions_give_the_replay_final_state() {
    let domain = TestDomain::new("late");
    let mut daemon = Daemon::start(&domain, &config(), "spin");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let samples = scenario(3.0, (20, 150)); // arrival order: positions up to 150 ms late
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    let lines = replay(&samples, &config());
    // A late fix's own snapshot is provisional: the samples after it are still
    // to be re-processed, in the daemon's idle time.
    let late_fixes: Vec<&StateSnapshot> = snaps.iter().filter(|s| s.input_replayed > 0).collect();
    assert!(late_fixes.len() >= 25, "positions were fused late by rewind: {}", late_fixes.len());
    for s in &late_fixes {
        assert!(s.input_t_ns < s.t_ns && !s.settled(), "{s:?}");
        // The late fix, or an older one whose rewind was still under way.
        assert!(s.pending_since_t_ns > 0 && s.pending_since_t_ns <= s.input_t_ns, "{s:?}");
        assert!(s.pending_steps >= 1);
    }
    // The correction lands without further input: a settled snapshot with the
    // replay's final estimate.
    let mut last = *snaps.last().unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    while !last.settled() {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "the last correction never landed");
        if let Some(s) = reader.wait_next(left).unwrap() {
            last = *s;
        }
    }
    assert_same_estimate(&last, lines.last().unwrap(), "final state");
    assert!(last.background_steps > 0, "rewinds were worked in between samples");
    assert!(daemon.terminate().success());
}

#[test]
fn bad_samples_are_rejected_counted_and_change_nothing() {
    let domain = TestDomain::new("bad");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let good = scenario(2.0, (0, 0));
    // Bad samples take their place in each sensor's sequence, as a faulty sensor's would.
    let mut mixed = Vec::new();
    let (mut imu_seq, mut pos_seq) = (0, 0);
    let mut bad_count = (0, 0);
    for (i, s) in good.iter().enumerate() {
        let mut s = *s;
        match &mut s {
            Sample::Imu(x) => {
                if i % 97 == 5 {
                    let mut nan = *x;
                    nan.header.seq = imu_seq;
                    nan.accel_mps2[1] = if i % 2 == 0 { f64::NAN } else { f64::INFINITY };
                    mixed.push((Sample::Imu(nan), false));
                    imu_seq += 1;
                    bad_count.0 += 1;
                }
                x.header.seq = imu_seq;
                imu_seq += 1;
            }
            Sample::Position(x) => {
                let mut bad = *x;
                bad.header.seq = pos_seq;
                match pos_seq % 4 {
                    0 => bad.cov_m2 = [1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0], // indefinite
                    1 => bad.cov_m2[1] = 0.3,                                        // not symmetric
                    2 => bad.header.t_ns = fusion_shared::now_ns() + 10_000_000_000, // far future
                    _ => bad.pos_m[2] = f64::NAN,
                }
                mixed.push((Sample::Position(bad), false));
                pos_seq += 1;
                bad_count.1 += 1;
                x.header.seq = pos_seq;
                pos_seq += 1;
            }
            _ => {}
        }
        mixed.push((s, true));
    }
    let mut publishers = fusion_client::SensorPublishers::all(&client).unwrap();
    let mut last = None;
    for (s, good) in &mixed {
        publishers.publish(*s).unwrap();
        if *good {
            last = Some(snapshot_of(&mut reader, s));
        }
    }
    let clean: Vec<Sample> = mixed.iter().filter(|(_, g)| *g).map(|(s, _)| *s).collect();
    let lines = replay(&clean, &config());
    let last = last.unwrap();
    assert_same_estimate(&last, lines.last().unwrap(), "final state with bad samples");
    let c = last.sensor_counters();
    // The position sensor's first sample is a bad one: an invalid sample takes no
    // sensor row, so it is counted against no sensor.
    assert_eq!((c[0].counts.invalid, c[1].counts.invalid + 1), bad_count, "{c:?}");
    assert_eq!(last.unknown_sensor, 1);
    for row in c {
        let n = row.counts;
        assert_eq!(n.received, n.processed + n.invalid + n.duplicate + n.too_late + n.rate_limited, "{n:?}");
    }
    assert_eq!((c[0].counts.lost, c[1].counts.lost), (0, 0), "a rejected sample arrived: it is not lost");
    assert!(daemon.terminate().success());
}

#[test]
fn a_reader_started_late_gets_the_latest_snapshot_at_once() {
    let domain = TestDomain::new("latereader");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let samples = scenario(0.5, (0, 0));
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    // Everything is quiet now; a new process-like client connects.
    let late_client = domain.client();
    let mut late = late_client.state_subscriber().unwrap();
    let got = late.wait_next(Duration::from_secs(2)).unwrap().copied().expect("history snapshot");
    // The newest snapshot when it connected: the last sample's, or one the
    // health published after it (a stream went stale while the late client
    // started, which on a loaded machine can take longer than the timeout),
    // which carries the same estimate.
    let last = snaps.last().unwrap();
    assert!(got.seq >= last.seq, "{} before {}", got.seq, last.seq);
    assert_eq!(got.state(), last.state());
    // And one fusiond published: the reader that was there all along has it.
    let mut seen = (got.seq == last.seq).then_some(last.publish_ns);
    while let Some(s) = reader.try_next().unwrap() {
        if s.seq == got.seq {
            seen = Some(s.publish_ns);
        }
    }
    assert_eq!(seen, Some(got.publish_ns), "snapshot {} was not published to the first reader", got.seq);
    assert!(daemon.terminate().success());
}

#[test]
fn sigterm_leaves_nothing_behind() {
    let domain = TestDomain::new("sigterm");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    {
        let client = domain.client();
        let mut reader = client.state_subscriber().unwrap();
        publish_in_lockstep(&client, &mut reader, &scenario(0.2, (0, 0)));
    }
    assert!(!domain.files().is_empty(), "the daemon's files are under the domain prefix");
    let status = daemon.terminate();
    assert!(status.success(), "{status}: {}", daemon.stderr());
    assert_eq!(domain.files(), Vec::<String>::new(), "left behind after SIGTERM");
    assert!(daemon.stderr().contains("fusiond stopping"));
}

#[test]
fn after_sigkill_a_new_daemon_starts_and_clients_carry_on() {
    let domain = TestDomain::new("sigkill");
    let mut first = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let samples = scenario(1.0, (0, 0));
    let (before, after) = samples.split_at(samples.len() / 2);
    publish_in_lockstep(&client, &mut reader, before);
    first.signal("-KILL");
    first.kill();
    // No manual cleanup: the new daemon starts on the dead one's leftovers.
    let mut second = Daemon::start(&domain, &config(), "event");
    // The same publisher and reader ports keep working with the new daemon.
    let snaps = publish_in_lockstep(&client, &mut reader, after);
    assert_eq!(snaps.len(), after.len());
    assert_eq!(snaps[0].seq, 0, "snapshots of the new daemon");
    assert!(second.terminate().success());
}

#[test]
fn sigkill_of_a_publisher_marks_its_stream_stale() {
    let domain = TestDomain::new("pubkill");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut sim = std::process::Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--duration", "60"])
        .env(fusion_shared::service::DOMAIN_ENV, &domain.domain)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let wait_for = |reader: &mut fusion_client::StateSubscriber, what: &str, f: &dyn Fn(&StateSnapshot) -> bool| {
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Some(s) = reader.wait_next(Duration::from_millis(100)).unwrap()
                && f(s)
            {
                return *s;
            }
        }
        panic!("never saw: {what}");
    };
    wait_for(&mut reader, "health ok", &|s| s.health == health::OK);
    std::process::Command::new("kill").args(["-KILL", &sim.id().to_string()]).status().unwrap();
    let _ = sim.wait();
    let s = wait_for(&mut reader, "imu stale", &|s| s.health_reasons & health::IMU_STALE != 0);
    assert_eq!(s.health, health::DEGRADED);
    assert!(daemon.is_running(), "the daemon keeps running");
    assert!(daemon.terminate().success());
}

#[test]
fn start_up_errors_are_clear_and_exit_non_zero() {
    let domain = TestDomain::new("startup");
    let dir = tempfile::tempdir().unwrap();
    let run_with = |config: &str, namespace: &str, args: &[&str]| {
        let path = dir.path().join("c.toml");
        std::fs::write(&path, config).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_fusiond"))
            .args(["run", "--namespace", namespace, "--config"])
            .arg(&path)
            .args(args)
            .env(fusion_shared::service::DOMAIN_ENV, &domain.domain)
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let run = |config: &str, namespace: &str| run_with(config, namespace, &[]);
    let (code, err) = run(&config().replace("accel_noise_std = 0.3", "accel_noise_std = -1"), &domain.namespace);
    assert_eq!(code, Some(1));
    assert!(err.contains("model.accel_noise_std"), "{err}");
    let (code, err) = run(&config(), "no/slashes");
    assert_eq!(code, Some(2), "a usage error");
    assert!(err.contains("invalid namespace"), "{err}");
    let (code, err) = run_with(&config(), &domain.namespace, &["--cpu", "100000"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("cannot pin to CPU 100000: this process may use CPUs"), "{err}");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let (code, err) = run(&config(), &domain.namespace);
    assert_eq!(code, Some(1));
    assert!(err.contains("already running"), "{err}");
    assert!(daemon.terminate().success());
}

/// The CPUs a thread of `pid` may run on, from /proc.
fn cpus_allowed(pid: u32, tid: &str) -> String {
    let status = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("Cpus_allowed_list:")).unwrap();
    line.split(':').nth(1).unwrap().trim().to_string()
}

#[test]
fn cpu_pins_the_fusion_loop_and_nothing_else() {
    let domain = TestDomain::new("pinned");
    // Event mode: a spinning loop pinned to CPU 0 would starve the tests running beside it.
    let mut daemon = Daemon::start_with(&domain, &config(), &["--wait", "event", "--cpu", "0"]);
    let pid = daemon.pid();
    // The loop runs on the main thread (its id is the process id).
    assert_eq!(cpus_allowed(pid, &pid.to_string()), "0");
    let before = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let others: Vec<String> = std::fs::read_dir(format!("/proc/{pid}/task"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|tid| *tid != pid.to_string())
        .map(|tid| cpus_allowed(pid, &tid))
        .collect();
    assert!(!others.is_empty(), "the summary thread exists: {before}");
    if std::thread::available_parallelism().map_or(1, |n| n.get()) > 1 {
        assert!(others.iter().all(|c| c != "0"), "other threads keep every CPU: {others:?}");
    }
    // It fuses as usual.
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(64).unwrap();
    let samples = scenario(0.2, (0, 0));
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    assert_eq!(snaps.len(), samples.len());
    assert!(daemon.stderr().contains("cpu=Some(0)"), "{}", daemon.stderr());
    assert!(daemon.terminate().success());
}

fn ins_config() -> String {
    "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
     accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
     initial_state = [0,0,0, 9,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
     initial_covariance_diagonal = [1,1,1, 100,100,100, 1,1,1, 0.01,0.01,0.01, 1e-5,1e-5,1e-5]\n\
     [gating]\nprobability = 0.999\n"
        .to_string()
}

#[test]
fn ins_live_gives_the_replay_estimates() {
    let domain = TestDomain::new("ins");
    let mut daemon = Daemon::start(&domain, &ins_config(), "spin");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(512).unwrap();
    let mut c = ScenarioConfig { seed: 21, duration_s: 2.0, ..Default::default() };
    c.imu = fusion_client::sim::ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5);
    c.imu_output = fusion_client::sim::ImuOutput::BodySpecificForce;
    // A GNSS receiver with Doppler velocity as well: fused on δv.
    c.aiding.push(std::sync::Arc::new(fusion_client::sim::VelocityConfig::default()));
    let mut samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    samples.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    let snaps = publish_in_lockstep(&client, &mut reader, &samples);
    let lines = replay(&samples, &ins_config());
    let last = snaps.last().unwrap();
    assert_eq!((last.model, last.state_len, last.cov_dim), (fusion_shared::snapshot::model::INS, 16, 15));
    let velocity = last.sensor_counters().iter().find(|c| c.kind == fusion_shared::SampleKind::Velocity as u32);
    assert!(velocity.is_some_and(|c| c.counts.fused == 21), "{velocity:?}");
    assert_eq!(snaps.len(), lines.len());
    for (i, (s, l)) in snaps.iter().zip(&lines).enumerate() {
        assert_same_estimate(s, l, &format!("ins sample {i}"));
    }
    assert!(daemon.terminate().success());
}

/// `fusiond run` without `--config` runs on the built-in defaults (what
/// `print-config` shows), says so in one line, and fuses what it is given.
#[test]
fn without_a_config_fusiond_runs_on_the_defaults() {
    let domain = TestDomain::new("defaults");
    let mut daemon = Daemon::start_on_defaults(&domain);
    let stderr = daemon.stderr();
    assert_eq!(stderr.matches("running on the built-in defaults").count(), 1, "{stderr}");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let mut imu = client.imu_publisher(0).unwrap();
    let t = fusion_shared::now_ns();
    imu.publish(t, [0.0, 0.0, 9.81], [0.0; 3]).unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(s) = reader.latest().unwrap()
            && s.sensor_counters().iter().any(|c| c.counts.processed == 1)
        {
            break;
        }
        assert!(Instant::now() < deadline, "no snapshot of the sample: {}", daemon.stderr());
        std::thread::sleep(Duration::from_millis(10));
    }
    drop((reader, imu, client));
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// Samples the model refuses for good as configured are not refused in
/// silence: one warning per sensor names the reason and the key to set
/// (`linear` and a magnetometer; `ins` and a barometer or pose sensor without
/// its `[[sensor]]` entry), and transient refusals are not warned about.
#[test]
fn lasting_refusals_are_warned_about_once_per_sensor() {
    use fusion_shared::{BarometerSample, MagnetometerSample, PoseSample};
    let mut cov = [0.0; 36];
    (0..6).for_each(|i| cov[i * 7] = 0.01);
    let field_cov = [0.1, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.1];
    for (tag, config, expected) in [
        (
            "refused-linear",
            common::linear_config(None),
            vec![
                "magnetometer 3: the linear model does not use",
                "barometer 5: the linear model does not use",
                "pose 6: the linear model does not use",
            ],
        ),
        (
            "refused-ins",
            common::ins_config_at_truth(1),
            vec![
                "magnetometer 3: no magnetometer sensor 3 is configured",
                "barometer 5: no barometer sensor 5 is configured",
                "pose 6: no pose sensor 6 is configured",
            ],
        ),
    ] {
        let domain = TestDomain::new(tag);
        let mut daemon = Daemon::start(&domain, &config, "event");
        let client = domain.client();
        let mut reader = client.state_subscriber().unwrap();
        let mut magnetometer = client.publisher::<MagnetometerSample>(3).unwrap();
        let mut barometer = client.publisher::<BarometerSample>(5).unwrap();
        let mut pose = client.publisher::<PoseSample>(6).unwrap();
        let t0 = fusion_shared::now_ns();
        for i in 0..3u64 {
            let t = t0 + i * 1_000_000;
            magnetometer.publish_next(MagnetometerSample::new(t, 3, 0, [20.0, 0.0, -40.0], field_cov)).unwrap();
            barometer.publish_next(BarometerSample::new(t, 5, 0, 95_000.0, 4.0)).unwrap();
            pose.publish_next(PoseSample::new(t, 6, 0, [0.0; 3], [1.0, 0.0, 0.0, 0.0], cov, 0)).unwrap();
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        while reader
            .latest()
            .unwrap()
            .is_none_or(|s| s.sensor_counters().iter().map(|c| c.counts.received).sum::<u64>() < 9)
        {
            assert!(Instant::now() < deadline, "{}", daemon.stderr());
            std::thread::sleep(Duration::from_millis(10));
        }
        drop((reader, magnetometer, barometer, pose, client));
        assert!(daemon.terminate().success());
        let stderr = daemon.stderr();
        for what in &expected {
            assert_eq!(stderr.matches(&format!("refusing every sample of {what}")).count(), 1, "{what}\n{stderr}");
        }
        assert_eq!(stderr.matches("refusing every sample of").count(), expected.len(), "{stderr}");
        // The key to set, as the configuration spells it.
        if tag == "refused-ins" {
            for key in [r#"[[sensor]] kinds = ["barometer"], id = 5"#, r#"[[sensor]] kinds = ["pose"], id = 6"#] {
                assert!(stderr.contains(key), "{key} not in\n{stderr}");
            }
            assert!(stderr.contains("[sensor.magnetic]"), "{stderr}");
        }
        drop(daemon);
        assert!(domain.files().is_empty(), "{:?}", domain.files());
    }
}
