use super::*;
use crate::frames::{Frames, SensorConfig};
use crate::model::ins::tests_support::{estimated_frame, model, moving, numeric_jacobian, set_aux_value};
use crate::model::ins::{AuxStates, N};

/// Pose sensor 4: a camera looking forward and down (FRD axes, pitched 10°),
/// 0.8 m ahead and 1.2 m up, with `pose_table` as its `[sensor.pose]`.
fn sensor(pose_table: &str) -> SensorConfig {
    let toml = format!(
        "name = \"slam\"\nid = 4\nkinds = [\"pose\"]\naxes = \"frd\"\nrotation_rpy_deg = [0, 10, 0]\n\
         lever_arm_m = [0.8, 0, 1.2]\n{pose_table}"
    );
    toml::from_str(&toml).unwrap()
}

/// An `ins` model with the map frame of [`sensor`] as four states.
fn estimated() -> InsModel<{ N + 4 }> {
    let frames = Frames::from_config(None, &[sensor("")], Default::default(), &crate::measurement::Kinds).unwrap();
    let (aux, _) = crate::measurement::aux_states(AuxStates::default(), &frames);
    assert_eq!(aux, estimated_frame(AuxStates::default(), 4), "the pose sensor's own priors");
    model().with_frames(frames).with_aux(aux).unwrap()
}

/// An `ins` model whose map frame is configured (yaw 30°, origin [100, −50, 2]).
fn configured() -> InsModel {
    let table = "[pose]\nframe_yaw_deg = 30\nframe_origin_m = [100, -50, 2]\n";
    model().with_frames(Frames::from_config(None, &[sensor(table)], Default::default(), &crate::measurement::Kinds).unwrap())
}

fn cov() -> [f64; 36] {
    fusion_shared::TwistSample::diagonal_cov([0.05; 3], [0.01; 3])
}

/// What sensor 4 reports in state `s` for map frame `frame`, without noise.
fn reading<const D: usize>(m: &InsModel<D>, s: &InsState<D>, frame: &MapFrame, counter: u32) -> PoseSample {
    let (p, S, _) = pose(s, m.frames().mount(SampleKind::Pose, 4), frame);
    let q = UnitQuaternion::from_matrix(&S);
    let c = q.quaternion().coords;
    let t_ns = <InsModel<D> as Model>::time_ns(s).unwrap_or(0);
    PoseSample::new(t_ns, 4, 0, p.into(), [c[3], c[0], c[1], c[2]], cov(), counter)
}

#[test]
fn every_bad_value_has_its_reason() {
    let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
    let check = |p: [f64; 3], q: [f64; 4], c: [f64; 36]| PoseSample::new(0, 4, 0, p, q, c, 0).validate(&limits);
    let unit = [0.6, 0.0, 0.0, 0.8];
    assert_eq!(check([1.0, 2.0, 3.0], unit, cov()), Ok(()));
    assert_eq!(check([1.0, 2.0, 3.0], [1.0, 0.0, 0.0, 0.1], cov()), Err(Rejection::OutOfRange), "not unit");
    assert_eq!(check([1.0, 2.0, 3.0], [0.0; 4], cov()), Err(Rejection::OutOfRange), "zero");
    assert_eq!(check([f64::NAN, 2.0, 3.0], unit, cov()), Err(Rejection::NonFinite));
    assert_eq!(check([1.0, 2.0, 3.0], [f64::NAN, 0.0, 0.0, 0.8], cov()), Err(Rejection::NonFinite));
    assert_eq!(check([2e7, 0.0, 0.0], unit, cov()), Err(Rejection::OutOfRange));
    let mut bad = cov();
    bad[0] = -1.0;
    assert_eq!(check([1.0, 2.0, 3.0], unit, bad), Err(Rejection::CovarianceNotPositiveDefinite));
    let mut asym = cov();
    asym[1] = 1e-3;
    assert_eq!(check([1.0, 2.0, 3.0], unit, asym), Err(Rejection::CovarianceNotSymmetric));
}

