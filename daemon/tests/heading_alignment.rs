//! A car that starts with its heading unknown: the heading taken from the GNSS
//! course over ground (`[model.alignment] heading_from_velocity_mps`) against the
//! filter left to find it through its cross-covariances.
//!
//! Each run: 20 s of a car-like drive (two 200 Hz MEMS IMUs, GNSS
//! latitude/longitude/height and Doppler velocity of an antenna 1.5 m from the
//! IMUs at 10 Hz, the land-vehicle motion constraint); the initial position,
//! velocity, roll, pitch and biases drawn from their configured σ, the heading
//! anywhere (uniform over ±180°, configured σ 104°, the uniform's).
//!
//! Held with the course alignment: after the first second every run's heading is
//! within 3σ of the truth, and the position-and-velocity NEES/dof from 1 s on is
//! in [0.6, 1.5] (over 20 runs). Reported for both: NEES/dof over the first 5 s
//! and from 5 s on, the heading error at 2 s, the share of estimates outside
//! 3σ on any of the six components.
//!
//! `cargo test --release -p fusion-daemon --test heading_alignment -- --nocapture`.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use fusion_client::sim::{GeodeticConfig, ImuOutput, PositionConfig, Scenario, ScenarioConfig, VelocityConfig};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;
use rand::SeedableRng;
use rand_distr::{Distribution, Uniform};

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
/// The σ of a heading uniform over ±π: π/√3.
const HEADING_SD: f64 = 1.813_799_364_234_217_8;
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const RUNS: u64 = 20;

#[derive(Debug, Default)]
struct Run {
    /// NEES sums and steps over [0, 1), [1, 5) and [5, 20) s.
    nees: [(f64, u64); 3],
    /// Steps with a component outside 3σ, of all steps from 1 s on.
    outside: u64,
    /// Heading error, rad, and its σ at 2 s, and the worst |error|/σ from 1 s on.
    at_2s: (f64, f64),
    worst_heading: f64,
    /// The initial heading error, rad.
    initial: f64,
}

fn run(seed: u64, aligned: bool) -> Run {
    let imu = |spec| common::car::imu(spec, SIGMA0[3], SIGMA0[4]);
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() };
    let mut c = ScenarioConfig {
        seed,
        duration_s: 20.0,
        imu: imu(&common::car::IMUS[0]),
        extra_imus: vec![imu(&common::car::IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        ..Default::default()
    };
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    c.aiding.push(Arc::new(VelocityConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    // The prior's draw, then the heading turned by an angle anywhere.
    let (t0, mut x0, mut p0) = common::ins_start_values(&scenario, seed, SIGMA0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xbead);
    let initial = Uniform::new(-PI, PI).unwrap().sample(&mut rng);
    common::turn_heading(&mut x0, initial);
    p0[8] = HEADING_SD * HEADING_SD;
    let fmt = common::toml_list;
    let sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\nlever_arm_m = [{}]\n{}",
        fmt(&LEVER_ARM),
        common::car::imu_sensors()
    );
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n{alignment}\
         [filter]\ninitial_state = [{}]\ninitial_covariance_diagonal = [{}]\n\
         [gating]\nprobability = 0.9999\n[datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n{sensors}",
        fmt(&x0),
        fmt(&p0),
        DATUM.latitude_deg,
        DATUM.longitude_deg,
        DATUM.height_m,
        alignment = if aligned { "[model.alignment]\nheading_from_velocity_mps = 3.0\n" } else { "" },
    ))
    .unwrap();
    let InsBuilt::Core(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("no scale state") };
    assert_eq!(model.course_alignment().is_some(), aligned);
    let mut out = drive(model, &config, &scenario, t0);
    out.initial = initial;
    out
}

fn drive(model: InsModel, config: &Config, scenario: &Scenario, t0: u64) -> Run {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let mut sink = |e: &Entry<_>| {
        if !matches!(e.sample, Sample::Imu(_)) {
            return;
        }
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel as Model>::covariance(&e.state));
        let truth = scenario.truth_at(e.key.t_ns);
        let (err, nees) = common::pv_error_and_nees(x, &cov, &truth);
        let slot = if t < 1.0 {
            0
        } else if t < 5.0 {
            1
        } else {
            2
        };
        out.nees[slot].0 += nees;
        out.nees[slot].1 += 1;
        if t < 1.0 {
            return;
        }
        let n = (cov.len() as f64).sqrt().round() as usize;
        out.outside += u64::from((0..6).any(|i| err[i].abs() > 3.0 * cov[i * n + i].sqrt()));
        let (e, sd) = common::heading_error(&e.state.q(), &cov, &truth.attitude);
        out.worst_heading = out.worst_heading.max(e.abs() / sd);
        if out.at_2s == (0.0, 0.0) && t >= 2.0 {
            out.at_2s = (e, sd);
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

/// Runs both setups over the same drives; returns (aligned, unaligned).
fn report() -> (Vec<Run>, Vec<Run>) {
    let both: Vec<(Run, Run)> = (0..RUNS).map(|seed| (run(9100 + seed, true), run(9100 + seed, false))).collect();
    let (on, off): (Vec<Run>, Vec<Run>) = both.into_iter().unzip();
    for (name, runs) in [("heading from the course over ground", &on), ("heading left to the filter", &off)] {
        let nees = |slot: usize| {
            let (sum, n) = runs.iter().fold((0.0, 0), |(s, n), r| (s + r.nees[slot].0, n + r.nees[slot].1));
            sum / n as f64 / 6.0
        };
        let steps: u64 = runs.iter().map(|r| r.nees[1].1 + r.nees[2].1).sum();
        let outside = runs.iter().map(|r| r.outside).sum::<u64>() as f64 / steps as f64;
        let mut at_2s: Vec<f64> = runs.iter().map(|r| r.at_2s.0.abs().to_degrees()).collect();
        at_2s.sort_by(f64::total_cmp);
        let worst = runs.iter().map(|r| r.worst_heading).fold(0.0, f64::max);
        eprintln!(
            "{RUNS} runs, {name}: NEES/dof (p, v) 0-1 s {:.2}, 1-5 s {:.2}, 5-20 s {:.2}; {:.2} % of estimates from 1 s \
             with a component outside 3 sigma; heading error at 2 s median {:.2} deg, worst {:.2} deg; worst heading \
             error from 1 s on {worst:.1} sigma",
            nees(0),
            nees(1),
            nees(2),
            outside * 100.0,
            at_2s[at_2s.len() / 2],
            at_2s[at_2s.len() - 1],
        );
    }
    (on, off)
}

/// With the course alignment the filter is consistent from its first second on,
/// whatever the heading it started with; without it, it is reported (it is not).
#[test]
fn an_unknown_heading_is_taken_from_the_course() {
    let (on, off) = report();
    let nees = |runs: &[Run]| {
        let (sum, n) =
            runs.iter().fold((0.0, 0), |(s, n), r| (s + r.nees[1].0 + r.nees[2].0, n + r.nees[1].1 + r.nees[2].1));
        sum / n as f64 / 6.0
    };
    let (aligned, unaligned) = (nees(&on), nees(&off));
    assert!((0.6..=1.5).contains(&aligned), "NEES/dof from 1 s with the alignment: {aligned}");
    for (seed, r) in on.iter().enumerate() {
        assert!(
            r.worst_heading < 3.0,
            "run {seed} (initial heading error {:.0} deg): heading error {:.1} sigma after the first second",
            r.initial.to_degrees(),
            r.worst_heading
        );
    }
    assert!(unaligned > aligned, "the alignment makes a difference: {unaligned} vs {aligned}");
}
