//! Measurements of a point off the body origin (a GNSS antenna), for the `ins`
//! model: the point's position and velocity through the attitude and the rate.
//!
//! With `l` the point's lever arm in the body frame, `R` the attitude (body →
//! world) and `ω = ω_m − b_g` the body rate (Groves 2013, eq. 14.121–14.122;
//! PX4 EKF2 `fuseGpsPos`/`fuseGpsVel` with `EKF2_GPS_POS_*`):
//!
//! ```text
//! position:  h = p + R l
//! velocity:  h = v + R (ω × l)
//! ```
//!
//! Jacobians with respect to the error state `[δp, δv, δθ, δb_a, δb_g]` (local
//! attitude error, `R_true = R Exp(δθ) ≈ R (I + [δθ]×)`, and `ω_true = ω − δb_g`):
//!
//! ```text
//! position:  H = [ I   0   −R [l]×        0   0       ]
//! velocity:  H = [ 0   I   −R [ω × l]×    0   R [l]×  ]
//! ```
//!
//! (`R [δθ]× a = −R [a]× δθ`, and `R ((−δb_g) × l) = R [l]× δb_g`). Each is checked
//! against numerical differentiation in the tests.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use fusion_shared::SampleKind;

use crate::frames::Mount;
use crate::model::ins::{InsModel, InsState};
use crate::model::{Kinematic, Model, StepOutcome};

/// `h` and `H` of a 3-vector measured at a lever arm ([`position`], [`velocity`]).
type AtArm<const D: usize> = fn(&InsState<D>, &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, D>);

/// `h` and `H` of the position of the point at lever arm `l`.
pub fn position<const D: usize>(s: &InsState<D>, l: &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let mut H = SMatrix::<f64, 3, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(-R * l.cross_matrix()));
    (s.p() + R * l, H)
}

/// `h` and `H` of the velocity of the point at lever arm `l`.
pub fn velocity<const D: usize>(s: &InsState<D>, l: &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let wl = InsModel::<D>::body_rate(s).cross(l);
    let mut H = SMatrix::<f64, 3, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::identity());
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(-R * wl.cross_matrix()));
    // While standing `ω` is 0 whatever `b_g` is ([`InsModel::body_rate`]).
    if !s.standing() {
        H.fixed_view_mut::<3, 3>(0, 12).copy_from(&(R * l.cross_matrix()));
    }
    (s.v() + R * wl, H)
}

/// The INS fuses a position or a velocity of the point at the sensor's lever
/// arm; a velocity also feeds the time-offset estimate (`ins::clock`) and, with
/// an unknown heading, the alignment to the course over ground (`ins::course`).
impl<const D: usize> Kinematic for InsModel<D> {
    fn fuse_position(
        &self,
        s: &mut InsState<D>,
        kind: SampleKind,
        sensor: u32,
        z: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        fuse_position(self, s, self.frames().mount(kind, sensor), z, R)
    }

    fn fuse_velocity(
        &self,
        s: &mut InsState<D>,
        sensor: u32,
        t_ns: u64,
        z: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        let mount = self.frames().mount(SampleKind::Velocity, sensor);
        let rotational = velocity(s, &mount.lever_arm).0 - s.v();
        let at_origin = z - rotational;
        self.observe_velocity(s, t_ns, &at_origin, R);
        let turned = self.align_course(s, &at_origin, R);
        let (outcome, injected) = fuse_velocity(self, s, mount, z, R);
        (outcome, crate::model::ins::record::both(turned, injected))
    }
}

/// Fuses a position `z` (covariance `R`) of the point of `mount`; at the origin,
/// the plain position update on δp. After a lock-out the filter re-initialises
/// from the fixes ([`crate::model::lockout`]), taken to the body origin as `z − R l`
/// with the attitude held.
pub fn fuse_position<const D: usize>(
    model: &InsModel<D>,
    s: &mut InsState<D>,
    mount: &Mount,
    z: &Vector3<f64>,
    R: &Matrix3<f64>,
) -> (StepOutcome, Option<SVector<f64, D>>) {
    let (outcome, correction) = fuse_at(model, s, mount, z, R, 0, position);
    if model.lockout().is_some() {
        let origin = if mount.at_origin { *z } else { z - s.q().to_rotation_matrix() * mount.lever_arm };
        model.observe_fix(s, &outcome, &origin, R);
    }
    (outcome, correction)
}

