//! Wheel odometry: the forward speed of the body at the sensor's reference point.
//!
//! With `l` the point's lever arm (the middle of the axle), `R` the attitude and
//! `ω = ω_m − b_g` the body rate, the point's body-frame velocity is
//! `v_b = Rᵀ v + ω × l`, and the sample measures its forward component:
//!
//! ```text
//! z = e₁ᵀ (Rᵀ v + ω × l) + n,   n ~ N(0, σ²)
//! H = [ 0   e₁ᵀRᵀ   e₁ᵀ [Rᵀ v]×   0   e₁ᵀ [l]× ]
//! ```
//!
//! (local attitude error: `R_trueᵀ ≈ (I − [δθ]×) Rᵀ`, so `δ(Rᵀ v) = Rᵀ δv + [Rᵀ v]× δθ`;
//! `ω_true = ω − δb_g`, so `δ(ω × l) = [l]× δb_g`; Groves 2013, §16.2.1 and
//! eq. 14.121 for the lever arm.) Through the attitude it observes heading and
//! pitch together with the velocity; the sideways and vertical components are the
//! motion constraint's ([`crate::model::ins::nonholonomic`]).
//!
//! With the scale factor `k` as a state (`[model.odometry_scale]`,
//! [`OdometryScale`](crate::model::ins::OdometryScale)) the sensor measures `k`
//! times that speed `u`, and the error in `k` is one more column:
//!
//! ```text
//! z = k u + n,   H = [ k H_u   u ]
//! ```
//!
//! (Groves 2013, eq. 16.15, with `k = 1 + s_o`.) While GNSS shows the velocity,
//! `k` is learned from the difference; through an outage the learned `k` and its
//! variance are carried, so the speed's scale error neither pulls the position
//! nor is believed away.
//!
//! - `ins`: the update above, Joseph form, gated, injected and reset; refused
//!   until roll and pitch are known to [`nonholonomic::MAX_ATTITUDE_SD`]
//!   ([`nonholonomic::tilt_known`]): a body-frame speed needs the tilt, never
//!   the heading, so a robot without a heading source fuses its wheels.
//! - `linear`: refused (no attitude to turn a body speed into the world frame);
//!   a config naming an odometry sensor is refused at start-up.
//!
//! Validation: finite; |speed| ≤ [`MAX_SPEED_MPS`]; variance ≥ 0 and ≤
//! [`MAX_SPEED_MPS`]², fused as at least [`VARIANCE_FLOOR`] (a driver's 0).
//! Not required by the health; stale after 1 s once seen.

#![allow(non_snake_case)]

use fusion_shared::{OdometrySample, SampleKind};
use nalgebra::{Matrix1, SMatrix, SVector, Vector1, Vector3};

use super::components::VARIANCE_FLOOR;
use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, finite};
use crate::model::ins::nonholonomic;
use crate::model::ins::{InsModel, InsState, N};
use crate::model::{Model, StepOutcome};

/// The fastest speed accepted, m/s (540 km/h).
pub const MAX_SPEED_MPS: f64 = 150.0;

impl Measurement for OdometrySample {
    const RANK: u8 = 2;
    /// A body-frame speed: the tilt, neither the heading nor the position.
    fn observes(_: Option<&()>) -> super::Observes {
        super::Observes { tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;

    /// Wheels that stand: an encoder that counts no tick reads exactly 0.
    fn exact(&self) -> bool {
        self.speed_mps == 0.0
    }
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    type Settings = ();

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&[self.speed_mps, self.var_m2ps2])?;
        if self.speed_mps.abs() > MAX_SPEED_MPS {
            return Err(Rejection::OutOfRange);
        }
        // A zero variance (a driver's "not given" or "exact") is fused as
        // [`VARIANCE_FLOOR`], as robot_localization floors it.
        if !(self.var_m2ps2 >= 0.0 && self.var_m2ps2 <= MAX_SPEED_MPS * MAX_SPEED_MPS) {
            return Err(Rejection::VarianceNotPositive);
        }
        Ok(())
    }
}

