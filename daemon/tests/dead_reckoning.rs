//! A ground vehicle dead-reckoning: two MEMS IMUs, wheel odometry, the motion
//! constraint and standstill detection; no GNSS and no heading source. Nothing
//! observes the yaw or the horizontal position: they must keep or grow their σ,
//! and stay consistent, through turns, stops and reversing.
//!
//! Each run: 90 s of a car-like drive with three stops (the first two followed
//! by 4 s and 5 s of reversing, the second standing 10 s), 50 Hz wheel odometry;
//! the start drawn from its σ (yaw 1°).
//!
//! The velocity at the start is unknown (σ 3 m/s): a velocity known in the
//! world frame would be a heading.
//!
//! Held over 100 runs (from 2 s on): NEES/dof of position and velocity, and of
//! the yaw, in [0.75, 1.35]; the yaw σ never below its start (to 1 %: the
//! yaw is about the estimated up, which moves while the tilt converges). No
//! update moves the heading where nothing observes it
//! ([`fusion_daemon::model::ins::observability`]); without that rule the yaw σ
//! fell to 0.56 of its start in the first second of driving while the yaw
//! error did not fall. With the odometry scale as a state (`[model.odometry_scale]`, its
//! error drawn with σ 1 %): the scale's NEES in [0.5, 1.5] and its σ never
//! below what the wheels and the IMU can teach (they do observe it: the IMU's
//! accelerations against the wheels' speed changes).
//!
//! `cargo test --release -p fusion-daemon --test dead_reckoning -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{ImuOutput, OdometryConfig, Scenario, ScenarioConfig, Stop};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::measurement::Steps;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::Sample;

const SIGMA0: [f64; 5] = [0.5, 3.0, 0.0175, 0.05, 0.0005];
const RUNS: u64 = 100;
const STOPS: [Stop; 3] = [
    Stop { at_s: 15.0, duration_s: 3.0, reverse_s: 4.0 },
    Stop { at_s: 40.0, duration_s: 10.0, reverse_s: 5.0 },
    Stop { at_s: 70.0, duration_s: 3.0, reverse_s: 0.0 },
];

#[derive(Debug, Default)]
struct Run {
    /// (sum, steps) of the p/v NEES (6 dof), the yaw's normalised squared error.
    pv: (f64, u64),
    yaw: (f64, u64),
    /// The yaw σ at the start and its smallest after.
    yaw_sd: (f64, f64),
    /// The scale's normalised squared error (sum, steps), when it is a state.
    scale: (f64, u64),
    /// Odometry samples fused, of all.
    wheels: (u64, u64),
    err0: f64,
    err_end: f64,
}

