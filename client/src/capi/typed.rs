//! The estimate of a snapshot by name, for C: the Rust client's typed accessors
//! (`StateSnapshot::position`, ...), which know each model's layout. Each
//! function writes its values to `out` and returns [`FusionStatus::FusionOk`],
//! or [`FusionStatus::FusionNotInModel`] when the snapshot's model has no such
//! quantity. Units, frames and conventions are those of the Rust accessors.
//! The functions are written out one by one: cbindgen does not expand macros.

use fusion_shared::StateSnapshot;

use super::{FusionStatus, guard, null};

/// Writes what `read` gives of `*snapshot` to `out[0..N]`.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for `N` doubles.
unsafe fn write<const N: usize>(
    snapshot: *const StateSnapshot,
    out: *mut f64,
    read: fn(&StateSnapshot) -> Option<[f64; N]>,
) -> FusionStatus {
    guard(|| {
        // SAFETY: null or readable, by the caller's contract.
        let s = unsafe { snapshot.as_ref() }.ok_or_else(|| null("snapshot"))?;
        if out.is_null() {
            return Err(null("out"));
        }
        Ok(match read(s) {
            Some(values) => {
                // SAFETY: `out` not null, with room for N doubles by the contract.
                unsafe { std::ptr::copy_nonoverlapping(values.as_ptr(), out, N) };
                FusionStatus::FusionOk
            }
            None => FusionStatus::FusionNotInModel,
        })
    })
}

/// Position, m, world frame (ENU about the datum), into `out[0..3]`; every model.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_position(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::position) }
}

/// Velocity, m/s, world frame (ENU), into `out[0..3]`; every model.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_velocity(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::velocity) }
}

/// Attitude, the unit quaternion `[w, x, y, z]` rotating the body frame
/// (forward-left-up) into the world frame (ENU), into `out[0..4]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 4 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_attitude(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::attitude) }
}

/// Roll, pitch and yaw, rad, into `out[0..3]`; ins only. Body → world is
/// `Rz(yaw) Ry(pitch) Rx(roll)` (ZYX on ENU and forward-left-up axes); yaw is the
/// forward axis's angle from east, counter-clockwise (compass heading = 90° − yaw).
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_roll_pitch_yaw(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::roll_pitch_yaw) }
}

/// Accelerometer bias, m/s², body frame, into `out[0..3]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_accel_bias(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::accel_bias) }
}

/// Gyroscope bias, rad/s, body frame, into `out[0..3]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_gyro_bias(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::gyro_bias) }
}

/// Standard deviation of each position component, m, into `out[0..3]`.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_position_std(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::position_std) }
}

/// Standard deviation of each velocity component, m/s, into `out[0..3]`.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_velocity_std(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::velocity_std) }
}

/// Standard deviation of the attitude error about each body axis (forward,
/// left, up), rad, into `out[0..3]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_attitude_std(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::attitude_std) }
}

/// Standard deviation of roll, pitch and yaw, rad, into `out[0..3]`; ins only:
/// the attitude error covariance through the Euler-angle rates (infinite at
/// pitch ±90°).
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_roll_pitch_yaw_std(
    snapshot: *const StateSnapshot,
    out: *mut f64,
) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::roll_pitch_yaw_std) }
}

/// Standard deviation of each accelerometer bias component, m/s², into
/// `out[0..3]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_accel_bias_std(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::accel_bias_std) }
}

/// Standard deviation of each gyroscope bias component, rad/s, into
/// `out[0..3]`; ins only.
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 3 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_gyro_bias_std(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::gyro_bias_std) }
}

/// The odometry scale factor `k` (odometry speed = `k` × true speed) and its
/// standard deviation, into `out[0..2]`; ins with `[model.odometry_scale]`
/// only (`aux_states` has [`FUSION_AUX_ODOMETRY_SCALE`](super::FUSION_AUX_ODOMETRY_SCALE)).
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 2 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_odometry_scale(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, |s| Some([s.odometry_scale()?, s.odometry_scale_std()?])) }
}

/// The barometer's bias (pressure altitude minus height, m) and its standard
/// deviation, into `out[0..2]`; ins with a barometer only (`aux_states` has
/// [`FUSION_AUX_BARO_BIAS`](super::FUSION_AUX_BARO_BIAS)).
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 2 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_baro_bias(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::baro_bias) }
}

/// A pose sensor's estimated map frame, into `out[0..8]`: yaw (rad), origin
/// east, north, up (m), then their standard deviations; ins with a pose sensor
/// whose frame is estimated only (`aux_states` has
/// [`FUSION_AUX_POSE_FRAME`](super::FUSION_AUX_POSE_FRAME)).
///
/// # Safety
/// `snapshot` is null or readable; `out` is null or has room for 8 doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_snapshot_pose_frame(snapshot: *const StateSnapshot, out: *mut f64) -> FusionStatus {
    unsafe { write(snapshot, out, StateSnapshot::pose_frame) }
}
