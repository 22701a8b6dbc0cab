//! A GNSS receiver whose clock is late: `[[sensor]] time_offset_ns`.
//!
//! Each run: a car-like drive (30 s), a 200 Hz MEMS IMU, geodetic fixes (10 Hz,
//! 0.5 m, antenna 1.5 m from the IMU) stamped 100 ms late by the receiver's clock
//! (a fix valid at `t` says `t + 0.1 s`), arriving 20–120 ms after their stamp.
//!
//! - With the offset configured, the estimate is the one of the same drive with an
//!   exact clock, bit for bit: the offset puts every fix back at its time of
//!   validity before it is ordered.
//! - With it configured the filter is consistent (position-and-velocity NEES/dof
//!   near 1 over the runs); without it, a car at ~9 m/s is fused ~0.9 m off
//!   along its track at every fix, and the NEES shows it.

mod common;

use std::sync::Arc;

use fusion_client::sim::{
    GeodeticConfig, ImuConfig, ImuOutput, PositionConfig, Scenario, ScenarioConfig, VelocityConfig,
};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const LAG_NS: u64 = 100_000_000;

/// A drive of `duration_s` with a 200 Hz MEMS IMU and geodetic fixes of a
/// receiver whose clock is `clock_lag_ns` late.
fn drive(seed: u64, duration_s: f64, clock_lag_ns: u64) -> ScenarioConfig {
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, clock_lag_ns, ..Default::default() };
    let mut c = ScenarioConfig {
        seed,
        duration_s,
        imu: ImuConfig {
            accel_bias_std: SIGMA0[3],
            gyro_bias_std: SIGMA0[4],
            ..ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5)
        },
        imu_output: ImuOutput::BodySpecificForce,
        ..Default::default()
    };
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    c
}

