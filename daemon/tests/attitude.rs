//! A vehicle with an AHRS (an IMU that reports its own orientation), wheel
//! odometry and no GNSS: the attitude set from the AHRS at its first sample
//! and then fused, consistently; and roll and pitch alone from an AHRS whose
//! yaw is 30° wrong (a magnetic yaw indoors), which must not pull the heading.
//!
//! Each run: 60 s of a car-like drive (two 200 Hz MEMS IMUs), an AHRS at 50 Hz
//! mounted as robot_localization's Husky has it (turned +90° about x, then −90°
//! about z; 0.5° of noise per axis), wheel odometry at 50 Hz, the land-vehicle
//! motion constraint; the start drawn from its σ with the attitude unknown
//! (1 rad per axis, its heading turned by a draw of that σ).
//!
//! Held over 20 runs (from 2 s on): the attitude NEES/dof (3 dof) in
//! [0.75, 1.35], the AHRS never refused and gated no more than the gate's own
//! false alarms. With `yaw = false`, the attitude known to 0.02 rad at the
//! start and the AHRS's yaw 30° off: the tilt's normalised squared error
//! (2 dof) in [0.5, 1.5] per dof, and the heading the same (to 10⁻⁹ rad) as
//! with the AHRS's yaw right, where full fusion follows the AHRS to within a
//! degree of its wrong yaw.
//!
//! `cargo test --release -p fusion-daemon --test attitude -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{AttitudeConfig, ImuOutput, OdometryConfig, Scenario, ScenarioConfig};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::{Sample, SampleKind};
use nalgebra::{Matrix2, Matrix3, Rotation3, Vector3};

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.0, 0.05, 0.0005];
const RUNS: u64 = 20;
const WRONG_YAW: f64 = std::f64::consts::FRAC_PI_6; // 30°

#[derive(Debug, Default)]
struct Run {
    /// Attitude NEES (3 dof): sum, steps.
    attitude: (f64, u64),
    /// Tilt normalised squared error (2 dof): sum, steps.
    tilt: (f64, u64),
    /// AHRS samples fused, gated, refused.
    ahrs: (u64, u64, u64),
    /// Heading error at the end, rad.
    heading_end: f64,
}

