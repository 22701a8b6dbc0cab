use nalgebra::UnitQuaternion;

use super::*;
use crate::frames::{Frames, SensorConfig};
use crate::model::ins::tests_support::{model, moving_scaled_state, moving_state, numeric_jacobian};

const COV: [f64; 9] = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 4e-4];

/// An `ins` model with AHRS 3 mounted as robot_localization's Husky has it
/// (`imu_link` turned +90° about x, then −90° about z) and fusing `yaw`.
fn mounted(yaw: bool) -> InsModel {
    let toml = format!(
        "name = \"ahrs\"\nid = 3\nkinds = [\"imu\", \"attitude\"]\nrotation_rpy_deg = [90, 0, -90]\n\
         [attitude]\nyaw = {yaw}\n"
    );
    let sensor: SensorConfig = toml::from_str(&toml).unwrap();
    let frames = Frames::from_config(None, &[sensor], Default::default(), &crate::measurement::Kinds).unwrap();
    model().with_frames(frames)
}

fn mount(m: &InsModel) -> Matrix3<f64> {
    m.frames().mount(SampleKind::Attitude, 3).rotation
}

/// The quaternion `[w, x, y, z]` AHRS 3 of `m` reports for the body attitude `q`.
fn reading(m: &InsModel, q: &UnitQuaternion<f64>) -> [f64; 4] {
    let S = q.to_rotation_matrix().into_inner() * mount(m);
    let r = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(S));
    [r.w, r.i, r.j, r.k]
}

/// A state whose attitude is known to `sd` rad about each axis.
fn known(m: &InsModel, q: UnitQuaternion<f64>, sd: f64) -> InsState {
    let mut s = m.initial_state();
    crate::model::ins::tests_support::set_ready(&mut s);
    s.set(s.p(), s.v(), q, s.b_a(), s.b_g());
    s.filter_mut().reset_error(|P| {
        for i in 6..9 {
            P[(i, i)] = sd * sd;
        }
    });
    s
}

#[test]
fn every_bad_value_has_its_reason() {
    let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
    let att = |q, cov| AttitudeSample::new(0, 0, 0, q, cov).validate(&limits);
    assert_eq!(att([0.6, 0.0, 0.0, 0.8], COV), Ok(()));
    assert_eq!(att([f64::NAN, 0.0, 0.0, 0.8], COV), Err(Rejection::NonFinite));
    assert_eq!(att([0.6, 0.0, 0.0, 0.9], COV), Err(Rejection::OutOfRange));
    let mut asym = COV;
    asym[1] = 1e-5;
    assert_eq!(att([1.0, 0.0, 0.0, 0.0], asym), Err(Rejection::CovarianceNotSymmetric));
    let mut neg = COV;
    neg[4] = -1e-4;
    assert_eq!(att([1.0, 0.0, 0.0, 0.0], neg), Err(Rejection::CovarianceNotPositiveDefinite));
}

/// `H` of both updates against central differences of `Log(Ŝ₀ᵀ Ŝ(x))` and
/// `P u(x)` at state `s`.
fn check_jacobians<const D: usize>(s: &InsState<D>, C: &Matrix3<f64>) {
    let (S0, H) = full(s, C);
    let numeric = numeric_jacobian(s, |x| super::super::pose::log(&(S0.transpose() * full(x, C).0)));
    assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
    let (_, P, H) = tilt(s, C);
    let numeric = numeric_jacobian(s, |x| P * tilt(x, C).0);
    assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
}

#[test]
fn jacobians_match_central_differences() {
    let C = mount(&mounted(true));
    check_jacobians(&moving_state(), &C);
    // With the odometry scale state: its column is zero.
    check_jacobians(&moving_scaled_state(), &C);
}

/// The mounted sensor's reading of the true attitude corrects a known
/// attitude that is 2° off about every axis, to within its noise.
#[test]
fn the_full_attitude_is_corrected() {
    let m = mounted(true);
    let truth = UnitQuaternion::from_euler_angles(0.1, -0.05, 2.0);
    let mut s = known(&m, UnitQuaternion::from_euler_angles(0.135, -0.015, 2.035), 0.05);
    let sample = AttitudeSample::new(1, 3, 0, reading(&m, &truth), [1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6]);
    let (out, injected) = sample.fuse(&m, &mut s);
    assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
    assert!(injected.is_some());
    assert!(s.q().angle_to(&truth) < 1e-3, "{}", s.q().angle_to(&truth));
}

/// Roll and pitch only: a sample whose yaw is 40° off (a magnetic yaw
/// indoors) corrects the tilt, leaves the yaw where it was and its
/// variance as it was.
#[test]
fn roll_and_pitch_only_leave_the_yaw_alone() {
    let m = mounted(false);
    let truth = UnitQuaternion::from_euler_angles(0.1, -0.05, 2.0);
    let mut s = known(&m, UnitQuaternion::from_euler_angles(0.12, -0.07, 2.3), 0.05);
    // Tilt known to 0.05 rad, yaw to 0.55 rad, about the world's axes.
    let R = s.q().to_rotation_matrix().into_inner();
    let world = Matrix3::from_diagonal(&Vector3::new(0.0025, 0.0025, 0.3));
    s.filter_mut().reset_error(|P| P.fixed_view_mut::<3, 3>(6, 6).copy_from(&(R.transpose() * world * R)));
    let yaw_var = heading_variance(&s);
    let off = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 40f64.to_radians()) * truth;
    let sample = AttitudeSample::new(1, 3, 0, reading(&m, &off), [1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6]);
    let (out, _) = sample.fuse(&m, &mut s);
    assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
    let (r, p, y) = s.q().euler_angles();
    assert!((r - 0.1).abs() < 1e-3 && (p + 0.05).abs() < 1e-3, "roll {r} pitch {p}");
    assert!((y - 2.3).abs() < 2e-3, "yaw {y}");
    assert!(heading_variance(&s) > 0.95 * yaw_var, "{} < {yaw_var}", heading_variance(&s));
}

