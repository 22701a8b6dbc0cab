//! Input validation: every sample is checked before it can reach the filter.
//!
//! A rejected sample is counted with its [`Rejection`] reason; it never changes the
//! estimate. The same checks run live and in replay. Each kind's checks live in its
//! measurement module; this file names the reasons and the limits they use, and
//! reads the `[validation]` table ([`ValidationConfig`]).

use fusion_shared::snapshot::MAX_SENSORS;

use crate::setting::{ConfigError, invalid, positive};

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
    /// The timestamp lies further in the past than `validation.max_past_ns`
    /// (an unset or foreign clock).
    PastTimestamp,
    /// Without a clock (replay): the timestamp jumps further ahead of everything
    /// processed than `validation.max_jump_ns`.
    TimeJump,
    /// More distinct sensor ids of this kind than `validation.max_sensors`, or
    /// more sensors in all than a snapshot has rows for.
    TooManySensors,
    /// A value beyond what the sensor can report: an IMU value beyond its range
    /// (`validation.accel_range_mps2`, `validation.gyro_range_radps`), a latitude
    /// beyond ±90°, a speed or an angle no vehicle has: a corrupted sample.
    OutOfRange,
    /// A variance that is not > 0 (or is absurdly large).
    VarianceNotPositive,
    /// The header's kind code is not the kind of the payload (of the service the
    /// sample came on): a publisher writing another wire layout, or garbage.
    WrongKind,
    /// Without a clock (replay): the timestamp steps further back behind
    /// everything processed than `validation.max_jump_ns`.
    TimeStepBack,
}

impl Rejection {
    /// Its code in snapshots ([`fusion_shared::snapshot::rejection`]).
    pub const fn code(self) -> u32 {
        use fusion_shared::snapshot::rejection as r;
        match self {
            Rejection::NonFinite => r::NON_FINITE,
            Rejection::CovarianceNotSymmetric => r::COVARIANCE_NOT_SYMMETRIC,
            Rejection::CovarianceNotPositiveDefinite => r::COVARIANCE_NOT_POSITIVE_DEFINITE,
            Rejection::FutureTimestamp => r::FUTURE_TIMESTAMP,
            Rejection::PastTimestamp => r::PAST_TIMESTAMP,
            Rejection::TimeJump => r::TIME_JUMP,
            Rejection::TooManySensors => r::TOO_MANY_SENSORS,
            Rejection::OutOfRange => r::OUT_OF_RANGE,
            Rejection::VarianceNotPositive => r::VARIANCE_NOT_POSITIVE,
            Rejection::WrongKind => r::WRONG_KIND,
            Rejection::TimeStepBack => r::TIME_STEP_BACK,
        }
    }

    /// A short reason for logs and summaries.
    pub const fn reason(self) -> &'static str {
        fusion_shared::snapshot::rejection::name(self.code())
    }
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.reason())
    }
}

/// Value limits of the payload checks (the `[validation]` config table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest accepted magnitude of an IMU's acceleration or specific force, m/s².
    pub accel_range_mps2: f64,
    /// Largest accepted magnitude of an IMU's angular rate, rad/s.
    pub gyro_range_radps: f64,
}

/// Input validation settings (`[validation]`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ValidationConfig {
    /// Largest accepted lead of a sample timestamp over the daemon's clock, ns.
    pub max_future_ns: u64,
    /// Largest accepted lag of a sample timestamp behind the daemon's clock, ns.
    pub max_past_ns: u64,
    /// Replay: largest accepted lead of a sample timestamp over the newest one
    /// processed, ns.
    pub max_jump_ns: u64,
    /// Distinct sensor ids tracked per kind (at most [`MAX_SENSORS`] in all).
    pub max_sensors: usize,
    /// Largest sustained sample rate of one sensor, Hz (on sample timestamps).
    pub max_rate_hz: f64,
    /// Samples one sensor may send at once beyond `max_rate_hz`.
    pub max_burst: u32,
    /// Largest accepted magnitude of an IMU's acceleration or specific force, m/s².
    pub accel_range_mps2: f64,
    /// Largest accepted magnitude of an IMU's angular rate, rad/s.
    pub gyro_range_radps: f64,
}

impl Default for ValidationConfig {
    fn default() -> Self {
        Self {
            max_future_ns: 50_000_000,
            max_past_ns: 5_000_000_000,
            max_jump_ns: fusion_shared::time::DEFAULT_MAX_JUMP_NS,
            max_sensors: 8,
            max_rate_hz: 10_000.0,
            max_burst: 100,
            accel_range_mps2: 160.0,
            gyro_range_radps: 35.0,
        }
    }
}

impl ValidationConfig {
    /// The value limits of the payload checks.
    pub fn limits(&self) -> Limits {
        Limits { accel_range_mps2: self.accel_range_mps2, gyro_range_radps: self.gyro_range_radps }
    }

    /// Checks the values: ranges and rates > 0, at least one sensor per kind and
    /// at most a snapshot's rows, a burst of at least 1, a past window > 0.
    pub fn check(&self) -> Result<(), ConfigError> {
        positive("validation.accel_range_mps2", self.accel_range_mps2)?;
        positive("validation.gyro_range_radps", self.gyro_range_radps)?;
        positive("validation.max_rate_hz", self.max_rate_hz)?;
        if !(1..=MAX_SENSORS).contains(&self.max_sensors) {
            return Err(invalid(
                "validation.max_sensors",
                format!("must be in 1..={MAX_SENSORS} (the sensor rows of a snapshot), got {}", self.max_sensors),
            ));
        }
        if self.max_burst == 0 {
            return Err(invalid("validation.max_burst", "must be at least 1"));
        }
        if self.max_past_ns == 0 {
            return Err(invalid("validation.max_past_ns", "must be > 0"));
        }
        Ok(())
    }
}
