//! Coarse heading alignment from the course over ground, for the `ins` model.
//!
//! At start the heading of a vehicle is often unknown (no magnetometer, no dual
//! antenna, no static gyrocompassing with a MEMS gyro). While it is, the
//! linearised updates through the attitude are poor: the velocity errors stay
//! large for seconds while the heading converges through the cross-covariances.
//! A land vehicle or a fixed-wing aircraft moving forward faster than a few m/s
//! points along its velocity, so its yaw is the course over ground
//! `ψ = atan2(v_N, v_E)` (ENU; body forward-left-up) up to the sideslip. PX4
//! EKF2 (`Ekf::realignYawGPS`: fixed-wing vehicles after launch, from 5 m/s and a
//! velocity error below 15 % of the speed) and ArduPilot's EKF3
//! (`NavEKF3_core::realignYawGPS`) align the yaw to the GNSS course the same way.
//!
//! When a velocity sample arrives with the horizontal speed (at the body origin:
//! the lever arm's rotational part removed) at least `heading_from_velocity_mps`
//! and the heading uncertainty above [`ALIGN_ABOVE_SD`]:
//!
//! - the nominal attitude is rotated about world up by `Δ = ψ − ψ̂` (roll and
//!   pitch are kept: `q ← Rz(Δ) q`);
//! - the heading error, which in the local error `δθ` (body frame) lies along
//!   `u = Rᵀ e_z` (a rotation `ε` about world up is `q ⊗ Exp(ε u)`), is given the
//!   variance `σ_ψ² = σ_⊥² / |v|² + σ_β²` with `σ_⊥²` the measurement's variance
//!   across the track and `σ_β` the sideslip allowance, and no correlation with
//!   anything: with `Π = I − u uᵀ` on the δθ block,
//!   `P ← T P Tᵀ + σ_ψ² u uᵀ`, `T = diag(I, I, Π, I, …)`;
//! - then the velocity is fused as usual.
//!
//! The vehicle is assumed to move forward when it aligns: one reversing faster
//! than the threshold while its heading is unknown is aligned 180° off (the
//! velocity innovations then grow and the health reports it).

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector2, Vector3};

use super::{InsModel, InsState};
use crate::filter::wrap_angle as wrap;

/// Heading uncertainty (1σ, rad) above which a velocity sample aligns the
/// heading: 0.2 rad (11°), twice where the motion constraint starts
/// ([`super::nonholonomic::MAX_ATTITUDE_SD`]); below it the filter's own
/// update is accurate enough.
pub const ALIGN_ABOVE_SD: f64 = 0.2;

/// The course alignment's parameters (`[model.alignment]` keys
/// `heading_from_velocity_mps`, `heading_sideslip_std_deg`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CourseAlignment {
    /// Least horizontal speed at which the heading is taken from the course, m/s.
    pub min_speed_mps: f64,
    /// Standard deviation of the angle between the body's x axis and the
    /// velocity (sideslip, mounting), rad.
    pub sideslip_std_rad: f64,
}

impl<const D: usize> InsModel<D> {
    /// The same model with the heading aligned from the course over ground.
    pub fn with_course_alignment(mut self, course: Option<CourseAlignment>) -> Self {
        self.course = course;
        self
    }

    /// The course alignment, if configured.
    pub fn course_alignment(&self) -> Option<&CourseAlignment> {
        self.course.as_ref()
    }

