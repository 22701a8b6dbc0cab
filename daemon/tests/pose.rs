//! A robot with a localiser's poses in a map frame of its own: consistency with
//! the pose in the stream, the frame's estimate, and a re-initialisation of the
//! localiser mid-run.
//!
//! Each run: 60 s of a car-like drive (two 200 Hz MEMS IMUs, GNSS
//! latitude/longitude/height of an antenna 1.5 m from the IMUs at 1 Hz) and
//! 10 Hz poses from a lidar SLAM mounted with forward-right-down axes, pitched
//! 10°, 0.8 m ahead of and 1.2 m above the IMUs (5 cm and 0.005 rad noise per
//! axis, 40–100 ms late, 2 % lost), in a map frame turned 0.6 rad and shifted
//! [20, −15, 0.5] m against the world, whose frame is estimated. At 30 s the
//! localiser re-initialises: its map is now turned −1.0 rad and shifted
//! [5, 5, 0] m; in the even runs its reset counter says so, in the odd ones
//! only the jump shows (the gate finds it). The initial state drawn from its σ.
//!
//! Held over 20 runs: the position-and-velocity NEES/dof in [0.8, 1.25] from
//! 2 s on, the fused poses' mean NIS/dof in [0.8, 1.25]; at the reset the
//! position error changes by less than 3σ from one snapshot to the next (over
//! the second after it); the frame is set twice (the first pose, the reset),
//! and settles: 10 s after the reset its yaw and origin are within 3σ of the
//! new frame's, their σ below 0.01 rad and 1 m (the origin is known as well as
//! the GNSS position is). Reported: the figures, the frame's errors, the poses
//! gated (the silent jump's).
//!
//! Then the same drives without the reset, with the frame configured (the true
//! one) and with the poses fused relative (their change, as a twist): NEES/dof
//! and the fused poses' NIS/dof in [0.8, 1.25] for each.
//!
//! `cargo test --release -p fusion-daemon --test pose -- --nocapture`.

mod common;

use std::sync::Arc;

use fusion_client::sim::{GeodeticConfig, LocaliserReset, MapFrame, PoseConfig, PositionConfig, Scenario};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::ins::{InsModel, N};
use fusion_daemon::model::{Model, StepOutcome};
use fusion_shared::Sample;
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde_json::Value;

const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
const LEVER_ARM: [f64; 3] = [1.0, 0.5, 1.0];
const SLAM_ARM: [f64; 3] = [0.8, 0.0, 1.2];
const DATUM: Datum = Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 };
const RUNS: u64 = 20;
const RESET_S: f64 = 30.0;
const BEFORE: MapFrame = MapFrame { yaw_rad: 0.6, origin_m: [20.0, -15.0, 0.5] };
const AFTER: MapFrame = MapFrame { yaw_rad: -1.0, origin_m: [5.0, 5.0, 0.0] };

#[derive(Debug, Default)]
struct Run {
    nees: (f64, u64),
    nis: (f64, u64),
    /// The largest change of the position error from one snapshot to the next
    /// over its σ, in the second after the reset.
    worst_step: f64,
    /// The frame 10 s after the reset: errors of yaw (rad) and origin (m), and
    /// their σ.
    frame: Option<([f64; 4], [f64; 4])>,
    /// Times the frame was set.
    alignments: u32,
    /// Poses gated.
    gated: u32,
}

/// How the pose sensor's map frame is known.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    /// Estimated (four states), with the localiser's reset at 30 s.
    Estimated,
    /// Configured (the true frame), no reset.
    Configured,
    /// Relative: only the change between poses, no reset.
    Relative,
}

fn run(seed: u64, mode: Mode) -> Run {
    let (config, scenario, t0) = setup(seed, mode);
    match InsBuilt::from_config(&config).unwrap() {
        InsBuilt::Aux4(model) => drive(model, &config, &scenario, t0),
        InsBuilt::Core(model) => drive(model, &config, &scenario, t0),
        other => unreachable!("{other:?}"),
    }
}

