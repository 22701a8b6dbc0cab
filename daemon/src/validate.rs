//! Input validation: every sample is checked before it can reach the filter.
//!
//! A rejected sample is counted with its [`Rejection`] reason; it never changes the
//! estimate. The same checks run live and in replay. Each kind's checks live in its
//! measurement module; this file names the reasons and the limits they use.

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
}

impl Rejection {
    /// A short reason for logs and summaries.
    pub const fn reason(self) -> &'static str {
        match self {
            Rejection::NonFinite => "non-finite value",
            Rejection::CovarianceNotSymmetric => "covariance not symmetric",
            Rejection::CovarianceNotPositiveDefinite => "covariance not positive definite",
            Rejection::FutureTimestamp => "timestamp in the future",
            Rejection::PastTimestamp => "timestamp too far in the past",
            Rejection::TimeJump => "timestamp jumps too far ahead of the others",
            Rejection::TooManySensors => "too many sensors",
            Rejection::OutOfRange => "beyond the sensor range",
            Rejection::VarianceNotPositive => "variance not positive",
            Rejection::WrongKind => "header kind does not match the payload",
        }
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