/// `H` against central differences of `[m̂(x); Log(Ŝ(x₀)ᵀ Ŝ(x))]`, with the
/// frame's four states, a rotated mount and a lever arm.
#[test]
fn jacobian_matches_numerical_differentiation() {
    let m = estimated();
    let mut s = moving(&m);
    let i = s.aux_index(aux::POSE_FRAME_YAW).unwrap();
    for (k, v) in [0.7, 120.0, -40.0, 3.0].into_iter().enumerate() {
        set_aux_value(&mut s, i + k, v);
    }
    let mount = *m.frames().mount(SampleKind::Pose, 4);
    let frame = MapFrame::estimated(&s).unwrap();
    let (_, S0, H) = pose(&s, &mount, &frame);
    let numeric = numeric_jacobian(&s, |x| {
        let (m, S, _) = pose(x, &mount, &MapFrame::estimated(x).unwrap());
        let mut h = Vector6::zeros();
        h.fixed_rows_mut::<3>(0).copy_from(&m);
        h.fixed_rows_mut::<3>(3).copy_from(&log(&(S0.transpose() * S)));
        h
    });
    assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
    assert!(H.fixed_view::<6, 4>(0, i).amax() > 0.5, "the frame's columns enter");
    // Without the states (a configured frame) their columns are zero.
    let (_, _, H) = pose(&s, &mount, &MapFrame { states: None, ..frame });
    assert_eq!(H.fixed_view::<6, 4>(0, i).amax(), 0.0);
}

/// The first pose sets the frame from the estimate and moves nothing else;
/// the next poses of the same frame fuse with a small NIS; a new reset counter
/// sets the frame again, with no jump of the estimate.
#[test]
fn the_first_pose_and_a_reset_set_the_frame_without_a_jump() {
    let m = estimated();
    let mut s = moving(&m);
    let truth = MapFrame { yaw: 0.9, origin: Vector3::new(30.0, -12.0, 1.5), states: None };
    let first = reading(&m, &s, &truth, 0);
    let before = s;
    assert_eq!(first.fuse(&m, &mut s).0, StepOutcome::Propagated);
    assert_eq!(&InsModel::x_of(&s)[..16], &InsModel::x_of(&before)[..16], "the estimate does not move");
    let frame = MapFrame::estimated(&s).unwrap();
    assert!((frame.yaw - 0.9).abs() < 1e-9 && (frame.origin - truth.origin).norm() < 1e-9, "{frame:?}");
    assert_eq!((s.aux_progress().kinds.pose.counter, s.aux_progress().kinds.pose.alignments), (Some(0), 1));
    // The frame's variance: at least the yaw's uncertainty (1 rad in this state).
    let P = s.filter().P();
    assert!(P[(N, N)] > 0.5, "{}", P[(N, N)]);
    let next = reading(&m, &s, &truth, 0);
    match next.fuse(&m, &mut s).0 {
        StepOutcome::Fused { nis } => assert!(nis < 1e-6, "{nis}"),
        out => panic!("{out:?}"),
    }
    // The localiser re-initialises: its map is now turned and shifted.
    let moved = MapFrame { yaw: -2.0, origin: Vector3::new(-5.0, 8.0, 0.0), states: None };
    let x = s;
    let reset = reading(&m, &s, &moved, 1);
    assert_eq!(reset.fuse(&m, &mut s).0, StepOutcome::Propagated);
    assert_eq!(&InsModel::x_of(&s)[..16], &InsModel::x_of(&x)[..16]);
    let frame = MapFrame::estimated(&s).unwrap();
    assert!((frame.yaw + 2.0).abs() < 1e-9 && (frame.origin - moved.origin).norm() < 1e-9, "{frame:?}");
    assert_eq!((s.aux_progress().kinds.pose.counter, s.aux_progress().kinds.pose.alignments), (Some(1), 2));
}