/// Fuses a velocity `z` (covariance `R`) of the point of `mount`; at the origin,
/// the plain velocity update on δv.
pub fn fuse_velocity<const D: usize>(
    model: &InsModel<D>,
    s: &mut InsState<D>,
    mount: &Mount,
    z: &Vector3<f64>,
    R: &Matrix3<f64>,
) -> (StepOutcome, Option<SVector<f64, D>>) {
    fuse_at(model, s, mount, z, R, 3, velocity)
}

/// A measurement of the nominal block at `offset` (position 0, velocity 3) of the
/// point of `mount`: at the origin the block itself, selected (the lean update);
/// elsewhere `h` and `H` of `at_arm` about the lever arm.
fn fuse_at<const D: usize>(
    model: &InsModel<D>,
    s: &mut InsState<D>,
    mount: &Mount,
    z: &Vector3<f64>,
    R: &Matrix3<f64>,
    offset: usize,
    at_arm: AtArm<D>,
) -> (StepOutcome, Option<SVector<f64, D>>) {
    if mount.at_origin {
        let predicted = Vector3::from_column_slice(&InsModel::<D>::x_of(s)[offset..offset + 3]);
        return model.update_block(s, z, &predicted, offset, R);
    }
    let (h, H) = at_arm(s, &mount.lever_arm);
    model.update_residual(s, &(z - h), &H, R)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ins::tests_support::{moving_state, numeric_jacobian};

    #[test]
    fn position_jacobian_matches_numerical_differentiation() {
        let s = moving_state();
        let l = Vector3::new(1.5, -0.3, 1.1);
        let (_, H) = position(&s, &l);
        let numeric = numeric_jacobian(&s, |x| position(x, &l).0);
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        assert!(H.fixed_view::<3, 3>(0, 6).amax() > 0.5, "the attitude really enters");
    }

    #[test]
    fn velocity_jacobian_matches_numerical_differentiation() {
        let s = moving_state();
        let l = Vector3::new(1.5, -0.3, 1.1);
        let (h, H) = velocity(&s, &l);
        let numeric = numeric_jacobian(&s, |x| velocity(x, &l).0);
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        assert!(H.fixed_view::<3, 3>(0, 12).amax() > 0.5 && H.fixed_view::<3, 3>(0, 6).amax() > 0.1);
        // A 0.4 rad/s turn moves an antenna 1.5 m ahead sideways at 0.6 m/s.
        assert!((h - s.v()).norm() > 0.3, "{h} {}", s.v());
    }

    /// The antenna's position is fused where it is: with the true attitude and an
    /// exact fix of the antenna, the IMU position is not moved.
    #[test]
    fn an_exact_antenna_fix_leaves_the_imu_position_alone() {
        let m = crate::model::ins::tests_support::model();
        let mut s = moving_state();
        let mount = Mount::new(crate::frames::Axes::Flu, [0.0; 3], [1.5, 0.0, 1.0]);
        let (h, _) = position(&s, &mount.lever_arm);
        let p = s.p();
        let (out, _) = fuse_position(&m, &mut s, &mount, &h, &(Matrix3::identity() * 0.01));
        assert!(matches!(out, StepOutcome::Fused { nis } if nis < 1e-20), "{out:?}");
        assert!((s.p() - p).norm() < 1e-12);
        // Without the lever arm, the same fix moves it by about the arm.
        let mut t = moving_state();
        fuse_position(&m, &mut t, &Mount::IDENTITY, &h, &(Matrix3::identity() * 0.01));
        assert!((t.p() - p).norm() > 1.0, "{}", (t.p() - p).norm());
    }
}
