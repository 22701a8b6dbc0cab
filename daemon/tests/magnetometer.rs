//! A car with a magnetometer: consistency with the field in the stream, and a
//! magnetic disturbance that must be refused.
//!
//! Each run: 60 s of a car-like drive (two 200 Hz MEMS IMUs, GNSS
//! latitude/longitude/height and Doppler velocity of an antenna 1.5 m from the
//! IMUs at 10 Hz, the land-vehicle motion constraint) and a 20 Hz magnetometer
//! mounted with forward-right-down axes turned 90° (0.5 µT noise per axis,
//! Munich's field: declination 3.5°, inclination 64.5°, 48.5 µT, 2 % of its
//! samples lost); the initial state drawn from its σ, the heading's 0.3 rad. From
//! 30 s to 35 s a disturbance (a lorry alongside) adds 30 µT pointing east.
//!
//! Held over 20 runs: the position-and-velocity NEES/dof in [0.8, 1.25] and the
//! heading's normalised squared error in [0.5, 1.5] (from 2 s on); every
//! disturbed sample refused and counted as refused, none of the others; during
//! the disturbance the heading's normalised squared error at most 1.5 and at
//! most 1 % of the steps outside 3σ. Reported beside: the same drives with the
//! disturbance checks opened wide, where the χ² gate refuses what it can, and
//! with the gate off too (the disturbed samples fused).
//!
//! `cargo test --release -p fusion-daemon --test magnetometer -- --nocapture`.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use fusion_client::sim::{
    GeodeticConfig, ImuOutput, MagneticDisturbance, MagnetometerConfig, PositionConfig, Scenario, ScenarioConfig,
    VelocityConfig,
};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::geodesy::Datum;
use fusion_shared::{Sample, SampleKind};
use nalgebra::{UnitQuaternion, Vector3};

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const HEADING_SD: f64 = 0.3;
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const DISTURBANCE: MagneticDisturbance =
    MagneticDisturbance { at_s: 30.0, duration_s: 5.0, field_ut: [30.0, 0.0, 0.0] };
const RUNS: u64 = 20;

/// What guards the estimate against disturbed samples.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Guard {
    /// The disturbance checks and the gate.
    Checks,
    /// The gate alone (the checks opened wide).
    Gate,
    /// Nothing.
    Nothing,
}

#[derive(Debug, Default)]
struct Run {
    nees: (f64, u64),
    heading: (f64, u64),
    /// Magnetometer samples inside the disturbance: refused, gated, fused.
    disturbed: (u64, u64, u64),
    /// Outside it: fused, gated, refused.
    clean: (u64, u64, u64),
    /// Heading: sum of squared normalised errors, steps outside 3σ, steps,
    /// during the disturbance; and its worst |error| / σ there.
    in_disturbance: (f64, u64, u64),
    worst_in_disturbance: f64,
    refused_counter: u64,
    /// Re-initialisations after a lock-out of the fixes.
    reinitialisations: u64,
}

fn run(seed: u64, guard: Guard, heading_sd: f64) -> Run {
    let imu = |spec| common::car::imu(spec, SIGMA0[3], SIGMA0[4]);
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() };
    let mut c = ScenarioConfig {
        seed,
        duration_s: 60.0,
        imu: imu(&common::car::IMUS[0]),
        extra_imus: vec![imu(&common::car::IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        ..Default::default()
    };
    let mount = UnitQuaternion::from_euler_angles(0.0, 0.0, PI / 2.0).to_rotation_matrix().into_inner()
        * nalgebra::Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    c.aiding.push(Arc::new(VelocityConfig { sensor: 3, lever_arm_m: LEVER_ARM, ..Default::default() }));
    c.aiding.push(Arc::new(MagnetometerConfig {
        sensor: 5,
        rotation: mount,
        dropout_probability: 0.02,
        disturbances: vec![DISTURBANCE],
        ..Default::default()
    }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    // The prior's draw, then the heading turned with its own σ.
    let (t0, mut x0, mut p0) = common::ins_start_values(&scenario, seed, SIGMA0);
    let turn: f64 = {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x3a9);
        let n: f64 = StandardNormal.sample(&mut rng);
        n * heading_sd
    };
    common::turn_heading(&mut x0, turn);
    p0[8] = heading_sd * heading_sd;
    let fmt = common::toml_list;
    let sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\nlever_arm_m = [{}]\n\
         [[sensor]]\nname = \"compass\"\nid = 5\nkinds = [\"magnetometer\"]\naxes = \"frd\"\n\
         rotation_rpy_deg = [0, 0, 90]\n[sensor.magnetic]\ndeclination_deg = 3.5\ninclination_deg = 64.5\n\
         strength_ut = 48.5\n{}{}",
        fmt(&LEVER_ARM),
        if guard == Guard::Checks { "" } else { "max_strength_deviation = 0.99\nmax_inclination_deviation_deg = 90\n" },
        common::car::imu_sensors()
    );
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n\
         [filter]\ninitial_state = [{}]\ninitial_covariance_diagonal = [{}]\n\
         {gating}[datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n{sensors}",
        fmt(&x0),
        fmt(&p0),
        DATUM.latitude_deg,
        DATUM.longitude_deg,
        DATUM.height_m,
        gating = if guard == Guard::Nothing { "" } else { "[gating]\nprobability = 0.9999\n" },
    ))
    .unwrap();
    let InsBuilt::Core(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("no scale state") };
    drive(model, &config, &scenario, t0)
}