/// A jump the localiser does not announce: poses are gated, and after
/// `realign_after_gated` in a row the frame is set again.
#[test]
fn gated_poses_in_a_row_set_the_frame_again() {
    let gate = crate::filter::ChiSquareGate::new(0.999).ok();
    let frames = Frames::from_config(None, &[sensor("")], Default::default(), &crate::measurement::Kinds).unwrap();
    let aux = estimated_frame(AuxStates::default(), 4);
    let core = InsModel::new(crate::model::ins::tests_support::NOISE, 9.80665, x0(), [1e-4; N], gate, 0).unwrap();
    let m = core.with_frames(frames).with_aux::<{ N + 4 }>(aux).unwrap();
    let mut s = moving(&m);
    let truth = MapFrame { yaw: 0.2, origin: Vector3::new(3.0, 4.0, 0.0), states: None };
    assert_eq!(reading(&m, &s, &truth, 0).fuse(&m, &mut s).0, StepOutcome::Propagated);
    let jumped = MapFrame { origin: Vector3::new(13.0, 4.0, 0.0), ..truth };
    for k in 0..5 {
        let out = reading(&m, &s, &jumped, 0).fuse(&m, &mut s).0;
        assert!(matches!(out, StepOutcome::Gated { .. }), "{k}: {out:?}");
    }
    let x = s;
    let sixth = reading(&m, &s, &jumped, 0).fuse(&m, &mut s).0;
    assert_eq!(sixth, StepOutcome::Propagated, "the 6th sets the frame");
    assert_eq!(&InsModel::x_of(&s)[..16], &InsModel::x_of(&x)[..16]);
    assert!((MapFrame::estimated(&s).unwrap().origin - jumped.origin).norm() < 1e-6);
    assert!(matches!(reading(&m, &s, &jumped, 0).fuse(&m, &mut s).0, StepOutcome::Fused { .. }));
}

fn x0() -> [f64; 16] {
    let mut x = [0.0; 16];
    x[6] = 1.0;
    x
}

/// A configured frame: no states; a pose 1 m east of the prediction pulls
/// the position east.
#[test]
fn a_configured_frame_is_fused_as_it_is() {
    let m = configured();
    let mut s = moving(&m);
    let mut P = s.filter().P();
    for i in 6..9 {
        P[(i, i)] = 1e-6;
    }
    s.filter_mut().set_state(SVector::zeros(), P).unwrap();
    let frame = MapFrame { yaw: 30f64.to_radians(), origin: Vector3::new(100.0, -50.0, 2.0), states: None };
    let mut sample = reading(&m, &s, &frame, 7);
    // 1 m east in the world is (cos 30°, −sin 30°) in the map.
    sample.position_m[0] += 30f64.to_radians().cos();
    sample.position_m[1] -= 30f64.to_radians().sin();
    let east = s.p().x;
    assert!(matches!(sample.fuse(&m, &mut s).0, StepOutcome::Fused { .. }));
    assert!(s.p().x - east > 0.9, "{}", s.p().x - east);
}

/// Relative mode: the first pose is kept, the second's change is fused as a
/// twist, the third starts the next pair; a reset counter change is not
/// differenced.
#[test]
fn relative_poses_are_fused_as_their_change() {
    let frames = Frames::from_config(None, &[sensor("[pose]\nrelative = true\n")], Default::default(), &crate::measurement::Kinds).unwrap();
    let m = model().with_frames(frames);
    let mut s = moving(&m);
    let mut P = s.filter().P();
    for i in 6..9 {
        P[(i, i)] = 1e-4;
    }
    s.filter_mut().set_state(SVector::zeros(), P).unwrap();
    let frame = MapFrame { yaw: 0.4, origin: Vector3::zeros(), states: None };
    let a = reading(&m, &s, &frame, 0);
    assert_eq!(a.fuse(&m, &mut s).0, StepOutcome::Propagated, "kept");
    // 0.1 s later the sensor has moved by the velocity of the state.
    let mut b = a;
    b.header.t_ns += 100_000_000;
    let (v, _) = crate::measurement::twist::twist(&s, m.frames().mount(SampleKind::Pose, 4));
    let Z = rotation_of(&a.orientation_wxyz);
    let moved = Vector3::from(a.position_m) + Z * v.fixed_rows::<3>(0) * 0.1;
    b.position_m = moved.into();
    let (z, cov) = relative_twist(&previous(&a), &previous(&b)).unwrap();
    assert!((z.fixed_rows::<3>(0) - v.fixed_rows::<3>(0)).norm() < 1e-9, "{z}");
    assert!((cov[(0, 0)] - 2.0 * 0.05 * 0.05 / 0.01).abs() < 1e-9, "{cov}");
    assert!(matches!(b.fuse(&m, &mut s).0, StepOutcome::Fused { .. }));
    let mut c = b;
    c.header.t_ns += 100_000_000;
    assert_eq!(c.fuse(&m, &mut s).0, StepOutcome::Propagated, "a new pair");
    let mut d = c;
    d.header.t_ns += 100_000_000;
    d.reset_counter = 1;
    assert!(relative_twist(&previous(&c), &previous(&d)).is_none(), "a reset is not differenced");
    assert_eq!(d.fuse(&m, &mut s).0, StepOutcome::Propagated);
}

