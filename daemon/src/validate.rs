//! Input validation: every sample is checked before it can reach the filter.
//!
//! A rejected sample is counted with its [`Rejection`] reason; it never changes the
//! estimate. The same checks run live and in replay.

use fusion_shared::{ImuSample, PositionSample};
use nalgebra::{Cholesky, Matrix3};

/// Why a sample was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rejection {
    /// A NaN or ±∞ in a value.
    NonFinite,
    /// The covariance differs from its transpose beyond rounding.
    CovarianceNotSymmetric,
    /// The covariance has no Cholesky factor (not positive definite).
    CovarianceNotPositiveDefinite,
    /// The timestamp lies further in the future than `validation.max_future_ns`.
    FutureTimestamp,
    /// More distinct sensor ids of this kind than `validation.max_sensors`.
    TooManySensors,
    /// An IMU value beyond the sensor's range (`validation.accel_range_mps2`,
    /// `validation.gyro_range_radps`): a corrupted sample.
    OutOfRange,
}

impl Rejection {
    /// A short reason for logs and summaries.
    pub const fn reason(self) -> &'static str {
        match self {
            Rejection::NonFinite => "non-finite value",
            Rejection::CovarianceNotSymmetric => "covariance not symmetric",
            Rejection::CovarianceNotPositiveDefinite => "covariance not positive definite",
            Rejection::FutureTimestamp => "timestamp in the future",
            Rejection::TooManySensors => "too many sensors",
            Rejection::OutOfRange => "beyond the sensor range",
        }
    }
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.reason())
    }
}

/// Relative tolerance of the symmetry check, against the largest entry.
const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// Checks an IMU sample's values: finite, and the magnitudes of acceleration
/// and rate within the sensor's range.
pub fn check_imu(s: &ImuSample, accel_range: f64, gyro_range: f64) -> Result<(), Rejection> {
    if !s.accel_mps2.iter().chain(&s.gyro_radps).all(|v| v.is_finite()) {
        return Err(Rejection::NonFinite);
    }
    let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if norm(&s.accel_mps2) > accel_range || norm(&s.gyro_radps) > gyro_range {
        return Err(Rejection::OutOfRange);
    }
    Ok(())
}

/// Checks a position sample: finite, covariance symmetric positive definite.
pub fn check_position(s: &PositionSample) -> Result<(), Rejection> {
    if !s.pos_m.iter().chain(&s.cov_m2).all(|v| v.is_finite()) {
        return Err(Rejection::NonFinite);
    }
    let c = Matrix3::from_row_slice(&s.cov_m2);
    if (c - c.transpose()).amax() > SYMMETRY_TOLERANCE * c.amax() {
        return Err(Rejection::CovarianceNotSymmetric);
    }
    if Cholesky::new(c).is_none() {
        return Err(Rejection::CovarianceNotPositiveDefinite);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pos(cov: [f64; 9]) -> PositionSample {
        PositionSample { pos_m: [1.0, 2.0, 3.0], cov_m2: cov, ..Default::default() }
    }

    #[test]
    fn every_bad_value_has_its_reason() {
        let good = [1.0, 0.1, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 2.0];
        assert_eq!(check_position(&pos(good)), Ok(()));
        let mut nan = pos(good);
        nan.pos_m[1] = f64::NAN;
        assert_eq!(check_position(&nan), Err(Rejection::NonFinite));
        assert_eq!(
            check_position(&pos([1.0, 0.5, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 2.0])),
            Err(Rejection::CovarianceNotSymmetric)
        );
        assert_eq!(
            check_position(&pos([1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 2.0])),
            Err(Rejection::CovarianceNotPositiveDefinite)
        );
        assert_eq!(check_position(&pos([0.0; 9])), Err(Rejection::CovarianceNotPositiveDefinite));
        let imu = ImuSample { gyro_radps: [0.0, f64::INFINITY, 0.0], ..Default::default() };
        assert_eq!(check_imu(&imu, 160.0, 35.0), Err(Rejection::NonFinite));
        assert_eq!(check_imu(&ImuSample::default(), 160.0, 35.0), Ok(()));
        let fast = ImuSample { gyro_radps: [30.0, 30.0, 0.0], ..Default::default() };
        assert_eq!(check_imu(&fast, 160.0, 35.0), Err(Rejection::OutOfRange));
        let hard = ImuSample { accel_mps2: [0.0, 0.0, 200.0], ..Default::default() };
        assert_eq!(check_imu(&hard, 160.0, 35.0), Err(Rejection::OutOfRange));
    }
}
