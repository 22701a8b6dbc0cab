//! A GNSS receiver whose fix type changes under way, with a late clock: the
//! quality mapping (`[sensor.quality]`) and the time offset make the filter
//! consistent; without either it is not.
//!
//! Each run: a car-like drive of 60 s; two 200 Hz MEMS IMUs on one clock; GNSS
//! latitude/longitude/height and Doppler velocity of an antenna 1.5 m from the
//! IMUs at 10 Hz, 20–120 ms late, stamped 100 ms late by the receiver's clock;
//! the motion constraint. The receiver's fix type runs RTK fixed (0–15 s, 2 cm),
//! RTK float (15–25 s, 0.3 m), fixed (25–35 s), single point (35–45 s, 1.5 m), no
//! fix (45–50 s, 10 m), fixed (50–60 s); it reports accuracies that are optimistic
//! in float (5 cm) and single point (0.8 m), as receivers do
//! ([`fusion_client::sim::FixPhase`]).
//!
//! Setups: the quality mapping (floors per fix type at the true noise; `none`
//! refused) and `time_offset_ns = 100 ms`; the offset without the mapping; the
//! mapping without the offset. Reported per setup: the position-and-velocity
//! NEES/dof over the drive after 5 s and the share of steps in the 95 % χ²₆
//! band, the horizontal RMS error per fix type, and the largest horizontal error
//! in the 2 s after each downgrade (fixed → float, fixed → single point: does the
//! estimate get yanked?), median and worst over the runs. Held: consistent with
//! both (NEES/dof in [0.8, 1.25], > 90 % of steps in the band); clearly not
//! without either (NEES/dof > 1.5, < 90 % in the band); the worst error after a
//! downgrade smaller with the mapping than without.
//!
//! `cargo test --release -p fusion-daemon --test gnss_quality -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{
    FixPhase, GeodeticConfig, ImuOutput, PositionConfig, Scenario, ScenarioConfig, VelocityConfig,
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
/// The receiver's clock: its fixes are stamped this late, ns.
const CLOCK_LAG_NS: u64 = 100_000_000;
/// Two-sided 95 % band of χ²₆ (tables).
const CHI2_6_95: (f64, f64) = (1.2373, 14.4494);
/// Where the fix type gets worse, s.
const DOWNGRADES: [f64; 2] = [15.0, 35.0];
/// The mapping: the true noise of each fix type as its floor, no fix refused.
const QUALITY: &str = "[sensor.quality]\nrefuse = [\"none\", \"2d\"]\n\
    horizontal_floor_m = { rtk_fixed = 0.02, rtk_float = 0.3, \"3d\" = 1.5 }\n\
    vertical_floor_m = { rtk_fixed = 0.03, rtk_float = 0.5, \"3d\" = 2.5 }\n";

fn phases() -> Vec<FixPhase> {
    vec![
        FixPhase::rtk_fixed(0.0),
        FixPhase::rtk_float(15.0),
        FixPhase::rtk_fixed(25.0),
        FixPhase::single(35.0),
        FixPhase::none(45.0),
        FixPhase::rtk_fixed(50.0),
    ]
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Setup {
    Both,
    OffsetOnly,
    QualityOnly,
}

impl Setup {
    fn name(self) -> &'static str {
        match self {
            Self::Both => "quality mapping and time offset",
            Self::OffsetOnly => "time offset, no quality mapping",
            Self::QualityOnly => "quality mapping, no time offset",
        }
    }
}

#[derive(Debug, Default)]
struct Run {
    nees_sum: f64,
    in_band: u64,
    steps: u64,
    /// Sum of squared horizontal errors and steps per fix type phase (index of `phases()`).
    phase_sq: Vec<(f64, u64)>,
    /// The largest horizontal error in the 2 s after each downgrade, m.
    after_downgrade: f64,
}

