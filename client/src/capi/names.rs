//! Names of the codes in a snapshot, for C: static, NUL-terminated strings.

use std::ffi::{CStr, c_char};

use super::{
    FUSION_HEALTH_DEGRADED, FUSION_HEALTH_INITIALISING, FUSION_HEALTH_OK,
    FUSION_REJECTION_COVARIANCE_NOT_POSITIVE_DEFINITE, FUSION_REJECTION_COVARIANCE_NOT_SYMMETRIC,
    FUSION_REJECTION_FUTURE_TIMESTAMP, FUSION_REJECTION_NON_FINITE, FUSION_REJECTION_OUT_OF_RANGE,
    FUSION_REJECTION_PAST_TIMESTAMP, FUSION_REJECTION_TIME_JUMP, FUSION_REJECTION_TIME_STEP_BACK,
    FUSION_REJECTION_TOO_MANY_SENSORS, FUSION_REJECTION_VARIANCE_NOT_POSITIVE, FUSION_REJECTION_WRONG_KIND,
};

/// The name of a `FusionStateSnapshot.health` value ("ok", "degraded", ...), a
/// static string.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_health_name(health: u32) -> *const c_char {
    match health {
        FUSION_HEALTH_INITIALISING => c"initialising".as_ptr(),
        FUSION_HEALTH_OK => c"ok".as_ptr(),
        FUSION_HEALTH_DEGRADED => c"degraded".as_ptr(),
        _ => c"unknown".as_ptr(),
    }
}

/// The name of a rejection code (`FUSION_REJECTION_*`: an index of
/// `FusionStateSnapshot.rejections`), a static string; "unknown" for none.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_rejection_name(code: u32) -> *const c_char {
    rejection_text(code).0.as_ptr()
}

/// The configuration setting that decides refusals of a rejection code (for
/// `FUSION_REJECTION_PAST_TIMESTAMP`: `"[validation] max_past_ns"`), a static
/// string; NULL when none does (the publisher's values are to fix).
#[unsafe(no_mangle)]
pub extern "C" fn fusion_rejection_setting(code: u32) -> *const c_char {
    rejection_text(code).1.map_or(std::ptr::null(), CStr::as_ptr)
}

/// The C strings of [`fusion_shared::snapshot::rejection::name`] and
/// [`setting`](fusion_shared::snapshot::rejection::setting) (compared in a test).
const fn rejection_text(code: u32) -> (&'static CStr, Option<&'static CStr>) {
    match code {
        FUSION_REJECTION_NON_FINITE => (c"non-finite value", None),
        FUSION_REJECTION_COVARIANCE_NOT_SYMMETRIC => (c"covariance not symmetric", None),
        FUSION_REJECTION_COVARIANCE_NOT_POSITIVE_DEFINITE => (c"covariance not positive definite", None),
        FUSION_REJECTION_FUTURE_TIMESTAMP => (c"timestamp in the future", Some(c"[validation] max_future_ns")),
        FUSION_REJECTION_PAST_TIMESTAMP => (c"timestamp too far in the past", Some(c"[validation] max_past_ns")),
        FUSION_REJECTION_TIME_JUMP => {
            (c"timestamp jumps too far ahead of the others", Some(c"[validation] max_jump_ns"))
        }
        FUSION_REJECTION_TOO_MANY_SENSORS => (c"too many sensors", Some(c"[validation] max_sensors")),
        FUSION_REJECTION_OUT_OF_RANGE => {
            (c"beyond the sensor range", Some(c"[validation] accel_range_mps2 and gyro_range_radps (IMU)"))
        }
        FUSION_REJECTION_VARIANCE_NOT_POSITIVE => (c"variance not positive", None),
        FUSION_REJECTION_WRONG_KIND => (c"header kind does not match the payload", None),
        FUSION_REJECTION_TIME_STEP_BACK => {
            (c"timestamp steps too far back behind the others", Some(c"[validation] max_jump_ns"))
        }
        _ => (c"unknown", None),
    }
}
