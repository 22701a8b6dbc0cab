//! Two IMUs, one killed mid-drive: the real fusiond, three real `fusion-sim`
//! processes (IMU 0, IMU 1, and a GNSS receiver with latitude/longitude/height and
//! Doppler velocity of an antenna 1.5 m from the IMUs), over real iceoryx2. At 6 s
//! the process of IMU 0 (the one in use) is SIGKILLed. For both ways of
//! combining IMUs (`average`, `failover`):
//!
//! - no step in the estimate's position or velocity error between consecutive
//!   snapshots is larger than 3σ;
//! - the health says which IMU is gone (stale: imu 0), and only that one;
//! - the drive finishes consistent: the position-and-velocity NEES of the last
//!   snapshot of each second after the kill stays below the 99.9 % χ²₆ bound, and
//!   the final position error is within 3σ.

mod common;

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::heartbeat::Heartbeat;
use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_client::sim::CarTrajectory;
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::snapshot::health;
use fusion_shared::{SampleKind, StateSnapshot, now_ns};
use nalgebra::{Cholesky, Matrix6, Vector6};

const SEED: u64 = 11;
const DRIVE_S: f64 = 12.0;
const KILL_AT_S: f64 = 6.0;
/// χ²₆ 99.9 % quantile (tables).
const CHI2_6_999: f64 = 22.458;

/// The demo's car (see `fusion-demo`): the IMUs' mounts and the antenna.
const MOUNTS: [&str; 4] = ["--imu-mount", "frd:3,-2,90", "--imu-mount", "flu:-1.5,2.5,-90"];

fn config(combine: &str) -> String {
    format!(
        "{}[gating]\nprobability = 0.9999\n\
         [datum]\nlatitude_deg = 48.1316\nlongitude_deg = 11.5494\nheight_m = 519.0\n\
         [[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\nlever_arm_m = [1.0, 0.5, 1.0]\n\
         [[sensor]]\nname = \"imu-a\"\nid = 0\nkinds = [\"imu\"]\naxes = \"frd\"\nrotation_rpy_deg = [3.0, -2.0, 90.0]\n\
         [[sensor]]\nname = \"imu-b\"\nid = 1\nkinds = [\"imu\"]\nrotation_rpy_deg = [-1.5, 2.5, -90.0]\n\
         [imu]\ncombine = \"{combine}\"\n",
        common::ins_config_at_truth(SEED)
    )
}