fn run(seed: u64, scale_std: Option<f64>) -> Run {
    let imu = |spec| common::car::imu(spec, SIGMA0[3], SIGMA0[4]);
    let scale_error = match scale_std {
        Some(sd) => {
            use rand::SeedableRng;
            use rand_distr::{Distribution, StandardNormal};
            let n: f64 = StandardNormal.sample(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5ca1e));
            n * sd
        }
        None => 0.0,
    };
    let mut c = ScenarioConfig {
        seed,
        duration_s: 90.0,
        imu: imu(&common::car::IMUS[0]),
        extra_imus: vec![imu(&common::car::IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        stops: STOPS.to_vec(),
        ..Default::default()
    };
    c.aiding.push(Arc::new(OdometryConfig {
        sensor: 4,
        lever_arm_m: [0.0; 3],
        scale_error,
        scale_in_variance: scale_std.is_none(),
        ..Default::default()
    }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (t0, x0, p0) = common::ins_start_values(&scenario, seed, SIGMA0);
    let fmt = common::toml_list;
    let scale = scale_std.map_or(String::new(), |sd| format!("[model.odometry_scale]\ninitial_std = {sd}\n"));
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n[model.standstill]\n{scale}\
         [filter]\ninitial_state = [{}]\ninitial_covariance_diagonal = [{}]\n\
         [[sensor]]\nname = \"wheels\"\nid = 4\nkinds = [\"odometry\"]\n{}",
        fmt(&x0),
        fmt(&p0),
        common::car::imu_sensors()
    ))
    .unwrap();
    match InsBuilt::from_config(&config).unwrap() {
        InsBuilt::Core(model) => drive(model, &config, &scenario, t0, None),
        InsBuilt::Aux1(model) => drive(model, &config, &scenario, t0, Some(1.0 + scale_error)),
        _ => unreachable!("one auxiliary state at most"),
    }
}

fn drive<const D: usize>(
    model: InsModel<D>,
    config: &Config,
    scenario: &Scenario,
    t0: u64,
    true_scale: Option<f64>,
) -> Run
where
    InsModel<D>: Steps<State = fusion_daemon::model::ins::InsState<D>>,
{
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let mut sink = |e: &Entry<_>| {
        if let Sample::Odometry(_) = &e.sample {
            out.wheels.1 += 1;
            out.wheels.0 += u64::from(matches!(e.outcome, StepOutcome::Fused { .. }));
        }
        if !matches!(e.sample, Sample::Imu(_)) {
            return;
        }
        let cov = <InsModel<D> as Model>::covariance(&e.state);
        let truth = scenario.truth_at(e.key.t_ns);
        let (err, sd) = common::heading_error(&e.state.q(), &cov, &truth.attitude);
        if out.yaw_sd.0 == 0.0 {
            out.yaw_sd = (sd, sd);
            out.err0 = err;
        }
        out.err_end = err;
        out.yaw_sd.1 = out.yaw_sd.1.min(sd);
        if e.key.t_ns.saturating_sub(t0) < 2_000_000_000 {
            return;
        }
        let (_, nees) = common::pv_error_and_nees(<InsModel<D> as Model>::x(&e.state), &cov, &truth);
        out.pv = (out.pv.0 + nees, out.pv.1 + 1);
        out.yaw = (out.yaw.0 + (err / sd).powi(2), out.yaw.1 + 1);
        let scale_index = e.state.aux_index(fusion_shared::snapshot::aux::ODOMETRY_SCALE);
        if let (Some(k), Some(i), Some(truth_k)) = (e.state.odometry_scale(), scale_index, true_scale) {
            out.scale = (out.scale.0 + (k - truth_k).powi(2) / e.state.filter().variance(i), out.scale.1 + 1);
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

fn mean(runs: &[Run], f: impl Fn(&Run) -> (f64, u64)) -> f64 {
    let (s, n) = runs.iter().map(f).fold((0.0, 0), |(s, n), (a, b)| (s + a, n + b));
    s / n as f64
}

#[test]
fn dead_reckoning_stays_consistent_and_its_yaw_sigma_never_falls() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9900 + seed, None)).collect();
    let pv = mean(&runs, |r| r.pv) / 6.0;
    let yaw = mean(&runs, |r| r.yaw);
    let lowest = runs.iter().map(|r| r.yaw_sd.1 / r.yaw_sd.0).fold(f64::INFINITY, f64::min);
    let rms = |f: &dyn Fn(&Run) -> f64| (runs.iter().map(|r| f(r).powi(2)).sum::<f64>() / runs.len() as f64).sqrt();
    let wheels = runs.iter().fold((0, 0), |(f, n), r| (f + r.wheels.0, n + r.wheels.1));
    println!(
        "dead reckoning, {RUNS} runs: NEES/dof p,v {pv:.3}; yaw {yaw:.3}; yaw error RMS {:.2}° at the start, {:.2}° at \
         the end; the yaw σ at least {lowest:.4} of its start; wheels fused {:.1} %",
        rms(&|r| r.err0).to_degrees(),
        rms(&|r| r.err_end).to_degrees(),
        100.0 * wheels.0 as f64 / wheels.1 as f64
    );
    assert!((0.75..=1.35).contains(&pv), "p,v NEES/dof {pv}");
    assert!((0.75..=1.35).contains(&yaw), "yaw NEES {yaw}");
    // Nothing observes the heading, and no update moves it: its σ does not
    // fall (within 1 %: the yaw is about the estimated up, which turns while
    // the tilt converges in the first second; 2 ‰ at most on these drives,
    // 5 ‰ on other seeds). Without the rule it fell to 0.56 of its start.
    assert!(lowest >= 0.99, "the yaw σ fell to {lowest} of its start");
}

#[test]
fn the_odometry_scale_stays_consistent_without_gnss() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9950 + seed, Some(0.01))).collect();
    let pv = mean(&runs, |r| r.pv) / 6.0;
    let scale = mean(&runs, |r| r.scale);
    println!("dead reckoning with the scale as a state, {RUNS} runs: NEES/dof p,v {pv:.3}; scale {scale:.3}");
    assert!((0.5..=1.5).contains(&scale), "scale NEES {scale}");
    assert!((0.75..=1.35).contains(&pv), "p,v NEES/dof {pv}");
}