fn run(seed: u64, setup: Setup) -> Run {
    let imu = |spec| common::car::imu(spec, SIGMA0[3], SIGMA0[4]);
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, clock_lag_ns: CLOCK_LAG_NS, ..Default::default() };
    let mut c = ScenarioConfig {
        seed,
        duration_s: 60.0,
        imu: imu(&common::car::IMUS[0]),
        extra_imus: vec![imu(&common::car::IMUS[1])],
        imu_output: ImuOutput::BodySpecificForce,
        ..Default::default()
    };
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: phases() }));
    c.aiding.push(Arc::new(VelocityConfig {
        sensor: 3,
        lever_arm_m: LEVER_ARM,
        clock_lag_ns: CLOCK_LAG_NS,
        ..Default::default()
    }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (_, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let offset = if setup == Setup::QualityOnly { 0 } else { CLOCK_LAG_NS };
    let quality = if setup == Setup::OffsetOnly { "" } else { QUALITY };
    let mut sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\nlever_arm_m = [{}]\n\
         time_offset_ns = {offset}\n{quality}",
        common::toml_list(&LEVER_ARM),
    );
    sensors += &common::car::imu_sensors();
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [model.constraints]\nnonholonomic_std_mps = 0.1\n[filter]\n{filter}\
         [gating]\nprobability = 0.9999\n[datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n{sensors}",
        DATUM.latitude_deg, DATUM.longitude_deg, DATUM.height_m,
    ))
    .unwrap();
    let mut engine = Engine::new(InsModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let start_ns = scenario.start_ns;
    let phase_starts: Vec<f64> = phases().iter().map(|p| p.at_s).collect();
    let mut out = Run { phase_sq: vec![(0.0, 0); phase_starts.len()], ..Default::default() };
    let mut sink = |e: &Entry<_>| {
        let t = (e.key.t_ns - start_ns) as f64 * 1e-9;
        if !matches!(e.sample, Sample::Imu(_)) || t < 5.0 {
            return;
        }
        let (x, cov) = (InsModel::x_of(&e.state), <InsModel as Model>::covariance(&e.state));
        let (err, nees) = common::pv_error_and_nees(x, &cov, &scenario.truth_at(e.key.t_ns));
        out.nees_sum += nees;
        out.in_band += u64::from((CHI2_6_95.0..=CHI2_6_95.1).contains(&nees));
        out.steps += 1;
        let horizontal = err[0].hypot(err[1]);
        let phase = phase_starts.iter().rposition(|&at| at <= t).unwrap();
        out.phase_sq[phase].0 += horizontal * horizontal;
        out.phase_sq[phase].1 += 1;
        if DOWNGRADES.iter().any(|&at| (at..at + 2.0).contains(&t)) {
            out.after_downgrade = out.after_downgrade.max(horizontal);
        }
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

/// The setup's NEES/dof, its share of steps in the 95 % band and the worst over
/// the runs of the largest error after a downgrade, printed with the rest.
fn report(runs: u64, setup: Setup) -> (f64, f64, f64) {
    let results: Vec<Run> = (0..runs).map(|seed| run(9000 + seed, setup)).collect();
    let steps: u64 = results.iter().map(|r| r.steps).sum();
    let nees = results.iter().map(|r| r.nees_sum).sum::<f64>() / steps as f64 / 6.0;
    let band = results.iter().map(|r| r.in_band).sum::<u64>() as f64 / steps as f64;
    let mut yank: Vec<f64> = results.iter().map(|r| r.after_downgrade).collect();
    yank.sort_by(f64::total_cmp);
    let rms: Vec<String> = phases()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (sq, n) = results.iter().fold((0.0, 0), |(s, k), r| (s + r.phase_sq[i].0, k + r.phase_sq[i].1));
            format!(
                "{} from {:.0} s {:.3} m",
                fusion_shared::fix::name(p.fix_type),
                p.at_s,
                (sq / n.max(1) as f64).sqrt()
            )
        })
        .collect();
    eprintln!(
        "{runs} runs, {}: NEES/dof {nees:.2}, {:.1} % of steps in the 95 % band; horizontal RMS: {}; \
         largest horizontal error in the 2 s after a downgrade: median {:.3} m, worst {:.3} m",
        setup.name(),
        band * 100.0,
        rms.join(", "),
        yank[yank.len() / 2],
        yank[yank.len() - 1],
    );
    (nees, band, yank[yank.len() - 1])
}

#[test]
fn fix_type_changes_and_a_late_clock() {
    let runs = 20;
    let (nees, band, yank) = report(runs, Setup::Both);
    assert!((0.8..=1.25).contains(&nees), "consistent with the mapping and the offset: NEES/dof {nees}");
    assert!(band > 0.9, "{band} of the steps in the 95 % band");
    let (nees_raw, band_raw, yank_raw) = report(runs, Setup::OffsetOnly);
    assert!(
        nees_raw > 1.5 && band_raw < 0.9,
        "without the quality mapping the filter believes optimistic fixes: NEES/dof {nees_raw}, {band_raw} in band"
    );
    assert!(yank < yank_raw, "a downgrade moves the estimate less with the mapping: {yank} m against {yank_raw} m");
    let (nees_late, band_late, _) = report(runs, Setup::QualityOnly);
    assert!(
        nees_late > 1.5 && band_late < 0.9,
        "without the time offset the late clock shows: NEES/dof {nees_late}, {band_late} in band"
    );
}