fn sim(domain: &TestDomain, start_ns: u64, role: &[&str]) -> Child {
    Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--seed", &SEED.to_string()])
        .args(["--duration", &DRIVE_S.to_string(), "--start-at-ns", &start_ns.to_string()])
        .args(["--imu-output", "body", "--imu-rate", "200", "--accel-noise", "0.283", "--gyro-noise", "0.0141"])
        .args(["--accel-bias", "0.05", "--gyro-bias", "0.0005", "--accel-random-walk", "0.001"])
        .args(["--gyro-random-walk", "1e-5"])
        .args(MOUNTS)
        .args(["--position-rate", "0", "--geodetic-rate", "10", "--velocity-rate", "10", "--lever-arm", "1.0,0.5,1.0"])
        .args(role)
        .env(DOMAIN_ENV, &domain.domain)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// The sensor processes, killed and reaped on drop (also when a check fails).
struct Sensors(Vec<Child>);

impl Drop for Sensors {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Position and velocity error against the truth, and its covariance.
fn error(s: &StateSnapshot, truth: &CarTrajectory, start_ns: u64) -> (Vector6<f64>, Matrix6<f64>) {
    let t = (s.t_ns as f64 - start_ns as f64) * 1e-9;
    let tr = truth.at(t);
    let x = s.state();
    let e = Vector6::new(
        x[0] - tr.pos_m.x,
        x[1] - tr.pos_m.y,
        x[2] - tr.pos_m.z,
        x[3] - tr.vel_mps.x,
        x[4] - tr.vel_mps.y,
        x[5] - tr.vel_mps.z,
    );
    let cov = s.covariance();
    (e, Matrix6::from_fn(|r, c| cov[r * 15 + c]))
}

fn drive(combine: &str) {
    let _beat = Heartbeat::start(
        if combine == "average" { "imu_failover average" } else { "imu_failover failover" },
        Duration::from_secs(14),
    );
    let domain = TestDomain::new(&format!("failover-{combine}"));
    let mut daemon = Daemon::start(&domain, &config(combine), "event");
    let client = domain.client();
    let mut state = client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER).unwrap();
    workspace_bin("fusion-sim"); // built before the start time is set
    let start_ns = now_ns() + 700_000_000;
    let mut sensors = Sensors(vec![
        sim(&domain, start_ns, &["--imu-only", "--imu-ids", "0"]),
        sim(&domain, start_ns, &["--imu-only", "--imu-ids", "1"]),
        sim(&domain, start_ns, &["--position-only"]),
    ]);

    let kill_ns = start_ns + (KILL_AT_S * 1e9) as u64;
    let end = Instant::now() + Duration::from_secs_f64(0.7 + DRIVE_S + 1.0);
    let mut snaps: Vec<StateSnapshot> = Vec::new();
    let mut killed_at = None;
    while Instant::now() < end {
        if killed_at.is_none() && now_ns() >= kill_ns {
            sensors.0[0].kill().unwrap(); // SIGKILL
            sensors.0[0].wait().unwrap();
            killed_at = Some(now_ns());
        }
        if let Some(s) = state.wait_next(Duration::from_millis(20)).unwrap()
            && s.input_kind == SampleKind::Imu as u32
            && s.state_len == 16
        {
            snaps.push(*s);
        }
    }
    for c in &mut sensors.0[1..] {
        let _ = c.wait();
    }
    daemon.terminate();
    let killed_at = killed_at.expect("the kill happened");
    let truth = CarTrajectory::new(SEED);

    // Steps: between consecutive snapshots the error moves by less than 3σ.
    let mut largest = 0.0f64;
    for pair in snaps.windows(2).filter(|w| w[1].t_ns > w[0].t_ns && w[0].t_ns > start_ns + 1_000_000_000) {
        let (p0, p1) = (error(&pair[0], &truth, start_ns).1, error(&pair[1], &truth, start_ns).1);
        let (e0, e1) = (error(&pair[0], &truth, start_ns).0, error(&pair[1], &truth, start_ns).0);
        for i in 0..6 {
            let step = (e1[i] - e0[i]).abs() / p0[(i, i)].max(p1[(i, i)]).sqrt();
            largest = largest.max(step);
        }
    }
    assert!(largest < 3.0, "{combine}: a step of {largest:.2} sigma");

    // Health: after the kill (IMU timeout 100 ms), imu 0 is named stale and imu 1 never.
    let after: Vec<&StateSnapshot> = snaps.iter().filter(|s| s.publish_ns > killed_at + 300_000_000).collect();
    assert!(after.len() > 500, "{combine}: the drive went on after the kill ({} snapshots)", after.len());
    for s in &after {
        let stale: Vec<(u32, u32)> = s.stale_sensor_counters().map(|c| (c.kind, c.sensor)).collect();
        assert_eq!(stale, vec![(SampleKind::Imu as u32, 0)], "{combine}");
        assert_eq!((s.health, s.health_reasons & health::IMU_STALE), (health::DEGRADED, health::IMU_STALE));
    }
    let before: Vec<&StateSnapshot> =
        snaps.iter().filter(|s| s.t_ns > start_ns + 2_000_000_000 && s.publish_ns < killed_at).collect();
    assert!(before.iter().all(|s| s.stale_sensors == 0), "{combine}: nothing stale before the kill");

    // Consistency after the kill: the last snapshot of each second, and the end.
    let mut worst = 0.0f64;
    for second in (KILL_AT_S as u64 + 1)..(DRIVE_S as u64) {
        let t_end = start_ns + second * 1_000_000_000;
        let Some(s) = snaps.iter().rev().find(|s| s.t_ns <= t_end) else { continue };
        let (e, p) = error(s, &truth, start_ns);
        let nees = e.dot(&Cholesky::new(p).unwrap().solve(&e));
        worst = worst.max(nees);
    }
    eprintln!(
        "{combine}: largest step {largest:.2} sigma, worst NEES after the kill {worst:.2}, {} snapshots",
        snaps.len()
    );
    assert!(worst < CHI2_6_999, "{combine}: NEES {worst}");
    let last = snaps.last().unwrap();
    let (e, p) = error(last, &truth, start_ns);
    for i in 0..3 {
        assert!(e[i].abs() < 3.0 * p[(i, i)].sqrt(), "{combine}: final position error {e}");
    }
    // Both IMUs were fused before the kill, only IMU 1 after it.
    let imu = |s: &StateSnapshot, id: u32| {
        s.sensor_counters().iter().find(|c| c.kind == SampleKind::Imu as u32 && c.sensor == id).map(|c| c.counts)
    };
    let (a, b) = (imu(last, 0).unwrap(), imu(last, 1).unwrap());
    assert!(a.processed > 1000 && b.processed > 2000, "{a:?} {b:?}");
}

#[test]
fn averaged_imus_carry_on_when_one_is_killed() {
    drive("average");
}

#[test]
fn the_standby_imu_takes_over_when_the_one_in_use_is_killed() {
    drive("failover");
}