/// An unknown attitude is set from the first sample (not linearised across
/// a large error): full mode takes the sensor's attitude and its covariance;
/// roll/pitch mode takes its tilt under the estimate's own yaw and keeps the
/// heading's variance.
#[test]
fn an_unknown_attitude_is_aligned_from_the_sample() {
    let truth = UnitQuaternion::from_euler_angles(0.3, -0.2, -2.5);
    let wrong = UnitQuaternion::from_euler_angles(-0.4, 0.5, 1.0);
    let m = mounted(true);
    let mut s = known(&m, wrong, 1.0);
    let sample = AttitudeSample::new(1, 3, 0, reading(&m, &truth), COV);
    let (out, change) = sample.fuse(&m, &mut s);
    assert_eq!(out, StepOutcome::Propagated);
    assert!(change.is_some_and(|dx| dx.fixed_rows::<3>(6).norm() > 1.0), "the turn is in the record");
    assert!(s.q().angle_to(&truth) < 1e-12, "{}", s.q().angle_to(&truth));
    let C = mount(&m);
    let expected = C * Matrix3::from_row_slice(&COV) * C.transpose();
    assert!((s.filter().P().fixed_view::<3, 3>(6, 6) - expected).amax() < 1e-15);
    // Known now: the next sample is fused.
    assert!(matches!(sample.fuse(&m, &mut s).0, StepOutcome::Fused { .. }));

    let m = mounted(false);
    let mut s = known(&m, wrong, 1.0);
    let heading_var = heading_variance(&s);
    assert_eq!(sample.fuse(&m, &mut s).0, StepOutcome::Propagated);
    let (r, p, y) = s.q().euler_angles();
    let (tr, tp, _) = truth.euler_angles();
    let (_, _, wy) = wrong.euler_angles();
    assert!((r - tr).abs() < 1e-12 && (p - tp).abs() < 1e-12 && (y - wy).abs() < 1e-12, "{r} {p} {y}");
    assert!((heading_variance(&s) - heading_var).abs() < 1e-12);
    assert!(tilt_variance(&s) < 5e-4, "{}", tilt_variance(&s));
}

/// Roll and pitch only, as an AHRS without a magnetometer sends them: about
/// the world's axes, the yaw's variance −1 ("not given") or 0, taken to the
/// sensor's axes as the ROS decoder does (`Zᵀ Σ Z`; the sensor is mounted
/// turned, so world up is not its `z`). Validated as selected, refused whole;
/// fused as with any valid yaw variance (to the rounding of that rotation); a
/// zero tilt variance is floored, a negative one refused.
#[test]
fn roll_and_pitch_only_never_look_at_the_yaw_variance() {
    let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
    let m = mounted(false);
    let config = *crate::measurement::settings::<AttitudeSample>(m.frames(), 3).unwrap();
    let truth = UnitQuaternion::from_euler_angles(0.1, -0.05, 2.0);
    let q = reading(&m, &truth);
    let Z = rotation_of(&q);
    let sensor_axes = |world: [f64; 3]| {
        let c = Z.transpose() * Matrix3::from_diagonal(&Vector3::from(world)) * Z;
        let mut out = [0.0; 9];
        out.copy_from_slice(c.transpose().as_slice());
        out
    };
    let sample = |cov| AttitudeSample::new(1, 3, 0, q, cov);
    let (sent, valid) = (sensor_axes([1e-4, 2e-4, -1.0]), sensor_axes([1e-4, 2e-4, 0.3]));
    assert_eq!(sample(sent).validate(&limits), Err(Rejection::CovarianceNotPositiveDefinite), "whole, refused");
    assert_eq!(sample(sent).validate_as(&limits, Some(&config)), Ok(()));
    let start = known(&m, UnitQuaternion::from_euler_angles(0.12, -0.07, 2.3), 0.05);
    let fused = |cov| {
        let mut s = start;
        let (out, _) = sample(cov).fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
        (InsModel::x_of(&s).to_vec(), s.filter().P())
    };
    let sigma = |cov: &[f64; 9]| tilt_sigma(cov, &Z).unwrap();
    // What was sent along up changes Σ' by the rounding of `Zᵀ Σ Z` alone.
    assert!((sigma(&sent) - sigma(&valid)).amax() < 1e-15, "{} {}", sigma(&sent), sigma(&valid));
    for other in [valid, sensor_axes([1e-4, 2e-4, 0.0])] {
        let ((xa, pa), (xb, pb)) = (fused(sent), fused(other));
        let dq = xa[6..10].iter().zip(&xb[6..10]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!((pa - pb).amax() < 1e-15 && dq < 1e-12, "{dq} {}", (pa - pb).amax());
    }
    // The tilt's variances: a zero floored (as the floor itself), a negative refused.
    let (zero, floor) = (sensor_axes([0.0, 2e-4, -1.0]), crate::measurement::components::VARIANCE_FLOOR);
    assert!((sigma(&zero) - sigma(&sensor_axes([floor, 2e-4, -1.0]))).amax() < 1e-15);
    assert!(sigma(&zero).symmetric_eigenvalues().min() > 0.5 * floor);
    let negative = sensor_axes([-1e-4, 2e-4, -1.0]);
    assert_eq!(sample(negative).validate_as(&limits, Some(&config)), Err(Rejection::CovarianceNotPositiveDefinite));
}
