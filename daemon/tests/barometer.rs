//! A vehicle with a barometer: consistency with the pressure altitude in the
//! stream, its bias state, and the height it holds through a GNSS outage.
//!
//! Each run: 60 s of a car-like drive over gentle hills (two 200 Hz MEMS IMUs,
//! GNSS latitude/longitude/height of an antenna 1.5 m from the IMUs at 1 Hz
//! with a 20 s outage at 25 s) and a 20 Hz barometer whose port is 0.3 m above
//! the IMUs (3 Pa noise, about 0.25 m; the world origin at a pressure altitude
//! of 500 m, the weather's offset drifting 0.05 m/√s; 5–20 ms late, 2 % lost);
//! the initial state drawn from its σ.
//!
//! Held over 20 runs: the position-and-velocity NEES/dof in [0.8, 1.25] from
//! 2 s on, the barometer's mean NIS/dof in [0.8, 1.25], the bias' normalised
//! squared error at the end below 3 on average, and the height RMSE in the
//! outage with the barometer below the one without it (the same drives).
//!
//! `cargo test --release -p fusion-daemon --test barometer -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{BarometerConfig, GeodeticConfig, Outage, PositionConfig, Scenario, ScenarioConfig};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const PORT_ARM: [f64; 3] = [0.0, 0.0, 0.3];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const RUNS: u64 = 20;
const OUTAGE: Outage = Outage { at_s: 25.0, duration_s: 20.0 };
const ORIGIN_ALTITUDE_M: f64 = 500.0;

#[derive(Debug, Default)]
struct Run {
    nees: (f64, u64),
    nis: (f64, u64),
    /// Sum of squared height errors in the outage, and steps.
    outage_height: (f64, u64),
    /// The bias' error over its σ at the end, squared (with the barometer).
    bias_nse: f64,
}

fn run(seed: u64, with_baro: bool) -> Run {
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, rate_hz: 1.0, ..Default::default() };
    let mut c = ScenarioConfig { outages: vec![OUTAGE], ..common::car::drive(seed, 60.0, SIGMA0) };
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    if with_baro {
        c.aiding.push(Arc::new(BarometerConfig {
            sensor: 5,
            lever_arm_m: PORT_ARM,
            origin_altitude_m: ORIGIN_ALTITUDE_M,
            drift_m: 0.05,
            dropout_probability: 0.02,
            ..Default::default()
        }));
    }
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (t0, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let fmt = common::toml_list;
    let baro = if with_baro {
        format!(
            "[[sensor]]\nname = \"baro\"\nid = 5\nkinds = [\"barometer\"]\nlever_arm_m = [{}]\n\
             [sensor.barometer]\nbias_random_walk_m = 0.05\n",
            fmt(&PORT_ARM)
        )
    } else {
        String::new()
    };
    let gnss =
        format!("[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\nlever_arm_m = [{}]\n", fmt(&LEVER_ARM));
    let config = Config::parse(&common::car::ins_config(&filter, &DATUM, &(gnss + &baro))).unwrap();
    match InsBuilt::from_config(&config).unwrap() {
        InsBuilt::Core(model) => drive(model, &config, &scenario, t0),
        InsBuilt::Aux1(model) => drive(model, &config, &scenario, t0),
        other => unreachable!("{other:?}"),
    }
}

fn drive<const D: usize>(model: InsModel<D>, config: &Config, scenario: &Scenario, t0: u64) -> Run {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let mut last = None;
    let outage = (t0 + (OUTAGE.at_s * 1e9) as u64)..(t0 + ((OUTAGE.at_s + OUTAGE.duration_s) * 1e9) as u64);
    let mut sink = |e: &Entry<_>| {
        if let (Sample::Barometer(_), StepOutcome::Fused { nis } | StepOutcome::Gated { nis }) = (&e.sample, e.outcome)
        {
            out.nis.0 += nis;
            out.nis.1 += 1;
        }
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        if !matches!(e.sample, Sample::Imu(_)) || t < 2.0 {
            return;
        }
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel<D> as Model>::covariance(&e.state));
        let truth = scenario.truth_at(e.key.t_ns);
        let (err, nees) = common::pv_error_and_nees(x, &cov, &truth);
        out.nees.0 += nees;
        out.nees.1 += 1;
        if outage.contains(&e.key.t_ns) {
            out.outage_height.0 += err.z * err.z;
            out.outage_height.1 += 1;
        }
        if D > 15 {
            last = Some((x[16], cov[15 * D + 15]));
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    if let Some((bias, var)) = last {
        // The sim's offset drifts; its value at the end is the origin's
        // altitude plus the walk, which the scenario does not report: compare
        // with the walk's spread added to the bias' variance.
        let walk_var = 0.05 * 0.05 * 60.0;
        out.bias_nse = (bias - ORIGIN_ALTITUDE_M).powi(2) / (var + walk_var);
    }
    out
}

#[test]
fn a_barometer_is_fused_consistently_and_holds_the_height() {
    let with: Vec<Run> = (0..RUNS).map(|seed| run(9700 + seed, true)).collect();
    let without: Vec<Run> = (0..RUNS).map(|seed| run(9700 + seed, false)).collect();
    let nees = common::pooled_mean(&with, |r| r.nees) / 6.0;
    let nis = common::pooled_mean(&with, |r| r.nis);
    let rmse = common::pooled_mean(&with, |r| r.outage_height).sqrt();
    let rmse_without = common::pooled_mean(&without, |r| r.outage_height).sqrt();
    let bias_nse = with.iter().map(|r| r.bias_nse).sum::<f64>() / RUNS as f64;
    eprintln!(
        "{RUNS} runs with a 20 Hz barometer: NEES/dof (p, v) {nees:.2}, barometer NIS/dof {nis:.2}, bias NSE at the end {bias_nse:.2}; height RMSE in the 20 s outage {rmse:.2} m (without the barometer: {rmse_without:.2} m, NEES/dof {:.2})",
        common::pooled_mean(&without, |r| r.nees) / 6.0
    );
    assert!((0.8..=1.25).contains(&nees), "NEES/dof {nees}");
    assert!((0.8..=1.25).contains(&nis), "barometer NIS/dof {nis}");
    assert!(bias_nse < 3.0, "bias NSE {bias_nse}");
    assert!(rmse < rmse_without, "the barometer holds the height: {rmse} vs {rmse_without}");
}
