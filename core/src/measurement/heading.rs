//! Heading: the yaw of the body frame (dual-antenna GNSS, compass).
//!
//! Yaw is the angle of the body's forward axis `R e₁` in the world frame from east,
//! counter-clockwise: `ψ = atan2(R₁₀, R₀₀)`. With the local attitude error
//! `R_true ≈ R (I + [δθ]×)`, `δ(R e₁) = R (δθ × e₁) = −R [e₁]× δθ`, so
//!
//! ```text
//! z = ψ + n,  n ~ N(0, σ²)
//! H_δθ = (R₀₀ ∂R₁₀ − R₁₀ ∂R₀₀) / (R₀₀² + R₁₀²),   ∂R_{i0} = −(R [e₁]×)ᵢ,   H = [0 0 H_δθ 0 0]
//! ```
//!
//! and the residual `z − ψ` is wrapped into (−π, π], so 179° against −179° is a
//! 2° residual, not 358°. The same as the yaw update of PX4 EKF2
//! (`fuseYaw`, 3-2-1 Euler sequence) written for the local attitude error.
//!
//! - `ins`: the update above, Joseph form, gated, injected and reset. Refused
//!   with the forward axis within 0.06° of vertical (yaw undefined).
//! - `linear`: refused (no attitude); a config naming a heading sensor is refused
//!   at start-up.
//!
//! Validation: finite; |yaw| ≤ [`MAX_YAW_RAD`]; variance > 0 and ≤ π². Not
//! required by the health; stale after 1 s once seen.

#![allow(non_snake_case)]

use std::f64::consts::PI;

use fusion_shared::HeadingSample;
use nalgebra::{Matrix1, SMatrix, SVector, Vector1, Vector3};

use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, finite};
use crate::filter::wrap_angle as wrap;
use crate::model::StepOutcome;
use crate::model::ins::{InsModel, InsState};

/// Largest |yaw| accepted, rad: a wrapped angle or a few turns of an unwrapped one.
pub const MAX_YAW_RAD: f64 = 1000.0;

/// `R₀₀² + R₁₀²` below which yaw is undefined (forward axis near vertical).
const MIN_HORIZONTAL: f64 = 1e-6;

impl Measurement for HeadingSample {
    const RANK: u8 = 2;
    /// The yaw, and (as an attitude) the tilt.
    fn observes(_: Option<&()>) -> super::Observes {
        super::Observes { heading: true, tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    type Settings = ();

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&[self.yaw_rad, self.var_rad2])?;
        if self.yaw_rad.abs() > MAX_YAW_RAD {
            return Err(Rejection::OutOfRange);
        }
        if !(self.var_rad2 > 0.0 && self.var_rad2 <= PI * PI) {
            return Err(Rejection::VarianceNotPositive);
        }
        Ok(())
    }
}


/// `h` and `H` of the yaw; `None` with the forward axis near vertical.
pub fn yaw<const D: usize>(s: &InsState<D>) -> Option<(f64, SMatrix<f64, 1, D>)> {
    let R = s.q().to_rotation_matrix().into_inner();
    let (c, d) = (R[(0, 0)], R[(1, 0)]);
    let horizontal = c * c + d * d;
    if horizontal < MIN_HORIZONTAL {
        return None;
    }
    let dR = -R * Vector3::x().cross_matrix(); // rows: ∂(R e₁)ᵢ / ∂δθ
    let mut H = SMatrix::<f64, 1, D>::zeros();
    for k in 0..3 {
        H[(0, 6 + k)] = (c * dR[(1, k)] - d * dR[(0, k)]) / horizontal;
    }
    Some((d.atan2(c), H))
}

impl<const D: usize> Fuse<InsModel<D>> for HeadingSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        match self.observe(model, s) {
            Some(o) => model.update_residual(s, &o.y, &o.H, &o.R),
            None => (StepOutcome::Refused, None),
        }
    }
}

/// `y = wrap(z − ψ)` of [`yaw`]; `None` with the forward axis near vertical.
impl<const D: usize> Observe<InsModel<D>, 1, D> for HeadingSample {
    fn observe(&self, _: &InsModel<D>, s: &InsState<D>) -> Option<Observation<1, D>> {
        let (h, H) = yaw(s)?;
        Some(Observation { y: Vector1::new(wrap(self.yaw_rad - h)), H, R: Matrix1::new(self.var_rad2) })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitQuaternion;

    use super::*;
    use crate::model::ins::tests_support::{model, moving_state, numeric_jacobian};

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let heading = |yaw, var| HeadingSample::new(0, 0, 0, yaw, var).validate(&limits);
        assert_eq!(heading(3.0, 1e-3), Ok(()));
        assert_eq!(heading(-40.0, 1e-3), Ok(()), "an unwrapped angle");
        assert_eq!(heading(1e9, 1e-3), Err(Rejection::OutOfRange));
        assert_eq!(heading(f64::NAN, 1e-3), Err(Rejection::NonFinite));
        assert_eq!(heading(0.0, -1e-3), Err(Rejection::VarianceNotPositive));
        assert_eq!(heading(0.0, 100.0), Err(Rejection::VarianceNotPositive));
    }

    #[test]
    fn residuals_wrap_into_the_half_open_interval() {
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-15);
        assert!((wrap(179f64.to_radians() - (-179f64).to_radians()) + 2f64.to_radians()).abs() < 1e-12);
        assert!((wrap(7.0 * PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
        assert!((wrap(-0.3) + 0.3).abs() < 1e-15);
    }

    #[test]
    fn jacobian_matches_numerical_differentiation() {
        let s = moving_state();
        let (h, H) = yaw(&s).unwrap();
        let numeric = numeric_jacobian(&s, |x| Vector1::new(yaw(x).unwrap().0));
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        assert!((h - 2.3).abs() < 1e-12, "{h}");
        // Level, the yaw is the rotation about the body's z axis (up).
        let mut level = s;
        level.set(s.p(), s.v(), UnitQuaternion::from_euler_angles(0.0, 0.0, 1.0), s.b_a(), s.b_g());
        let (_, H) = yaw(&level).unwrap();
        assert!((H[(0, 8)] - 1.0).abs() < 1e-12 && H[(0, 6)].abs() < 1e-12 && H[(0, 7)].abs() < 1e-12);
    }

    /// Across ±π the update takes the short way round: a measured −179° against an
    /// estimate of 179° turns the estimate by about +2° · gain, to near ±180°.
    #[test]
    fn the_update_across_pi_takes_the_short_way() {
        let m = model();
        let mut s = moving_state();
        s.set(s.p(), s.v(), UnitQuaternion::from_euler_angles(0.0, 0.0, 179f64.to_radians()), s.b_a(), s.b_g());
        let z = HeadingSample::new(0, 0, 0, (-179f64).to_radians(), 1e-6);
        let (out, _) = z.fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
        let after = yaw(&s).unwrap().0;
        assert!(wrap(after - (-179f64).to_radians()).abs() < 0.01, "{}", after.to_degrees());
    }
}