fn drive(model: InsModel, config: &Config, scenario: &Scenario, t0: u64) -> Run {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let start_ns = scenario.start_ns;
    let mut sink = |e: &Entry<_>| {
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        out.reinitialisations = <InsModel as Model>::diagnostics(&e.state).reinitialisations;
        if let Sample::Magnetometer(m) = &e.sample {
            let ts = (m.header.t_ns - start_ns) as f64 * 1e-9;
            let inside = (DISTURBANCE.at_s..DISTURBANCE.at_s + DISTURBANCE.duration_s).contains(&ts);
            let refused = e.outcome == StepOutcome::Refused;
            let gated = matches!(e.outcome, StepOutcome::Gated { .. });
            match (inside, refused, gated) {
                (true, true, _) => out.disturbed.0 += 1,
                (true, _, true) => out.disturbed.1 += 1,
                (true, false, false) => out.disturbed.2 += 1,
                (false, true, _) => out.clean.2 += 1,
                (false, _, true) => out.clean.1 += 1,
                (false, false, false) => out.clean.0 += 1,
            }
        }
        if !matches!(e.sample, Sample::Imu(_)) || t < 2.0 {
            return;
        }
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel as Model>::covariance(&e.state));
        let truth = scenario.truth_at(e.key.t_ns);
        let (_, nees) = common::pv_error_and_nees(x, &cov, &truth);
        out.nees.0 += nees;
        out.nees.1 += 1;
        let (err, sd) = common::heading_error(&e.state.q(), &cov, &truth.attitude);
        out.heading.0 += (err / sd).powi(2);
        out.heading.1 += 1;
        if (DISTURBANCE.at_s..DISTURBANCE.at_s + DISTURBANCE.duration_s).contains(&t) {
            let d = &mut out.in_disturbance;
            (d.0, d.1, d.2) = (d.0 + (err / sd).powi(2), d.1 + u64::from(err.abs() > 3.0 * sd), d.2 + 1);
            out.worst_in_disturbance = out.worst_in_disturbance.max(err.abs() / sd);
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out.refused_counter = engine.totals(Some(SampleKind::Magnetometer)).refused;
    // The history is empty after the flush: the count is the last entry's (in the sink).
    out
}

/// Sums of `(NSE, outside 3σ, steps)` during the disturbance and the worst |error|/σ there.
fn disturbance_figures(runs: &[Run]) -> (f64, f64, f64) {
    let (nse, outside, n) = runs
        .iter()
        .fold((0.0, 0, 0), |(a, b, c), r| (a + r.in_disturbance.0, b + r.in_disturbance.1, c + r.in_disturbance.2));
    let worst = runs.iter().map(|r| r.worst_in_disturbance).fold(0.0, f64::max);
    (nse / n as f64, outside as f64 / n as f64, worst)
}

/// The magnetometer in the stream: consistent; a disturbance refused, counted,
/// and harmless to the heading.
#[test]
fn a_magnetometer_is_fused_and_its_disturbances_refused() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9300 + seed, Guard::Checks, HEADING_SD)).collect();
    let sum = |f: &dyn Fn(&Run) -> (f64, u64)| runs.iter().map(f).fold((0.0, 0), |(s, n), (a, b)| (s + a, n + b));
    let (nees, n) = sum(&|r| r.nees);
    let nees = nees / n as f64 / 6.0;
    let (heading, n) = sum(&|r| r.heading);
    let heading = heading / n as f64;
    let disturbed = |runs: &[Run]| {
        runs.iter().fold((0, 0, 0), |(a, b, c), r| (a + r.disturbed.0, b + r.disturbed.1, c + r.disturbed.2))
    };
    let (refused, gated, fused) = disturbed(&runs);
    let clean = runs.iter().fold((0, 0, 0), |(a, b, c), r| (a + r.clean.0, b + r.clean.1, c + r.clean.2));
    let (nse, outside, worst) = disturbance_figures(&runs);
    eprintln!(
        "{RUNS} runs with a 20 Hz magnetometer: NEES/dof (p, v) {nees:.2}, heading normalised squared error \
         {heading:.2}; disturbed samples refused {} of {}, clean ones fused {} of {} ({} gated); during the disturbance the \
         heading's normalised squared error {nse:.2}, {:.2} % of steps outside 3 sigma, worst {worst:.2} sigma",
        refused,
        refused + gated + fused,
        clean.0,
        clean.0 + clean.1 + clean.2,
        clean.1,
        outside * 100.0,
    );
    for (guard, name) in [(Guard::Gate, "the gate alone"), (Guard::Nothing, "no gate either")] {
        let other: Vec<Run> = (0..RUNS).map(|seed| run(9300 + seed, guard, HEADING_SD)).collect();
        let (nse, outside, worst) = disturbance_figures(&other);
        let (_, gated, fused) = disturbed(&other);
        eprintln!(
            "  checks opened wide, {name}: disturbed samples gated {gated}, fused {fused}; during the disturbance the \
             heading's normalised squared error {nse:.1}, {:.1} % of steps outside 3 sigma, worst {worst:.1} sigma",
            outside * 100.0
        );
        if guard == Guard::Nothing {
            assert!(fused > 0 && nse > 3.0, "fused, the disturbance pulls the heading: {nse}");
        }
    }
    assert!((0.8..=1.25).contains(&nees), "NEES/dof {nees}");
    assert!((0.5..=1.5).contains(&heading), "heading normalised squared error {heading}");
    assert!(refused > 0 && gated + fused == 0, "every disturbed sample refused: {refused} {gated} {fused}");
    assert_eq!(clean.2, 0, "no clean sample refused");
    for (seed, r) in runs.iter().enumerate() {
        assert_eq!(r.refused_counter, r.disturbed.0, "run {seed}: the sensor's refused counter");
    }
    assert!(nse <= 1.5 && outside <= 0.01, "during the disturbance: {nse}, {outside}");
}