fn run(seed: u64, yaw: bool, yaw_error: f64, attitude_sd: f64) -> Run {
    let imu = |spec| common::car::imu(spec, SIGMA0[3], SIGMA0[4]);
    let sigma0 = [SIGMA0[0], SIGMA0[1], attitude_sd, SIGMA0[3], SIGMA0[4]];
    let mount = Rotation3::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, -std::f64::consts::FRAC_PI_2);
    let mut c = ScenarioConfig {
        seed,
        duration_s: 60.0,
        imu: imu(&common::car::IMUS[0]),
        extra_imus: vec![imu(&common::car::IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        ..Default::default()
    };
    c.aiding.push(Arc::new(AttitudeConfig {
        sensor: 7,
        rotation: mount.into_inner(),
        yaw_error_rad: yaw_error,
        ..Default::default()
    }));
    c.aiding.push(Arc::new(OdometryConfig { sensor: 4, ..Default::default() }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (t0, mut x0, p0) = common::ins_start_values(&scenario, seed, sigma0);
    let turn: f64 = {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xa4);
        StandardNormal.sample(&mut rng)
    };
    common::turn_heading(&mut x0, turn * attitude_sd);
    let fmt = common::toml_list;
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n\
         [filter]\ninitial_state = [{}]\ninitial_covariance_diagonal = [{}]\n[gating]\nprobability = 0.9999\n\
         [[sensor]]\nname = \"ahrs\"\nid = 7\nkinds = [\"attitude\"]\nrotation_rpy_deg = [90, 0, -90]\n\
         [sensor.attitude]\nyaw = {yaw}\n\
         [[sensor]]\nname = \"wheels\"\nid = 4\nkinds = [\"odometry\"]\n{}",
        fmt(&x0),
        fmt(&p0),
        common::car::imu_sensors()
    ))
    .unwrap();
    let InsBuilt::Core(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("no scale state") };
    let mut engine = Engine::new(model, EngineConfig::from_config(&config));
    let mut out = Run::default();
    let mut sink = |e: &Entry<_>| {
        if let Sample::Attitude(_) = &e.sample {
            match e.outcome {
                StepOutcome::Fused { .. } | StepOutcome::Propagated => out.ahrs.0 += 1,
                StepOutcome::Gated { .. } => out.ahrs.1 += 1,
                StepOutcome::Refused => out.ahrs.2 += 1,
            }
        }
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        if !matches!(e.sample, Sample::Imu(_)) || t < 2.0 {
            return;
        }
        let cov = <InsModel as Model>::covariance(&e.state);
        let n = (cov.len() as f64).sqrt().round() as usize;
        let p = Matrix3::from_fn(|r, c| cov[(6 + r) * n + 6 + c]);
        let truth = scenario.truth_at(e.key.t_ns);
        let q = e.state.q();
        // Local error: q_true = q Exp(δθ).
        let d = (q.inverse() * truth.attitude).scaled_axis();
        out.attitude.0 += d.dot(&p.cholesky().expect("P_θθ positive definite").solve(&d));
        out.attitude.1 += 1;
        // The tilt: δθ across body up.
        let u = q.inverse_transform_vector(&Vector3::z());
        let a = u.cross(&Vector3::x()).normalize();
        let b = u.cross(&a);
        let basis = nalgebra::Matrix2x3::from_rows(&[a.transpose(), b.transpose()]);
        let (dt, pt) = (basis * d, basis * p * basis.transpose());
        out.tilt.0 += dt.dot(&Matrix2::from(pt).cholesky().expect("tilt positive definite").solve(&dt));
        out.tilt.1 += 1;
        out.heading_end = common::heading_error(&q, &cov, &truth.attitude).0;
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    assert_eq!(engine.totals(Some(SampleKind::Attitude)).refused, out.ahrs.2);
    out
}

fn per_dof(runs: &[Run], f: impl Fn(&Run) -> (f64, u64), dof: f64) -> f64 {
    let (s, n) = runs.iter().map(f).fold((0.0, 0), |(s, n), (a, b)| (s + a, n + b));
    s / n as f64 / dof
}

#[test]
fn an_ahrs_sets_and_holds_the_attitude_consistently() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9700 + seed, true, 0.0, 1.0)).collect();
    let nees = per_dof(&runs, |r| r.attitude, 3.0);
    let (fused, gated, refused) =
        runs.iter().fold((0, 0, 0), |(f, g, r), x| (f + x.ahrs.0, g + x.ahrs.1, r + x.ahrs.2));
    println!(
        "AHRS, full attitude: attitude NEES/dof {nees:.3}; AHRS samples fused {fused}, gated {gated}, refused {refused}"
    );
    assert!((0.75..=1.35).contains(&nees), "attitude NEES/dof {nees}");
    // The gate's own false alarms (probability 0.9999) and nothing else.
    assert!(refused == 0 && gated * 1000 < fused, "gated {gated}, refused {refused}");
    assert!(fused > RUNS * 2900, "{fused}");
}

#[test]
fn roll_and_pitch_alone_leave_a_wrong_ahrs_yaw_out() {
    let tilt_only: Vec<Run> = (0..RUNS).map(|seed| run(9800 + seed, false, WRONG_YAW, 0.02)).collect();
    let right_yaw: Vec<Run> = (0..RUNS).map(|seed| run(9800 + seed, false, 0.0, 0.02)).collect();
    let full: Vec<Run> = (0..RUNS).map(|seed| run(9800 + seed, true, WRONG_YAW, 1.0)).collect();
    let tilt = per_dof(&tilt_only, |r| r.tilt, 2.0);
    let worst = tilt_only.iter().map(|r| r.heading_end.abs()).fold(0.0, f64::max);
    // Roll and pitch do not see a turn about world up: the heading is the
    // same, to rounding, whatever the AHRS's yaw.
    let moved =
        tilt_only.iter().zip(&right_yaw).map(|(a, b)| (a.heading_end - b.heading_end).abs()).fold(0.0, f64::max);
    let followed = full.iter().map(|r| (r.heading_end - WRONG_YAW).abs()).fold(0.0, f64::max);
    println!(
        "AHRS yaw 30° off: roll/pitch only: tilt NSE/dof {tilt:.3}, worst heading error at the end {:.2}° (its own \
         drift; {moved:.1e} rad from the runs with the AHRS's yaw right); full: worst distance from the AHRS's wrong \
         yaw {:.2}°",
        worst.to_degrees(),
        followed.to_degrees()
    );
    assert!((0.5..=1.5).contains(&tilt), "tilt NSE/dof {tilt}");
    assert!(moved < 1e-9, "the AHRS's yaw moved the heading by {moved} rad");
    assert!(followed < 1f64.to_radians(), "full fusion follows the AHRS: {followed}");
}