/// A sonar's height as a pose (`fuse = ["z"]`), as a drone's driver sends
/// it: orientation (0, 0, 0, 0), NaN where nothing is measured and every
/// variance 0. It validates as selected (not whole); the first sets the
/// frame's height alone (its yaw and horizontal origin keep their prior),
/// the next is fused with the zero variance floored, and every step is bit
/// for bit the one of the same poses with valid values where nothing is
/// selected.
#[test]
fn a_height_alone_sets_and_fuses_the_height_only() {
    let frames =
        Frames::from_config(None, &[sensor("[pose]\nfuse = [\"z\"]\n")], Default::default(), &crate::measurement::Kinds)
            .unwrap();
    let (aux, _) = crate::measurement::aux_states(AuxStates::default(), &frames);
    let m: InsModel<{ N + 4 }> = model().with_frames(frames).with_aux(aux).unwrap();
    let config = *crate::measurement::settings::<PoseSample>(m.frames(), 4).unwrap();
    let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
    let truth = MapFrame { yaw: 0.9, origin: Vector3::new(30.0, -12.0, 1.5), states: None };
    let (mut driven, mut valid) = (moving(&m), moving(&m));
    let i = valid.aux_index(aux::POSE_FRAME_YAW).unwrap();
    for k in 0..2 {
        let mut clean = reading(&m, &valid, &truth, 0);
        clean.position_m[2] += 0.05 * k as f64;
        clean.cov[14] = 0.0;
        let mut sent = clean;
        (sent.orientation_wxyz, sent.cov) = ([0.0; 4], [0.0; 36]);
        (sent.position_m[0], sent.position_m[1]) = (f64::NAN, f64::NAN);
        assert_eq!(sent.validate(&limits), Err(Rejection::NonFinite), "whole, it is refused");
        assert_eq!(sent.validate_as(&limits, Some(&config)), Ok(()));
        let before = valid;
        let (a, b) = (sent.fuse(&m, &mut driven), clean.fuse(&m, &mut valid));
        assert_eq!(a, b);
        assert_eq!(InsModel::x_of(&driven), InsModel::x_of(&valid), "{k}");
        assert_eq!(driven.filter().P(), valid.filter().P(), "{k}");
        if k == 0 {
            assert_eq!(a.0, StepOutcome::Propagated, "the first sets the frame");
            let frame = MapFrame::estimated(&valid).unwrap();
            assert!((frame.origin.z - truth.origin.z).abs() < 1e-9, "{frame:?}");
            assert_eq!((frame.yaw, frame.origin.x, frame.origin.y), (0.0, 0.0, 0.0), "not informed");
            let (P, P0) = (valid.filter().P(), before.filter().P());
            assert_eq!(P.fixed_view::<3, 3>(i, i), P0.fixed_view::<3, 3>(i, i), "their prior kept");
            // The height is set: as uncertain as the vehicle's (not its 1 km prior).
            assert!(P[(i + 3, i + 3)] < 4.0 * P0[(2, 2)], "{} {}", P[(i + 3, i + 3)], P0[(2, 2)]);
            assert!(P0[(i + 3, i + 3)] > 1e5);
        } else {
            assert!(matches!(a.0, StepOutcome::Fused { .. }), "{a:?}");
            let o = sent.observe(&m, &before).unwrap();
            assert_eq!(o.R[(2, 2)], crate::measurement::components::VARIANCE_FLOOR);
        }
    }
}