/// The config, the drive and its first sample time of run `seed` in `mode`.
fn setup(seed: u64, mode: Mode) -> (Config, Scenario, u64) {
    let fix = PositionConfig { sensor: 3, lever_arm_m: LEVER_ARM, rate_hz: 1.0, ..Default::default() };
    let mut c = common::car::drive(seed, 60.0, SIGMA0);
    let mount = UnitQuaternion::from_euler_angles(0.0, 10f64.to_radians(), 0.0).to_rotation_matrix().into_inner()
        * Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    c.aiding.push(Arc::new(GeodeticConfig { datum: DATUM, fix, phases: Vec::new() }));
    c.aiding.push(Arc::new(PoseConfig {
        sensor: 6,
        rotation: mount,
        lever_arm_m: SLAM_ARM,
        frame: BEFORE,
        reset: (mode == Mode::Estimated).then_some(LocaliserReset {
            at_s: RESET_S,
            frame: AFTER,
            announced: seed.is_multiple_of(2),
        }),
        dropout_probability: 0.02,
        ..Default::default()
    }));
    let mut scenario = Scenario::generate(&c);
    scenario.arrivals.retain(|a| !matches!(a.sample, Sample::Position(_)));
    let (t0, filter) = common::ins_start_from_prior(&scenario, seed, SIGMA0);
    let fmt = common::toml_list;
    let frame = match mode {
        Mode::Estimated => String::new(),
        Mode::Configured => format!(
            "[sensor.pose]\nframe_yaw_deg = {}\nframe_origin_m = [{}]\n",
            BEFORE.yaw_rad.to_degrees(),
            fmt(&BEFORE.origin_m)
        ),
        Mode::Relative => "[sensor.pose]\nrelative = true\n".into(),
    };
    let sensors = format!(
        "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\nlever_arm_m = [{}]\n\
         [[sensor]]\nname = \"slam\"\nid = 6\nkinds = [\"pose\"]\naxes = \"frd\"\nrotation_rpy_deg = [0, 10, 0]\n\
         lever_arm_m = [{}]\n{frame}",
        fmt(&LEVER_ARM),
        fmt(&SLAM_ARM),
    );
    let config = Config::parse(&common::car::ins_config(&filter, &DATUM, &sensors)).unwrap();
    (config, scenario, t0)
}

