//! Why fusiond refused a sample in validation: the codes of
//! [`StateSnapshot::rejections`](super::StateSnapshot::rejections) (the index of
//! its count) and of [`SensorCounters::last_rejection`](super::SensorCounters::last_rejection),
//! with a name and the setting that decides each (for C: `FUSION_REJECTION_*`,
//! `fusion_rejection_name`, `fusion_rejection_setting`; Python: `REJECTION_*`).
//!
//! Codes start at 1 and are never reused; entry 0 of the counts is unused.

/// A NaN or ±∞ in a value.
pub const NON_FINITE: u32 = 1;
/// The covariance differs from its transpose beyond rounding.
pub const COVARIANCE_NOT_SYMMETRIC: u32 = 2;
/// The covariance has no Cholesky factor (not positive definite).
pub const COVARIANCE_NOT_POSITIVE_DEFINITE: u32 = 3;
/// The timestamp lies further ahead of fusiond's clock than `[validation] max_future_ns`.
pub const FUTURE_TIMESTAMP: u32 = 4;
/// The timestamp lies further behind fusiond's clock than `[validation]
/// max_past_ns`: a publisher stamping on another clock (a recording's, an unset
/// one) than fusiond's CLOCK_MONOTONIC.
pub const PAST_TIMESTAMP: u32 = 5;
/// Without a clock (replay): the timestamp jumps further ahead of everything
/// processed than `[validation] max_jump_ns`.
pub const TIME_JUMP: u32 = 6;
/// More distinct sensor ids of the kind than `[validation] max_sensors`, or more
/// sensors in all than a snapshot has rows for.
pub const TOO_MANY_SENSORS: u32 = 7;
/// A value beyond what the sensor can report (an IMU beyond `[validation]
/// accel_range_mps2` or `gyro_range_radps`, a latitude beyond ±90°, ...).
pub const OUT_OF_RANGE: u32 = 8;
/// A variance that is not > 0 (or is absurdly large).
pub const VARIANCE_NOT_POSITIVE: u32 = 9;
/// The header's kind code is not the kind of the service the sample came on.
pub const WRONG_KIND: u32 = 10;
/// Without a clock (replay): the timestamp steps further back behind everything
/// processed than `[validation] max_jump_ns` (a recording's clock set back, or
/// a sensor stamping on another clock than the others).
pub const TIME_STEP_BACK: u32 = 11;

/// Codes in use: `1..=COUNT`.
pub const COUNT: usize = 11;
/// Entries of [`StateSnapshot::rejections`](super::StateSnapshot::rejections)
/// (room for codes to come; entry 0 is unused).
pub const MAX: usize = super::MAX_REJECTIONS;

const _: () = assert!(COUNT < MAX);

/// Every code with its name, in code order.
pub const ALL: [(u32, &str); COUNT] = [
    (NON_FINITE, "non-finite value"),
    (COVARIANCE_NOT_SYMMETRIC, "covariance not symmetric"),
    (COVARIANCE_NOT_POSITIVE_DEFINITE, "covariance not positive definite"),
    (FUTURE_TIMESTAMP, "timestamp in the future"),
    (PAST_TIMESTAMP, "timestamp too far in the past"),
    (TIME_JUMP, "timestamp jumps too far ahead of the others"),
    (TOO_MANY_SENSORS, "too many sensors"),
    (OUT_OF_RANGE, "beyond the sensor range"),
    (VARIANCE_NOT_POSITIVE, "variance not positive"),
    (WRONG_KIND, "header kind does not match the payload"),
    (TIME_STEP_BACK, "timestamp steps too far back behind the others"),
];

/// Every code under its constant's name (without a prefix), in code order:
/// the C and Python mirrors' `REJECTION_<NAME>`.
pub const CONSTANTS: [(&str, u32); COUNT] = [
    ("NON_FINITE", NON_FINITE),
    ("COVARIANCE_NOT_SYMMETRIC", COVARIANCE_NOT_SYMMETRIC),
    ("COVARIANCE_NOT_POSITIVE_DEFINITE", COVARIANCE_NOT_POSITIVE_DEFINITE),
    ("FUTURE_TIMESTAMP", FUTURE_TIMESTAMP),
    ("PAST_TIMESTAMP", PAST_TIMESTAMP),
    ("TIME_JUMP", TIME_JUMP),
    ("TOO_MANY_SENSORS", TOO_MANY_SENSORS),
    ("OUT_OF_RANGE", OUT_OF_RANGE),
    ("VARIANCE_NOT_POSITIVE", VARIANCE_NOT_POSITIVE),
    ("WRONG_KIND", WRONG_KIND),
    ("TIME_STEP_BACK", TIME_STEP_BACK),
];

/// The name of a code ("unknown" for none).
pub const fn name(code: u32) -> &'static str {
    if code >= 1 && code as usize <= COUNT { ALL[code as usize - 1].1 } else { "unknown" }
}

/// The configuration setting that decides a refusal of this code, when one
/// does (the others are the publisher's to fix).
pub const fn setting(code: u32) -> Option<&'static str> {
    match code {
        FUTURE_TIMESTAMP => Some("[validation] max_future_ns"),
        PAST_TIMESTAMP => Some("[validation] max_past_ns"),
        TIME_JUMP | TIME_STEP_BACK => Some("[validation] max_jump_ns"),
        TOO_MANY_SENSORS => Some("[validation] max_sensors"),
        OUT_OF_RANGE => Some("[validation] accel_range_mps2 and gyro_range_radps (IMU)"),
        _ => None,
    }
}

/// What a user can do about refusals of this code: the setting to change (and
/// when), or what to fix in the publisher.
pub const fn advice(code: u32) -> &'static str {
    match code {
        PAST_TIMESTAMP => {
            "the publisher stamps on another clock than fusiond's CLOCK_MONOTONIC (a recording's, an unset one): \
             stamp with CLOCK_MONOTONIC, raise [validation] max_past_ns, or run `fusiond replay` on a recording"
        }
        FUTURE_TIMESTAMP => {
            "the publisher's clock runs ahead of fusiond's CLOCK_MONOTONIC: stamp with CLOCK_MONOTONIC or raise \
             [validation] max_future_ns"
        }
        TIME_JUMP => {
            "the timestamps jump ahead of the other sensors': check the clock, or raise [validation] max_jump_ns"
        }
        TIME_STEP_BACK => {
            "the timestamps step back behind the other sensors': a sensor stamping on another clock, or the \
             recording's clock set back (a run of such stamps starts a new timeline); check the clock, or raise \
             [validation] max_jump_ns"
        }
        TOO_MANY_SENSORS => {
            "more sensor ids than the table has rows: check the publishers' sensor ids, or raise [validation] \
             max_sensors"
        }
        OUT_OF_RANGE => {
            "a value beyond what the sensor can report (corrupted, or an IMU beyond [validation] accel_range_mps2 / \
             gyro_range_radps)"
        }
        WRONG_KIND => "the publisher writes another wire layout (a different fusion-client version?) or garbage",
        _ => "the publisher sends values no sensor measures: fix the driver",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_their_index_and_named() {
        for (i, (code, name)) in ALL.iter().enumerate() {
            assert_eq!(*code as usize, i + 1);
            assert_eq!(super::name(*code), *name);
        }
        assert_eq!(name(0), "unknown");
        assert_eq!(name(COUNT as u32 + 1), "unknown");
        assert_eq!(setting(PAST_TIMESTAMP), Some("[validation] max_past_ns"));
        assert!(advice(PAST_TIMESTAMP).contains("max_past_ns"));
    }
}