    /// Aligns the heading to the course of `v` (world-frame velocity of the body
    /// origin, m/s; `R` its covariance) if configured and due (see the module
    /// documentation). Returns the error-state change of the nominal state
    /// (`Δ u` on δθ) for the smoother's record, or `None` if nothing changed.
    pub(crate) fn align_course(
        &self,
        s: &mut InsState<D>,
        v: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> Option<SVector<f64, D>> {
        let c = self.course.as_ref()?;
        let speed = v.xy().norm();
        if !s.ready || speed < c.min_speed_mps {
            return None;
        }
        if heading_variance(s) <= ALIGN_ABOVE_SD * ALIGN_ABOVE_SD {
            return None;
        }
        // The heading of the body's x axis; undefined when it points up or down.
        let x = s.q().transform_vector(&Vector3::x());
        if x.xy().norm() < 0.5 {
            return None;
        }
        let delta = wrap(v.y.atan2(v.x) - x.y.atan2(x.x));
        let across = Vector2::new(-v.y, v.x) / speed;
        let across_var = (across.transpose() * R.fixed_view::<2, 2>(0, 0) * across)[0];
        let var = across_var / (speed * speed) + c.sideslip_std_rad * c.sideslip_std_rad;
        Some(turn_heading(s, delta, var))
    }
}

/// The variance of the heading error: of the attitude error about world up,
/// `uᵀ P_θθ u` with `u = Rᵀ e_z`, rad².
pub(crate) fn heading_variance<const D: usize>(s: &InsState<D>) -> f64 {
    let u = s.q().inverse_transform_vector(&Vector3::z());
    let P = s.kf.P();
    (u.transpose() * P.fixed_view::<3, 3>(6, 6) * u)[0]
}

/// Turns the attitude about world up by `delta` (roll and pitch kept) and gives
/// the heading error the variance `var` without correlation (module docs:
/// `P ← T P Tᵀ + var u uᵀ`). Returns the error-state change of the nominal
/// state (`delta u` on δθ) for the smoother's record.
pub(crate) fn turn_heading<const D: usize>(s: &mut InsState<D>, delta: f64, var: f64) -> SVector<f64, D> {
    let q = s.q();
    let u = q.inverse_transform_vector(&Vector3::z());
    let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), delta) * q;
    let (p, vn, b_a, b_g) = (s.p(), s.v(), s.b_a(), s.b_g());
    s.put(p, vn, turned, b_a, b_g);
    let mut T = SMatrix::<f64, D, D>::identity();
    T.fixed_view_mut::<3, 3>(6, 6).copy_from(&(Matrix3::identity() - u * u.transpose()));
    s.kf.reset_error(|P| {
        *P = T * *P * T.transpose();
        let mut block = P.fixed_view_mut::<3, 3>(6, 6);
        block += u * u.transpose() * var;
    });
    let mut change = SVector::<f64, D>::zeros();
    change.fixed_rows_mut::<3>(6).copy_from(&(u * delta));
    change
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::model::ins::ImuNoise;

    const NOISE: ImuNoise = ImuNoise {
        accelerometer_noise_density: 0.02,
        gyroscope_noise_density: 0.001,
        accelerometer_random_walk: 0.001,
        gyroscope_random_walk: 1e-5,
    };

    /// A model whose heading is 1 rad uncertain, correlated with the velocity
    /// and the biases, rolled and pitched a little, and an IMU sample held.
    fn unaligned(course: Option<CourseAlignment>) -> (InsModel, InsState) {
        let q = UnitQuaternion::from_euler_angles(0.05, -0.03, 0.3);
        let c = q.quaternion().coords;
        let mut x0 = [0.0; 16];
        x0[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
        let p0 = [1.0, 1.0, 1.0, 4.0, 4.0, 1.0, 0.01, 0.01, 1.0, 0.01, 0.01, 0.01, 1e-6, 1e-6, 1e-6];
        let m = InsModel::new(NOISE, 9.80665, x0, p0, None, 0).unwrap().with_course_alignment(course);
        let mut s = m.initial_state();
        m.hold_imu(&mut s, 0, 1, q.inverse_transform_vector(&Vector3::new(0.0, 0.0, 9.80665)), Vector3::zeros());
        s.kf.reset_error(|P| {
            for (i, j) in [(8, 3), (8, 10), (6, 8)] {
                P[(i, j)] = 0.05;
                P[(j, i)] = 0.05;
            }
        });
        (m, s)
    }

    const ON: CourseAlignment = CourseAlignment { min_speed_mps: 3.0, sideslip_std_rad: 0.02 };

    /// Moving north-west at 10 m/s with an estimated yaw of 0.3 rad: the yaw
    /// becomes the course (3π/4), roll and pitch stay, the heading variance is
    /// `σ_⊥²/|v|² + σ_β²` along world up with no correlation, the rest of the
    /// covariance (the velocity block, the tilt about the horizontal axes)
    /// unchanged, and the change reported is `Δ u`.
    #[test]
    fn the_heading_becomes_the_course() {
        let (m, mut s) = unaligned(Some(ON));
        let before = s;
        let v = Vector3::new(-10.0, 10.0, 0.0) / 2f64.sqrt();
        let R = Matrix3::from_diagonal(&Vector3::new(0.04, 0.01, 0.09));
        let change = m.align_course(&mut s, &v, &R).expect("aligned");
        let (r0, p0, _) = before.q().euler_angles();
        let (r1, p1, y1) = s.q().euler_angles();
        assert!((y1 - 3.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12, "yaw {y1}");
        assert!((r1 - r0).abs() < 1e-12 && (p1 - p0).abs() < 1e-12, "roll/pitch {r0} {p0} -> {r1} {p1}");
        let u = s.q().inverse_transform_vector(&Vector3::z());
        let P = s.filter().P();
        // Across the track (north-east diagonal): (0.04 + 0.01)/2 / 100 + 0.02².
        let expected = 0.025 / 100.0 + 0.0004;
        assert!(((u.transpose() * P.fixed_view::<3, 3>(6, 6) * u)[0] - expected).abs() < 1e-15);
        for j in (0..15).filter(|j| !(6..9).contains(j)) {
            let c: f64 = (0..3).map(|k| u[k] * P[(6 + k, j)]).sum();
            assert!(c.abs() < 1e-15, "heading correlated with state {j}: {c}");
        }
        let Pb = before.filter().P();
        assert_eq!(P.fixed_view::<6, 6>(0, 0), Pb.fixed_view::<6, 6>(0, 0));
        let tilt = u.cross(&Vector3::x()).normalize();
        let tv = |P: &SMatrix<f64, 15, 15>| (tilt.transpose() * P.fixed_view::<3, 3>(6, 6) * tilt)[0];
        assert!((tv(&P) - tv(&Pb)).abs() < 1e-15, "the tilt variance is kept");
        let delta = 3.0 * std::f64::consts::FRAC_PI_4 - 0.3;
        assert!((change.fixed_rows::<3>(6) - u * delta).norm() < 1e-12, "{change:?}");
        assert!(s.filter().x().iter().all(|e| *e == 0.0));
    }

    /// Nothing changes: when not configured, below the speed, once the heading
    /// is known, or before the first IMU sample.
    #[test]
    fn it_aligns_only_when_due() {
        let v = Vector3::new(0.0, 10.0, 0.0);
        let R = Matrix3::identity() * 0.01;
        let (m, mut s) = unaligned(None);
        let before = s;
        assert!(m.align_course(&mut s, &v, &R).is_none());
        assert_eq!(s, before);
        let (m, mut s) = unaligned(Some(ON));
        assert!(m.align_course(&mut s, &(v * 0.29), &R).is_none());
        assert_eq!(s, before);
        m.align_course(&mut s, &v, &R).expect("aligned");
        let aligned = s;
        assert!(m.align_course(&mut s, &Vector3::new(10.0, 0.0, 0.0), &R).is_none(), "the heading is known now");
        assert_eq!(s, aligned);
        let mut fresh = m.initial_state();
        let untouched = fresh;
        assert!(m.align_course(&mut fresh, &v, &R).is_none(), "no IMU sample yet");
        assert_eq!(fresh, untouched);
    }
}