fn drive<const D: usize>(model: InsModel<D>, config: &Config, scenario: &Scenario, t0: u64) -> Run {
    type M<const D: usize> = InsModel<D>;
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut out = Run::default();
    let mut last: Option<Vector3<f64>> = None;
    let settled_ns = t0 + ((RESET_S + 10.0) * 1e9) as u64;
    let mut sink = |e: &Entry<fusion_daemon::model::ins::InsState<D>>| {
        match (&e.sample, e.outcome) {
            (Sample::Pose(_), StepOutcome::Fused { nis }) => {
                out.nis.0 += nis;
                out.nis.1 += 1;
            }
            (Sample::Pose(_), StepOutcome::Gated { .. }) => out.gated += 1,
            _ => {}
        }
        out.alignments = out.alignments.max(e.state.aux_progress().kinds.pose.alignments);
        let t = e.key.t_ns.saturating_sub(t0) as f64 * 1e-9;
        let (x, cov) = (M::<D>::x_of(&e.state), <M<D> as Model>::covariance(&e.state));
        let n = D;
        let p = Vector3::new(x[0], x[1], x[2]) - scenario.truth_at(e.key.t_ns).pos_m;
        let sd = Vector3::new(cov[0], cov[n + 1], cov[2 * n + 2]).map(f64::sqrt);
        if (RESET_S..RESET_S + 1.0).contains(&t)
            && let Some(before) = last
        {
            let step = (p - before).component_div(&sd).amax();
            out.worst_step = out.worst_step.max(step);
        }
        last = Some(p);
        if D == N + 4 && e.key.t_ns >= settled_ns && out.frame.is_none() {
            let i = N;
            let err = [
                fusion_daemon::filter::wrap_angle(x[i + 1] - AFTER.yaw_rad),
                x[i + 2] - AFTER.origin_m[0],
                x[i + 3] - AFTER.origin_m[1],
                x[i + 4] - AFTER.origin_m[2],
            ];
            let sd = [0, 1, 2, 3].map(|k| cov[(i + k) * n + i + k].sqrt());
            out.frame = Some((err, sd));
        }
        if !matches!(e.sample, Sample::Imu(_)) || t < 2.0 {
            return;
        }
        let truth = scenario.truth_at(e.key.t_ns);
        let (_, nees) = common::pv_error_and_nees(x, &cov, &truth);
        out.nees.0 += nees;
        out.nees.1 += 1;
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

#[test]
fn poses_are_fused_consistently_and_a_localiser_reset_realigns() {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(9900 + seed, Mode::Estimated)).collect();
    let nees = common::pooled_mean(&runs, |r| r.nees) / 6.0;
    let nis = common::pooled_mean(&runs, |r| r.nis) / 6.0;
    let worst_step = runs.iter().map(|r| r.worst_step).fold(0.0, f64::max);
    let frames: Vec<_> = runs.iter().map(|r| r.frame.expect("the run reached 10 s after the reset")).collect();
    let worst_frame =
        frames.iter().map(|(e, sd)| (0..4).map(|k| e[k].abs() / sd[k]).fold(0.0, f64::max)).fold(0.0, f64::max);
    let yaw_sd = frames.iter().map(|(_, sd)| sd[0]).fold(0.0, f64::max);
    let origin_sd = frames.iter().map(|(_, sd)| sd[1].max(sd[2]).max(sd[3])).fold(0.0, f64::max);
    let yaw_err = frames.iter().map(|(e, _)| e[0].abs()).fold(0.0, f64::max);
    let alignments: Vec<u32> = runs.iter().map(|r| r.alignments).collect();
    let gated: Vec<u32> = runs.iter().map(|r| r.gated).collect();
    eprintln!(
        "{RUNS} runs with 10 Hz poses: NEES/dof (p, v) {nees:.2}, pose NIS/dof {nis:.2}; at the reset the largest \
         step {worst_step:.2}σ; 10 s after it the frame's worst error {worst_frame:.2}σ (yaw {:.4} rad, σ ≤ {yaw_sd:.4} \
         rad; origin σ ≤ {origin_sd:.3} m); frame set {alignments:?} times; poses gated {gated:?}",
        yaw_err
    );
    assert!((0.8..=1.25).contains(&nees), "NEES/dof {nees}");
    assert!((0.8..=1.25).contains(&nis), "pose NIS/dof {nis}");
    assert!(worst_step < 3.0, "the estimate jumped {worst_step}σ at the reset");
    assert!(worst_frame < 3.0, "the frame after the reset is {worst_frame}σ off");
    assert!(yaw_sd < 0.01 && origin_sd < 1.0, "the frame settles: σ {yaw_sd} rad, {origin_sd} m");
    assert!(alignments.iter().all(|&a| a == 2), "set at the first pose and at the reset, once each: {alignments:?}");
}

/// The same drives without the reset, the frame configured or the poses
/// fused relative: NEES/dof (p, v) and the fused poses' NIS/dof in [0.8, 1.25].
#[test]
fn configured_and_relative_poses_are_fused_consistently() {
    for mode in [Mode::Configured, Mode::Relative] {
        let runs: Vec<Run> = (0..RUNS).map(|seed| run(9950 + seed, mode)).collect();
        let nees = common::pooled_mean(&runs, |r| r.nees) / 6.0;
        let nis = common::pooled_mean(&runs, |r| r.nis) / 6.0;
        let fused = runs.iter().map(|r| r.nis.1).sum::<u64>();
        eprintln!("{RUNS} runs, {mode:?}: NEES/dof (p, v) {nees:.2}, pose NIS/dof {nis:.2} over {fused} poses fused");
        assert!((0.8..=1.25).contains(&nees), "{mode:?}: NEES/dof {nees}");
        assert!((0.8..=1.25).contains(&nis), "{mode:?}: pose NIS/dof {nis}");
        assert!(fused > RUNS * 250, "{mode:?}: {fused} fused");
    }
}

/// Smoothing (`fusiond replay --smooth`) through the localiser's reset, an
/// announced one and a silent one: no smoothed standard deviation above the
/// filtered one (the step that set the new frame passes nothing of it back to
/// the old), and the smoothed frame just before the reset the old one.
#[test]
fn smoothing_through_a_localiser_reset_keeps_the_frames_apart() {
    use fusion_daemon::replay::replay;
    for seed in [9900, 9901] {
        let (config, scenario, t0) = setup(seed, Mode::Estimated);
        let input: String =
            scenario.arrivals.iter().map(|a| fusion_shared::jsonl::format_sample(&a.sample) + "\n").collect();
        let estimates = |smooth| {
            let mut out = Vec::new();
            replay(&config, input.as_bytes(), Some(&mut out), smooth).unwrap();
            String::from_utf8(out).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect::<Vec<Value>>()
        };
        let (filtered, smoothed) = (estimates(false), estimates(true));
        assert_eq!(filtered.len(), smoothed.len());
        let n = N + 4;
        let mut worst: f64 = 0.0;
        for (f, s) in filtered.iter().zip(&smoothed) {
            for i in 0..n {
                let (pf, ps) = (f["P"][i * n + i].as_f64().unwrap(), s["P"][i * n + i].as_f64().unwrap());
                worst = worst.max(ps / pf);
            }
        }
        let before =
            smoothed.iter().rfind(|e| e["t_ns"].as_u64().unwrap() < t0 + (RESET_S * 1e9) as u64 - 50_000_000).unwrap();
        let x: Vec<f64> = before["x"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let frame = [x[N + 1], x[N + 2], x[N + 3], x[N + 4]];
        eprintln!("seed {seed}: largest smoothed/filtered variance {worst:.6}; frame before the reset {frame:?}");
        assert!(worst <= 1.0 + 1e-6, "a smoothed variance above the filtered one: {worst}");
        assert!((frame[0] - BEFORE.yaw_rad).abs() < 0.01, "{frame:?}");
        for k in 0..3 {
            assert!((frame[k + 1] - BEFORE.origin_m[k]).abs() < 1.0, "{frame:?}");
        }
    }
}
