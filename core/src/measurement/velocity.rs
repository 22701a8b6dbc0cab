//! The velocity measurement (GNSS Doppler): `z = v + n`, `n ~ N(0, R)`, with `v`
//! the world-frame (ENU) velocity and R the sample's covariance.
//!
//! - `linear`: `H = [0 I]` (the velocity states are selected), Joseph-form update.
//! - `ins`: `H` selects δv; `h(x) = v` (nominal, the error being zero before the
//!   update); the correction is injected and the error reset, as for a fix.
//!   Through the cross-covariances the velocity also corrects attitude and
//!   accelerometer bias (Groves 2013, §14.2.7, loosely coupled velocity update).
//!   A sensor with a lever arm (a GNSS antenna off the IMU) measures
//!   `v + R (ω × l)` ([`super::lever_arm`]). With `[model.alignment]
//!   heading_from_velocity_mps` an unknown heading is first aligned to the course
//!   over ground ([`crate::model::ins::course`]).
//!
//! Validation: finite, covariance symmetric positive definite. Not required by
//! the health (a vehicle may have no such sensor); stale after 1 s once seen.

#![allow(non_snake_case)]

use fusion_shared::{SampleKind, VelocitySample};
use nalgebra::{Matrix3, Vector3};

use super::{Fuse, Kinematic, Limits, Measurement, Needed, Observation, Observe, Rejection, covariance3, finite, lever_arm};
use crate::model::ins::{InsModel, InsState};
use crate::model::linear::{self, LinearModel, LinearState};
use crate::model::{Model, StepOutcome};

impl Measurement for VelocitySample {
    const RANK: u8 = 2;
    /// A world velocity: the heading as the vehicle moves, and the tilt.
    fn observes(_: Option<&()>) -> super::Observes {
        super::Observes { heading: true, tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::None;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    type Settings = ();

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&self.vel_mps)?;
        covariance3(&self.cov_m2ps2)
    }
}

impl<M: Kinematic> Fuse<M> for VelocitySample {
    fn fuse(&self, model: &M, s: &mut M::State) -> (StepOutcome, M::Correction) {
        let z = Vector3::from(self.vel_mps);
        let R = Matrix3::from_row_slice(&self.cov_m2ps2);
        model.fuse_velocity(s, self.header.sensor, self.header.t_ns, &z, &R)
    }
}

/// `y = z − (v + R (ω × l))`, `H` of [`lever_arm::velocity`].
impl<const D: usize> Observe<InsModel<D>, 3, D> for VelocitySample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<3, D>> {
        let mount = model.frames().mount(SampleKind::Velocity, self.header.sensor);
        let (h, H) = lever_arm::velocity(s, &mount.lever_arm);
        Some(Observation { y: Vector3::from(self.vel_mps) - h, H, R: Matrix3::from_row_slice(&self.cov_m2ps2) })
    }
}

/// `y = z − v`, `H` selecting the velocity states ([`linear::block`]).
impl Observe<LinearModel, 3, { linear::N }> for VelocitySample {
    fn observe(&self, _: &LinearModel, s: &LinearState) -> Option<Observation<3, { linear::N }>> {
        let (h, H) = linear::block(s, 3);
        Some(Observation { y: Vector3::from(self.vel_mps) - h, H, R: Matrix3::from_row_slice(&self.cov_m2ps2) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::model::linear::LinearModel;

    const COV: [f64; 9] = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04];

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        assert_eq!(VelocitySample::new(0, 0, 0, [1.0, 2.0, 3.0], COV).validate(&limits), Ok(()));
        let inf = VelocitySample::new(0, 0, 0, [f64::INFINITY, 2.0, 3.0], COV);
        assert_eq!(inf.validate(&limits), Err(Rejection::NonFinite));
        let mut asym = COV;
        asym[1] = 0.005;
        assert_eq!(
            VelocitySample::new(0, 0, 0, [0.0; 3], asym).validate(&limits),
            Err(Rejection::CovarianceNotSymmetric)
        );
        let mut neg = COV;
        neg[8] = -0.04;
        assert_eq!(
            VelocitySample::new(0, 0, 0, [0.0; 3], neg).validate(&limits),
            Err(Rejection::CovarianceNotPositiveDefinite)
        );
    }

    /// `linear`: H = [0 I]. With P₀ = I and R = I the gain on the velocity block is
    /// ½, the position is untouched (no correlation yet), and NIS = |z|²/2.
    #[test]
    fn linear_fuses_the_velocity_block() {
        let m = LinearModel::new(0.5, [0.0; 6], [1.0; 6], None).unwrap();
        let mut s = m.initial_state();
        let z = VelocitySample::new(5, 0, 0, [2.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let (out, ()) = z.fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { nis } if (nis - 2.0).abs() < 1e-15), "{out:?}");
        let x = s.filter().x();
        assert_eq!(x[0], 0.0);
        assert!((x[3] - 1.0).abs() < 1e-15, "{}", x[3]);
        assert!((s.filter().P()[(3, 3)] - 0.5).abs() < 1e-15);
        assert_eq!(s.filter().P()[(0, 0)], 1.0);
    }

    /// `ins`: H selects δv. With P₀ = I on δv and R = I the nominal velocity moves
    /// half way, the error is reset (mean 0, δv variance ½), NIS = |z − v|²/2.
    #[test]
    fn ins_fuses_the_velocity_error_and_injects_it() {
        use crate::model::ins::{ImuNoise, InsModel};
        let noise = ImuNoise {
            accelerometer_noise_density: 0.02,
            gyroscope_noise_density: 0.001,
            accelerometer_random_walk: 0.001,
            gyroscope_random_walk: 1e-5,
        };
        let mut x0 = [0.0; 16];
        x0[3] = 10.0;
        x0[6] = 1.0;
        let m = InsModel::new(noise, 9.80665, x0, [1.0; 15], None, 0).unwrap();
        let mut s = m.initial_state();
        let z = VelocitySample::new(5, 0, 0, [12.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let (out, injected) = z.fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { nis } if (nis - 2.0).abs() < 1e-12), "{out:?}");
        assert!((s.v().x - 11.0).abs() < 1e-12 && s.p().x == 0.0, "v {:?}", s.v());
        assert!((injected.unwrap()[3] - 1.0).abs() < 1e-12);
        assert!((s.filter().P()[(3, 3)] - 0.5).abs() < 1e-12);
        assert!(s.filter().x().iter().all(|e| *e == 0.0), "the error is reset");
    }
}
