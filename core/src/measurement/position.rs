//! The position fix: `z = p + v`, `v ~ N(0, R)`, R the sample's covariance.
//!
//! - `linear`: `H = [I 0]` (the position states are selected), Joseph-form update.
//! - `ins`: `H` selects δp; the error state is zero before the update, so
//!   `h(x) = p` (nominal); the correction is injected into the nominal state and
//!   the error reset (Solà 2017, §7.2–7.3). A sensor with a lever arm (a GNSS
//!   antenna off the IMU) measures `p + R l` ([`super::lever_arm`]).
//!
//! In both models a long enough run of gated fixes re-initialises the filter from
//! the fixes ([`crate::model::lockout`]).
//!
//! Validation: finite, covariance symmetric positive definite.

#![allow(non_snake_case)]

use fusion_shared::{PositionSample, SampleKind};
use nalgebra::{Matrix3, Vector3};

use super::{Fuse, Kinematic, Limits, Measurement, Needed, Observation, Observe, Rejection, covariance3, finite, lever_arm};
use crate::model::ins::{InsModel, InsState};
use crate::model::linear::{self, LinearModel, LinearState};
use crate::model::{Model, StepOutcome};

impl Measurement for PositionSample {
    const RANK: u8 = 1;
    /// The horizontal position, and the tilt through the accelerometer.
    fn observes(_: Option<&()>) -> super::Observes {
        super::Observes { horizontal_position: true, tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Reinitialises;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = Some(Needed::Position);
    type Settings = ();

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&self.pos_m)?;
        covariance3(&self.cov_m2)
    }
}

impl<M: Kinematic> Fuse<M> for PositionSample {
    fn fuse(&self, model: &M, s: &mut M::State) -> (StepOutcome, M::Correction) {
        let z = Vector3::from(self.pos_m);
        let R = Matrix3::from_row_slice(&self.cov_m2);
        model.fuse_position(s, SampleKind::Position, self.header.sensor, &z, &R)
    }
}

/// `y = z − (p + R l)`, `H` of [`lever_arm::position`].
impl<const D: usize> Observe<InsModel<D>, 3, D> for PositionSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<3, D>> {
        let mount = model.frames().mount(SampleKind::Position, self.header.sensor);
        let (h, H) = lever_arm::position(s, &mount.lever_arm);
        Some(Observation { y: Vector3::from(self.pos_m) - h, H, R: Matrix3::from_row_slice(&self.cov_m2) })
    }
}

/// `y = z − p`, `H` selecting the position states ([`linear::block`]).
impl Observe<LinearModel, 3, { linear::N }> for PositionSample {
    fn observe(&self, _: &LinearModel, s: &LinearState) -> Option<Observation<3, { linear::N }>> {
        let (h, H) = linear::block(s, 0);
        Some(Observation { y: Vector3::from(self.pos_m) - h, H, R: Matrix3::from_row_slice(&self.cov_m2) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let good = [1.0, 0.1, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 2.0];
        assert_eq!(PositionSample::new(0, 0, 0, [1.0, 2.0, 3.0], good).validate(&limits), Ok(()));
        let nan = PositionSample::new(0, 0, 0, [1.0, f64::NAN, 3.0], good);
        assert_eq!(nan.validate(&limits), Err(Rejection::NonFinite));
        let bad = PositionSample::new(0, 0, 0, [1.0, 2.0, 3.0], [1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 2.0]);
        assert_eq!(bad.validate(&limits), Err(Rejection::CovarianceNotPositiveDefinite));
    }
}