/// The `ins` config with `filter` (`[filter]` lines) and the receiver as sensor 3
/// of `kinds` (a TOML list's contents) with `time_offset_ns`.
fn config(filter: &str, kinds: &str, time_offset_ns: u64) -> Config {
    Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n{filter}\
         [gating]\nprobability = 0.9999\n[datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n\
         [[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [{kinds}]\nlever_arm_m = [{}]\ntime_offset_ns = {time_offset_ns}\n",
        DATUM.latitude_deg,
        DATUM.longitude_deg,
        DATUM.height_m,
        common::toml_list(&LEVER_ARM),
    ))
    .unwrap()
}

/// The run's NEES/dof over the IMU steps after 2 s, and its last estimate.
fn run(seed: u64, clock_lag_ns: u64, configured_offset_ns: u64) -> (f64, Vec<f64>) {
    let c = drive(seed, 30.0, clock_lag_ns);
    let mut scenario = Scenario::generate(&c);
    // No local fixes; and the same geodetic fixes in every run (the drive's end
    // cuts a late-stamped one off earlier).
    let last_valid_ns = scenario.start_ns + 29_500_000_000;
    scenario.arrivals.retain(|a| match a.sample {
        Sample::Position(_) => false,
        Sample::Geodetic(g) => g.header.t_ns - clock_lag_ns <= last_valid_ns,
        _ => true,
    });
    let (t0, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let config = config(&filter, "\"geodetic\"", configured_offset_ns);
    let mut engine = Engine::new(InsModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let (mut nees, mut n, mut last) = (0.0, 0u64, Vec::new());
    let mut sink = |e: &Entry<_>| {
        last = InsModel::x_of(&e.state).to_vec();
        if matches!(e.sample, Sample::Imu(_)) && e.key.t_ns >= t0 + 2_000_000_000 {
            let cov = <InsModel as Model>::covariance(&e.state);
            nees += common::pv_error_and_nees(InsModel::x_of(&e.state), &cov, &scenario.truth_at(e.key.t_ns)).1;
            n += 1;
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    (nees / n as f64 / 6.0, last)
}

#[test]
fn a_late_receiver_clock_is_undone_by_its_configured_offset() {
    let (mut with, mut without) = (Vec::new(), Vec::new());
    for seed in 0..4 {
        let exact = run(9100 + seed, 0, 0);
        let offset = run(9100 + seed, LAG_NS, LAG_NS);
        assert_eq!(offset.1, exact.1, "seed {seed}: the offset puts the fixes back at their time, bit for bit");
        with.push(offset.0);
        without.push(run(9100 + seed, LAG_NS, 0).0);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "GNSS clock 100 ms late, 4 drives of 30 s: NEES/dof with time_offset_ns configured {:.2} (per drive {with:.2?}), \
         without {:.2} (per drive {without:.2?})",
        mean(&with),
        mean(&without)
    );
    assert!((0.6..=1.5).contains(&mean(&with)), "{with:?}");
    assert!(mean(&without) > 2.0 * mean(&with), "the late clock must show without the offset: {without:?}");
}

/// The velocity time offset estimate at the end of a 60 s drive whose GNSS
/// receiver (geodetic fixes and Doppler velocity) is `lag_ns` late, with
/// `configured_ns` in its `[[sensor]]` entry: `(τ̂, σ_τ, samples)`, s.
fn offset_estimate(seed: u64, lag_ns: u64, configured_ns: u64) -> (f64, f64, u64) {
    let mut c = drive(seed, 60.0, lag_ns);
    c.aiding.push(Arc::new(VelocityConfig {
        sensor: 3,
        lever_arm_m: LEVER_ARM,
        clock_lag_ns: lag_ns,
        ..Default::default()
    }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (_, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let config = config(&filter, "\"geodetic\", \"velocity\"", configured_ns);
    let mut engine = Engine::new(InsModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let mut estimate = None;
    let mut sink = |e: &Entry<_>| estimate = <InsModel as Model>::diagnostics(&e.state).velocity_time_offset;
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    estimate.expect("an estimate")
}

/// The diagnostic for setting the offset: with the receiver 100 ms late and no
/// offset configured the estimate says late, and the advice is given (it reads
/// low: about half, see `model::ins::clock`); with the offset configured it says
/// nothing is left.
#[test]
fn the_velocity_residuals_show_how_late_the_clock_is() {
    for seed in 0..3 {
        let (late, late_sd, n) = offset_estimate(9200 + seed, LAG_NS, 0);
        let (left, left_sd, _) = offset_estimate(9200 + seed, LAG_NS, LAG_NS);
        eprintln!(
            "drive {seed}: receiver 100 ms late; estimated {:.1} ± {:.1} ms without the offset ({n} samples), \
             {:+.1} ± {:.1} ms with it",
            late * 1e3,
            late_sd * 1e3,
            left * 1e3,
            left_sd * 1e3
        );
        let advice = fusion_shared::snapshot::time_offset_to_add_ms(late * 1e9, late_sd * 1e9, n);
        assert!(advice.is_some() && (0.03..=0.13).contains(&late), "{late} ± {late_sd}");
        assert!(left.abs() < (3.0 * left_sd).max(0.015), "{left} ± {left_sd}");
    }
}

/// Drives whose receiver clock is right: the diagnostic advises no offset in
/// at least 99 % of them (the advice is what `fusionctl state` and the replay
/// print: [`fusion_shared::snapshot::time_offset_to_add_ms`]).
#[test]
fn a_right_clock_gets_no_advice() {
    let runs: u64 = 100;
    let mut advised = Vec::new();
    let mut worst: f64 = 0.0;
    for seed in 0..runs {
        let (tau, sd, n) = offset_estimate(9300 + seed, 0, 0);
        worst = worst.max((tau / sd).abs());
        if let Some(ms) = fusion_shared::snapshot::time_offset_to_add_ms(tau * 1e9, sd * 1e9, n) {
            advised.push((seed, ms, sd * 1e3));
        }
        eprintln!("drive {seed}: {:+.1} ± {:.1} ms ({n} samples)", tau * 1e3, sd * 1e3);
    }
    eprintln!("{} of {runs} advised: {advised:?}; largest |τ̂|/σ {worst:.1}", advised.len());
    assert!(advised.len() * 100 <= runs as usize, "{advised:?}");
}
