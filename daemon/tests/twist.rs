//! A ground robot with visual odometry's twist: consistency with the twist in the
//! stream, and what it adds.
//!
//! Each run: 60 s of a car-like drive (two 200 Hz MEMS IMUs, GNSS
//! latitude/longitude/height of an antenna 1.5 m from the IMUs at 1 Hz, no
//! Doppler velocity, no motion constraint) and a 20 Hz twist from a camera
//! mounted with forward-right-down axes, pitched down 10° and 0.8 m ahead of
//! and 1.2 m above the IMUs (0.05 m/s and 0.01 rad/s noise per axis, 30–80 ms
//! late, 2 % lost); the initial state drawn from its σ.
//!
//! Held over 20 runs: the position-and-velocity NEES/dof in [0.8, 1.25] from 2 s
//! on, the twist's mean NIS/dof in [0.8, 1.25], and the velocity RMSE with the
//! twist below the one without it (the same drives, GNSS alone). Reported: both
//! RMSEs.
//!
//! `cargo test --release -p fusion-daemon --test twist -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{GeodeticConfig, PositionConfig, Scenario, TwistConfig};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const CAMERA_ARM: [f64; 3] = [0.8, 0.0, 1.2];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const RUNS: u64 = 20;

#[derive(Debug, Default)]
struct Run {
    nees: (f64, u64),
    nis: (f64, u64),
    /// Sum of squared velocity errors, and steps.
    velocity: (f64, u64),
}

fn run(seed: u64, with_twist: bool) -> Run {
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, rate_hz: 1.0, ..Default::default() };
    let mut c = common::car::drive(seed, 60.0, SIGMA0);
    let mount = UnitQuaternion::from_euler_angles(0.0, 10f64.to_radians(), 0.0).to_rotation_matrix().into_inner()
        * Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    if with_twist {
        c.aiding.push(Arc::new(TwistConfig {
            sensor: 4,
            rotation: mount,
            lever_arm_m: CAMERA_ARM,
            dropout_probability: 0.02,
            ..Default::default()
        }));
    }
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (t0, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let fmt = common::toml_list;
    let sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\nlever_arm_m = [{}]\n\
         [[sensor]]\nname = \"camera\"\nid = 4\nkinds = [\"twist\"]\naxes = \"frd\"\nrotation_rpy_deg = [0, 10, 0]\n\
         lever_arm_m = [{}]\n",
        fmt(&LEVER_ARM),
        fmt(&CAMERA_ARM),
    );
    let config = Config::parse(&common::car::ins_config(&filter, &DATUM, &sensors)).unwrap();
    let InsBuilt::Core(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("no scale state") };
    drive(model, &config, &scenario, t0)
}

fn drive(model: InsModel, config: &Config, scenario: &Scenario, t0: u64) -> Run {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let mut sink = |e: &Entry<_>| {
        if let (Sample::Twist(_), StepOutcome::Fused { nis } | StepOutcome::Gated { nis }) = (&e.sample, e.outcome) {
            out.nis.0 += nis;
            out.nis.1 += 1;
        }
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        if !matches!(e.sample, Sample::Imu(_)) || t < 2.0 {
            return;
        }
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel as Model>::covariance(&e.state));
        let truth = scenario.truth_at(e.key.t_ns);
        let (err, nees) = common::pv_error_and_nees(x, &cov, &truth);
        out.nees.0 += nees;
        out.nees.1 += 1;
        out.velocity.0 += err.fixed_rows::<3>(3).norm_squared();
        out.velocity.1 += 1;
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

#[test]
fn a_twist_is_fused_consistently() {
    let with: Vec<Run> = (0..RUNS).map(|seed| run(9500 + seed, true)).collect();
    let without: Vec<Run> = (0..RUNS).map(|seed| run(9500 + seed, false)).collect();
    let nees = common::pooled_mean(&with, |r| r.nees) / 6.0;
    let nis = common::pooled_mean(&with, |r| r.nis) / 6.0;
    let rmse = common::pooled_mean(&with, |r| r.velocity).sqrt();
    let rmse_without = common::pooled_mean(&without, |r| r.velocity).sqrt();
    eprintln!(
        "{RUNS} runs with a 20 Hz twist: NEES/dof (p, v) {nees:.2}, twist NIS/dof {nis:.2}; velocity RMSE {rmse:.3} m/s (GNSS at 1 Hz alone: {rmse_without:.3} m/s, NEES/dof {:.2})",
        common::pooled_mean(&without, |r| r.nees) / 6.0
    );
    assert!((0.8..=1.25).contains(&nees), "NEES/dof {nees}");
    assert!((0.8..=1.25).contains(&nis), "twist NIS/dof {nis}");
    assert!(rmse < rmse_without, "the twist helps: {rmse} vs {rmse_without}");
}