/// The heading unknown at start (σ 1 rad, drawn with it) and no course
/// alignment: the first magnetometer sample with the tilt known aligns it from
/// the tilt-compensated field. No lock-out, and consistent from 2 s on (the
/// linearised update alone locked 3 of 24 drives out, NEES/dof 1.55).
#[test]
fn an_unknown_heading_is_found_from_the_field() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9400 + seed, Guard::Checks, 1.0)).collect();
    let (nees, n) = runs.iter().fold((0.0, 0), |(s, k), r| (s + r.nees.0, k + r.nees.1));
    let nees = nees / n as f64 / 6.0;
    let (heading, n) = runs.iter().fold((0.0, 0), |(s, k), r| (s + r.heading.0, k + r.heading.1));
    let heading = heading / n as f64;
    let locked: u64 = runs.iter().map(|r| r.reinitialisations).sum();
    eprintln!(
        "{RUNS} runs with the heading unknown (1 rad): NEES/dof (p, v) {nees:.2}, heading normalised squared error \
         {heading:.2}, lock-outs {locked}"
    );
    assert_eq!(locked, 0, "no lock-out");
    assert!((0.75..=1.35).contains(&nees), "NEES/dof {nees}");
    assert!((0.5..=1.5).contains(&heading), "heading normalised squared error {heading}");
}
