//! Fault-injection soak (`FUSION_SOAK_SECS`, default 60 s): the real daemon on the
//! real clock with a simulated car (`fusion-sim`) killed and restarted at random,
//! the daemon and a reader stopped and continued at random (SIGSTOP/SIGCONT), and
//! a peer flooding invalid IMU samples and far-off position fixes. fusiond must
//! stay up with flat memory, account for every sample, and end near the truth.

mod common;

use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use common::heartbeat::Heartbeat;
use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_client::sim::CarTrajectory;
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{ImuSample, PositionSample, now_ns};

/// A small deterministic generator (xorshift64*) for the fault schedule.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in `lo..hi` ms.
    fn ms(&mut self, lo: u64, hi: u64) -> Duration {
        Duration::from_millis(lo + self.next() % (hi - lo))
    }
}

fn rss_kb(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

fn signal(pid: u32, sig: &str) {
    let _ = Command::new("kill").args([sig, &pid.to_string()]).status();
}

/// The simulated car from `start` (CLOCK_MONOTONIC ns) with `seed`.
fn spawn_sim(domain: &TestDomain, start: u64, seed: u64, duration_s: u64) -> Child {
    Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--imu-rate", "200", "--seed", &seed.to_string()])
        .args(["--start-at-ns", &start.to_string(), "--duration", &duration_s.to_string()])
        .env(DOMAIN_ENV, &domain.domain)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

#[test]
fn fusiond_survives_a_fault_injection_soak_with_flat_memory_and_a_consistent_estimate() {
    let secs: u64 = std::env::var("FUSION_SOAK_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(60);
    let _beat = Heartbeat::start("soak", Duration::from_secs(secs + 5));
    let domain = TestDomain::new("soak");
    // The demo's model on the real clock (default validation), gated.
    let config = format!("{}\n[validation]\n", common::linear_config(Some(0.999)));
    let mut daemon = Daemon::start(&domain, &config, "event");
    let pid = daemon.pid();
    let seed = 11;
    let start = now_ns() + 200_000_000;
    let mut sim = spawn_sim(&domain, start, seed, secs + 30);
    let mut reader = Command::new(workspace_bin("fusionctl"))
        .args(["echo", "--namespace", &domain.namespace])
        .env(DOMAIN_ENV, &domain.domain)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();

    // The hostile peer: floods invalid IMU samples and far-off fixes, and
    // restarts (new publishers, sequence from 0) now and then.
    let stop = Arc::new(AtomicBool::new(false));
    let flooded = Arc::new(AtomicU64::new(0));
    let peer = {
        let (stop, flooded, client) = (Arc::clone(&stop), Arc::clone(&flooded), domain.client());
        std::thread::spawn(move || {
            let mut rng = Rng(7);
            while !stop.load(Ordering::Relaxed) {
                let mut imu = client.imu_publisher(9).unwrap();
                let mut pos = client.position_publisher(9).unwrap();
                let until = Instant::now() + rng.ms(500, 3000);
                let mut seq = 0;
                while Instant::now() < until && !stop.load(Ordering::Relaxed) {
                    let t = now_ns();
                    imu.publish_sample(ImuSample::new(t, 9, seq, [f64::NAN, 0.0, 0.0], [0.0; 3])).unwrap();
                    let cov = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
                    pos.publish_sample(PositionSample::new(t, 9, seq, [1000.0, -1000.0, 0.0], cov)).unwrap();
                    seq += 1;
                    flooded.fetch_add(2, Ordering::Relaxed);
                    if seq % 64 == 0 {
                        std::thread::sleep(Duration::from_micros(200));
                    }
                }
                std::thread::sleep(rng.ms(100, 1500));
            }
        })
    };

    let mut rng = Rng(3);
    let begin = Instant::now();
    let faults_end = begin + Duration::from_secs(secs.saturating_sub(8).max(4));
    let mut warm_rss = None;
    let (mut restarts, mut stops) = (0, 0);
    while Instant::now() < faults_end {
        std::thread::sleep(rng.ms(500, 2500));
        if warm_rss.is_none() && begin.elapsed() > Duration::from_secs(5) {
            warm_rss = Some(rss_kb(pid));
        }
        match rng.next() % 4 {
            0 => {
                // The car's sensor process dies and comes back on the same drive.
                let _ = sim.kill();
                let _ = sim.wait();
                sim = spawn_sim(&domain, start, seed, secs + 30);
                restarts += 1;
            }
            1 => {
                signal(pid, "-STOP");
                std::thread::sleep(rng.ms(100, 1500));
                signal(pid, "-CONT");
                stops += 1;
            }
            2 => {
                signal(reader.id(), "-STOP");
                std::thread::sleep(rng.ms(500, 4000));
                signal(reader.id(), "-CONT");
            }
            _ => {}
        }
        assert!(daemon.is_running(), "fusiond died: {}", daemon.stderr());
    }
    stop.store(true, Ordering::Relaxed);
    peer.join().unwrap();
    // The good sensors alone for a while: the estimate settles on them.
    std::thread::sleep(Duration::from_secs(5));
    let end_rss = rss_kb(pid);

    let client = domain.client();
    let mut state = client.state_subscriber().unwrap();
    let snap = *state.wait_next(Duration::from_secs(5)).unwrap().expect("a snapshot");
    assert!(daemon.is_running(), "fusiond died: {}", daemon.stderr());
    let _ = sim.kill();
    let _ = sim.wait();
    let _ = reader.kill();
    let _ = reader.wait();

    // Memory: no growth beyond noise after the warm-up.
    let warm_rss = warm_rss.expect("ran past the warm-up");
    assert!(end_rss < warm_rss + 4096, "RSS grew from {warm_rss} kB to {end_rss} kB");
    // Every sample is accounted for, per sensor; the flooder's invalid IMU
    // samples took no row.
    for row in snap.sensor_counters() {
        let c = row.counts;
        assert_eq!(
            c.received,
            c.processed + c.invalid + c.duplicate + c.too_late + c.rate_limited,
            "sensor {}: {c:?}",
            row.sensor
        );
    }
    let rows: Vec<(u32, u32)> = snap.sensor_counters().iter().map(|r| (r.kind, r.sensor)).collect();
    assert!(!rows.contains(&(fusion_shared::SampleKind::Imu as u32, 9)), "{rows:?}");
    let far = snap.sensor_counters().iter().find(|r| r.sensor == 9).expect("the far-off fixes have a row").counts;
    assert_eq!(far.fused, 0, "no far-off fix was fused: {far:?}");
    assert!(snap.unknown_sensor > 0 && flooded.load(Ordering::Relaxed) > 1000);
    // The estimate is the car's, within its own uncertainty.
    let truth = CarTrajectory::new(seed).at(snap.t_ns.saturating_sub(start) as f64 * 1e-9);
    let sd: Vec<f64> = snap.std_devs().collect();
    for (i, (x, sigma)) in snap.state().iter().zip(&sd).take(3).enumerate() {
        let err = x - truth.pos_m[i];
        assert!(err.abs() < 5.0 * sigma + 0.5, "axis {i}: error {err} m, sigma {sigma} m ({snap:?})");
    }
    assert_eq!(snap.reinitialisations, 0, "the good fixes kept the filter out of lock-out");
    eprintln!(
        "soak {secs} s: {restarts} sensor restarts, {stops} daemon stops, RSS {warm_rss} -> {end_rss} kB, \
         {} flooded samples",
        flooded.load(Ordering::Relaxed)
    );
    assert!(daemon.terminate().success());
}