/// `h` and `H` of the forward speed of the point at lever arm `l`, as the
/// sensor measures it (times the scale factor, when it is a state).
pub fn forward_speed<const D: usize>(s: &InsState<D>, l: &Vector3<f64>) -> (f64, SMatrix<f64, 1, D>) {
    let (v_p, H_p) = nonholonomic::point_velocity(s, l);
    let (u, mut H) = (v_p.x, H_p.fixed_rows::<1>(0).into_owned());
    match s.odometry_scale() {
        Some(k) => {
            H *= k;
            H[(0, N)] = u;
            (k * u, H)
        }
        None => (u, H),
    }
}

impl<const D: usize> Fuse<InsModel<D>> for OdometrySample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        model.note_speed(s, self.header.t_ns, self.speed_mps);
        match self.observe(model, s) {
            Some(o) => model.update_residual(s, &o.y, &o.H, &o.R),
            None => (StepOutcome::Refused, None),
        }
    }
}

/// `y = z − k u` of [`forward_speed`]; `None` while the tilt is unknown (a
/// body-frame speed needs the tilt, not the heading: a robot without a heading
/// source fuses its wheels from the start).
impl<const D: usize> Observe<InsModel<D>, 1, D> for OdometrySample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<1, D>> {
        if !nonholonomic::tilt_known(s) {
            return None;
        }
        let mount = model.frames().mount(SampleKind::Odometry, self.header.sensor);
        let (h, H) = forward_speed(s, &mount.lever_arm);
        let R = Matrix1::new(self.var_m2ps2.max(VARIANCE_FLOOR));
        Some(Observation { y: Vector1::new(self.speed_mps - h), H, R })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ins::tests_support::{model, moving_scaled_state, moving_state, numeric_jacobian, scaled_model, set_scale};

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let odo = |speed, var| OdometrySample::new(0, 0, 0, speed, var).validate(&limits);
        assert_eq!(odo(12.0, 0.01), Ok(()));
        assert_eq!(odo(-3.0, 0.01), Ok(()), "reversing");
        assert_eq!(odo(f64::NAN, 0.01), Err(Rejection::NonFinite));
        assert_eq!(odo(12.0, f64::INFINITY), Err(Rejection::NonFinite));
        assert_eq!(odo(12.0, -0.01), Err(Rejection::VarianceNotPositive));
        assert_eq!(odo(12.0, 0.0), Ok(()), "a zero variance is floored when fused");
        assert_eq!(odo(1e6, 0.01), Err(Rejection::OutOfRange));
    }

    #[test]
    fn jacobian_matches_numerical_differentiation() {
        let s = moving_state();
        let l = Vector3::new(-1.3, 0.4, -0.3);
        let (h, H) = forward_speed(&s, &l);
        let numeric = numeric_jacobian(&s, |x| Vector1::new(forward_speed(x, &l).0));
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        // The 0.4 rad/s turn seen 0.4 m to the left slows the point by 0.16 m/s.
        assert!((h - (12.0 - 0.4 * 0.4)).abs() < 0.02, "{h}");
        assert!(H.fixed_view::<1, 3>(0, 6).amax() > 0.1, "the attitude enters");
    }

    /// With the scale factor as a state: `h = k u`, and the column of `δk` is `u`
    /// (against central differences, as every other column).
    #[test]
    fn the_scaled_jacobian_matches_numerical_differentiation() {
        let s = moving_scaled_state();
        let l = Vector3::new(-1.3, 0.4, -0.3);
        let (h, H) = forward_speed(&s, &l);
        let numeric = numeric_jacobian(&s, |x| Vector1::new(forward_speed(x, &l).0));
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        let (u, _) = forward_speed(&moving_state(), &l);
        assert!((h - 1.03 * u).abs() < 1e-12, "{h} vs 1.03 × {u}");
        assert!((H[(0, N)] - u).abs() < 1e-12, "the scale's column is the unscaled speed");
    }

    /// A car whose odometer reads 2 % fast: fused against a velocity that is
    /// known (GNSS), the speed's excess goes into the scale factor, not the
    /// velocity, and its variance shrinks.
    #[test]
    fn a_known_velocity_teaches_the_scale() {
        let m = scaled_model();
        let mut s = moving_scaled_state();
        set_scale(&mut s, 1.0);
        let mut P = SMatrix::<f64, { N + 1 }, { N + 1 }>::zeros();
        for i in 0..N {
            P[(i, i)] = 1e-8;
        }
        P[(N, N)] = 0.02 * 0.02;
        s.filter_mut().set_state(SVector::zeros(), P).unwrap();
        let (u, _) = forward_speed(&s, &Vector3::zeros());
        let v = s.v();
        for _ in 0..20 {
            let odo = OdometrySample::new(0, 0, 0, 1.02 * u, 0.05 * 0.05);
            assert!(matches!(odo.fuse(&m, &mut s).0, StepOutcome::Fused { .. }));
        }
        let k = s.odometry_scale().unwrap();
        assert!((k - 1.02).abs() < 0.002, "k = {k}");
        assert!((s.v() - v).norm() < 1e-3, "the velocity moved {}", (s.v() - v).norm());
        assert!(s.filter().variance(N) < 0.1 * 0.02 * 0.02);
    }

    /// The measured speed moves the velocity along the body's forward axis only.
    #[test]
    fn a_faster_speed_speeds_the_estimate_up_along_the_body_axis() {
        let m = model();
        let mut s = moving_state();
        let v = s.v();
        let forward = s.q() * Vector3::x();
        let (h, _) = forward_speed(&s, &Vector3::zeros());
        let odo = OdometrySample::new(0, 0, 0, h + 1.0, 1e-4);
        // With the attitude unknown (1 rad) it waits, changing nothing.
        let before = s;
        assert_eq!(odo.fuse(&m, &mut s).0, StepOutcome::Refused);
        assert_eq!(InsModel::x_of(&s), InsModel::x_of(&before));
        assert_eq!(s.filter().P(), before.filter().P());
        let mut P = s.filter().P();
        for i in 6..9 {
            P[(i, i)] = 1e-4;
        }
        s.filter_mut().set_state(SVector::zeros(), P).unwrap();
        let (out, _) = odo.fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
        let dv = s.v() - v;
        assert!(dv.dot(&forward) > 0.3, "{dv}");
    }

    /// With the heading unknown (1 rad) but roll and pitch known, the wheels
    /// are fused: a body-frame speed needs no heading (3932 of 3952 samples of
    /// a robot without a heading source were refused, and it ended ~700 km off).
    #[test]
    fn an_unknown_heading_does_not_hold_the_wheels_back() {
        let m = model();
        let mut s = moving_state();
        let mut P = s.filter().P();
        for i in 0..15 {
            for j in 0..15 {
                if i != j && ((6..9).contains(&i) || (6..9).contains(&j)) {
                    P[(i, j)] = 0.0;
                }
            }
        }
        // The attitude error about the world's up axis (the heading) 1 rad; tilt 0.01 rad.
        let R = s.q().to_rotation_matrix().into_inner();
        let world = nalgebra::Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1.0));
        P.fixed_view_mut::<3, 3>(6, 6).copy_from(&(R.transpose() * world * R));
        s.filter_mut().set_state(SVector::zeros(), P).unwrap();
        assert!(!nonholonomic::attitude_known(&s) && nonholonomic::tilt_known(&s));
        let (h, _) = forward_speed(&s, &Vector3::zeros());
        let (out, _) = OdometrySample::new(0, 0, 0, h + 0.2, 0.01).fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
        // An unknown tilt still holds it back.
        let mut P = s.filter().P();
        P[(6, 6)] = 1.0;
        s.filter_mut().set_state(SVector::zeros(), P).unwrap();
        assert_eq!(OdometrySample::new(0, 0, 0, h, 0.01).fuse(&m, &mut s).0, StepOutcome::Refused);
    }
}
