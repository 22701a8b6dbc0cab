//! The IMU: it drives the propagation. Not a measurement update: the models hold
//! its values (zero-order hold) and propagate with them to the next sample.
//!
//! Several IMUs are combined in the held values
//! ([`crate::model::held_imu`]).
//!
//! Validation: finite, and `|accel| ≤ validation.accel_range_mps2`,
//! `|gyro| ≤ validation.gyro_range_radps` (a value beyond the sensor's range is a
//! corrupted sample).

use fusion_shared::{ImuSample, SampleKind};
use nalgebra::Vector3;

use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, finite};
use crate::model::held_imu::Held;
use crate::model::ins::{InsModel, InsState};
use crate::model::linear::{LinearModel, LinearState};
use crate::model::{Model, StepOutcome};

/// The sample's values rotated into the body frame by its IMU's mount.
fn body_values<M: Model>(imu: &ImuSample, model: &M) -> (Vector3<f64>, Vector3<f64>) {
    let (f, w) = (Vector3::from(imu.accel_mps2), Vector3::from(imu.gyro_radps));
    let mount = model.frames().mount(SampleKind::Imu, imu.header.sensor);
    if mount.unrotated { (f, w) } else { (mount.rotation * f, mount.rotation * w) }
}

impl Measurement for ImuSample {
    const RANK: u8 = 0;
    /// Drives the propagation; observes nothing by itself (the gravity
    /// reference is the model's).
    const LOCKOUT: super::LockoutRule = super::LockoutRule::None;
    const TIMEOUT_NS: u64 = 100_000_000;
    const NEEDED: Option<Needed> = Some(Needed::Propagation);
    const ROTATED: bool = true;
    type Settings = ();

    fn validate(&self, limits: &Limits) -> Result<(), Rejection> {
        finite(&self.accel_mps2)?;
        finite(&self.gyro_radps)?;
        let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if norm(&self.accel_mps2) > limits.accel_range_mps2 || norm(&self.gyro_radps) > limits.gyro_range_radps {
            return Err(Rejection::OutOfRange);
        }
        Ok(())
    }
}

/// `linear`: the world-frame acceleration is held as the input of the next steps
/// (combined over the IMUs as configured; a linear model's IMUs are not rotated).
impl Fuse<LinearModel> for ImuSample {
    fn fuse(&self, model: &LinearModel, s: &mut LinearState) -> (StepOutcome, ()) {
        let (f, w) = (Vector3::from(self.accel_mps2), Vector3::from(self.gyro_radps));
        match model.hold_imu(s, self.header.sensor, self.header.t_ns, f, w) {
            Held::Unknown => (StepOutcome::Refused, ()),
            _ => (StepOutcome::Propagated, ()),
        }
    }
}

/// `ins`: specific force and rate, rotated into the body frame, are held
/// (combined over the IMUs, and summed during the static alignment); then the
/// model's own pseudo-measurements, standstill and the motion constraint, as
/// configured (`InsModel::pseudo_measurements`).
impl<const D: usize> Fuse<InsModel<D>> for ImuSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<nalgebra::SVector<f64, D>>) {
        let (f, w) = body_values(self, model);
        match model.hold_imu(s, self.header.sensor, self.header.t_ns, f, w) {
            Held::Held | Held::Switched => {}
            Held::Standby => return (StepOutcome::Propagated, None),
            Held::Unknown => return (StepOutcome::Refused, None),
        }
        (StepOutcome::Propagated, model.pseudo_measurements(s, self.header.t_ns, f, w))
    }
}

/// The IMU drives the propagation: it observes nothing.
impl<const D: usize> Observe<InsModel<D>, 0, D> for ImuSample {
    fn observe(&self, _: &InsModel<D>, _: &InsState<D>) -> Option<Observation<0, D>> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let imu = ImuSample { gyro_radps: [0.0, f64::INFINITY, 0.0], ..Default::default() };
        assert_eq!(imu.validate(&limits), Err(Rejection::NonFinite));
        assert_eq!(ImuSample::default().validate(&limits), Ok(()));
        let fast = ImuSample { gyro_radps: [30.0, 30.0, 0.0], ..Default::default() };
        assert_eq!(fast.validate(&limits), Err(Rejection::OutOfRange));
        let hard = ImuSample { accel_mps2: [0.0, 0.0, 200.0], ..Default::default() };
        assert_eq!(hard.validate(&limits), Err(Rejection::OutOfRange));
    }
}
