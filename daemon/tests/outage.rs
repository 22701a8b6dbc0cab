//! A 45 s GNSS outage (a tunnel) on a car's sensor set: how far the estimate is
//! off at the exit, and whether its σ says so.
//!
//! Each run: a car-like drive of 90 s with the outage from 30 s to 75 s; two 200 Hz
//! MEMS IMUs on one clock, mounted differently, with turn-on biases that wander;
//! GNSS latitude/longitude/height and Doppler velocity of an antenna 1.5 m from the
//! IMUs (10 Hz, 20–120 ms late) outside the tunnel; the land-vehicle motion
//! constraint; and, in one setup, wheel odometry at 50 Hz with a 1 % scale error
//! (tyre wear) that the odometry's reported variance covers at 1σ but no state
//! estimates.
//!
//! Reported per setup: the horizontal error at the end of the outage (median and
//! worst over the runs), its 1σ, and the position-and-velocity NEES/dof over the
//! outage with the share of steps in the 95 % χ²₆ band. The target is ≤ 2 m median
//! at the exit; what is reached is printed. Held: without odometry the filter is
//! consistent through the outage (its σ grows with its error). With the odometry's
//! 1 % scale error not a state of the filter, odometry makes the exit worse and the
//! filter over-confident (it takes a constant 0.09 m/s error for white noise at
//! 50 Hz): that setup is reported, not held, until the scale-factor state exists.
//!
//! The short version runs in `cargo test`; the full one (20 runs):
//! `cargo test --release -p fusion-daemon --test outage -- --ignored --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{
    GeodeticConfig, ImuConfig, ImuOutput, OdometryConfig, Outage, PositionConfig, Scenario, ScenarioConfig,
    VelocityConfig,
};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const ODOMETRY_ARM: [f64; 3] = [-1.3, 0.0, -0.3];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const OUTAGE: Outage = Outage { at_s: 30.0, duration_s: 45.0 };
/// Two-sided 95 % band of χ²₆ (tables).
const CHI2_6_95: (f64, f64) = (1.2373, 14.4494);
/// The IMUs: id, forward-right-down axes, roll/pitch/yaw of the mount (degrees).
const IMUS: [(u32, bool, [f64; 3]); 2] = [(0, true, [3.0, -2.0, 90.0]), (1, false, [-1.5, 2.5, -90.0])];

#[derive(Debug, Default)]
struct Run {
    /// Horizontal error and its 1σ at the end of the outage, m.
    exit: (f64, f64),
    nees_sum: f64,
    in_band: u64,
    steps: u64,
}

fn run(seed: u64, odometry: bool) -> Run {
    let imu = |&(id, frd, rpy): &(u32, bool, [f64; 3])| {
        let [r, p, y] = rpy.map(f64::to_radians);
        let flip = if frd { Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)) } else { Matrix3::identity() };
        ImuConfig {
            accel_bias_std: SIGMA0[3],
            gyro_bias_std: SIGMA0[4],
            sensor: id,
            rotation: UnitQuaternion::from_euler_angles(r, p, y).to_rotation_matrix().into_inner() * flip,
            ..ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5)
        }
    };
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() };
    let mut c = ScenarioConfig {
        seed,
        duration_s: OUTAGE.at_s + OUTAGE.duration_s + 15.0,
        imu: imu(&IMUS[0]),
        extra_imus: vec![imu(&IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        outages: vec![OUTAGE],
        ..Default::default()
    };
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix }));
    c.aiding.push(Arc::new(VelocityConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() }));
    if odometry {
        c.aiding.push(Arc::new(OdometryConfig { scale_error: 0.01, lever_arm_m: ODOMETRY_ARM, ..Default::default() }));
    }
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (_, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let fmt = common::toml_list;
    let mut sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\nlever_arm_m = [{}]\n\
         [[sensor]]\nname = \"wheels\"\nid = 0\nkinds = [\"odometry\"]\nlever_arm_m = [{}]\n",
        fmt(&LEVER_ARM),
        fmt(&ODOMETRY_ARM)
    );
    for (id, frd, [r, p, y]) in IMUS {
        let axes = if frd { "frd" } else { "flu" };
        sensors += &format!(
            "[[sensor]]\nname = \"imu-{id}\"\nid = {id}\nkinds = [\"imu\"]\naxes = \"{axes}\"\nrotation_rpy_deg = [{r}, {p}, {y}]\n"
        );
    }
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n[filter]\n{filter}\
         [gating]\nprobability = 0.9999\n[datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n{sensors}",
        DATUM.latitude_deg, DATUM.longitude_deg, DATUM.height_m,
    ))
    .unwrap();
    let mut engine = Engine::new(InsModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let (from, to) = (OUTAGE.at_s, OUTAGE.at_s + OUTAGE.duration_s);
    let start_ns = scenario.start_ns;
    let mut out = Run::default();
    let mut sink = |e: &Entry<_>| {
        let t = (e.key.t_ns - start_ns) as f64 * 1e-9;
        if !matches!(e.sample, Sample::Imu(_)) || !(from..to).contains(&t) {
            return;
        }
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel as Model>::covariance(&e.state));
        let truth = scenario.truth_at(e.key.t_ns);
        let (err, nees) = common::pv_error_and_nees(x, &cov, &truth);
        out.nees_sum += nees;
        out.in_band += u64::from((CHI2_6_95.0..=CHI2_6_95.1).contains(&nees));
        out.steps += 1;
        out.exit = (err[0].hypot(err[1]), (cov[0] + cov[16]).sqrt());
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

/// Median and worst of `v`.
fn median_worst(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[v.len() - 1])
}

/// The median exit error and the NEES/dof through the outage of the setup.
fn report(runs: u64, odometry: bool) -> (f64, f64) {
    let results: Vec<Run> = (0..runs).map(|seed| run(8000 + seed, odometry)).collect();
    let (median, worst) = median_worst(results.iter().map(|r| r.exit.0).collect());
    let sigma = median_worst(results.iter().map(|r| r.exit.1).collect()).0;
    let steps: u64 = results.iter().map(|r| r.steps).sum();
    let nees = results.iter().map(|r| r.nees_sum).sum::<f64>() / steps as f64 / 6.0;
    let band = results.iter().map(|r| r.in_band).sum::<u64>() as f64 / steps as f64;
    eprintln!(
        "{runs} runs, {}: horizontal error at the end of the 45 s outage median {median:.2} m, worst {worst:.2} m \
         (median 1-sigma {sigma:.2} m); NEES/dof through the outage {nees:.2}, {:.1} % of steps in the 95 % band",
        if odometry { "odometry 50 Hz with a 1 % scale error + motion constraint" } else { "motion constraint only" },
        band * 100.0
    );
    assert!(median.is_finite() && worst.is_finite());
    (median, nees)
}

fn check(runs: u64) {
    let (error, nees) = report(runs, false);
    assert!((0.5..=1.5).contains(&nees), "consistent through the outage: NEES/dof {nees}");
    assert!(error < 10.0, "{error} m at the exit");
    report(runs, true);
}

#[test]
fn a_45_second_tunnel_short() {
    check(3);
}

#[test]
#[ignore = "long: run in release, see the module docs"]
fn a_45_second_tunnel_full() {
    check(20);
}
