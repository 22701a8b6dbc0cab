//! The C API's sample kinds (each kind's code and its publish function) and
//! models (each model's code in a snapshot).
//!
//! Generated from the kind and model lists by `FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs`:
//! do not edit.

use super::FusionPublisher;
use super::FusionStatus;
use super::publish::publish;

/// An imu sample (`FusionImuSample`): specific force (`ins`) or world acceleration (`linear`), m/s²; angular
/// rate, rad/s. Its code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and
/// `fusion_publish`.
pub const FUSION_KIND_IMU: u32 = 1;
/// A position sample (`FusionPositionSample`): a position fix, m ENU, with its covariance (m², row-major 3×3).
/// Its code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_POSITION: u32 = 2;
/// A velocity sample (`FusionVelocitySample`): a velocity, m/s ENU, with its covariance (m²/s², row-major 3×3).
/// Its code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_VELOCITY: u32 = 3;
/// A geodetic sample (`FusionGeodeticSample`): a GNSS fix: WGS-84 latitude, longitude (deg), ellipsoidal height
/// (m); ENU covariance m²; the receiver's fix type (`FIX_*`), satellites used, HDOP and VDOP (0: not reported).
/// Its code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_GEODETIC: u32 = 4;
/// An odometry sample (`FusionOdometrySample`): forward speed from wheel odometry, m/s, with its variance. Its
/// code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_ODOMETRY: u32 = 5;
/// A heading sample (`FusionHeadingSample`): yaw, rad ENU (from east, counter-clockwise), with its variance. Its
/// code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_HEADING: u32 = 6;
/// A magnetometer sample (`FusionMagnetometerSample`): a magnetometer's field, µT in the sensor's axes
/// (calibrated), with its covariance (µT², row-major 3×3). Its code in `FusionSampleHeader.kind`, and the `kind`
/// of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_MAGNETOMETER: u32 = 7;
/// A twist sample (`FusionTwistSample`): linear (m/s) and angular (rad/s) velocity in the sensor's axes, with
/// their covariance (row-major 6×6, linear then angular): visual or lidar odometry. Its code in
/// `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_TWIST: u32 = 8;
/// A barometer sample (`FusionBarometerSample`): static air pressure, Pa, with its variance (Pa²). Its code in
/// `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_BAROMETER: u32 = 9;
/// A pose sample (`FusionPoseSample`): a localiser's pose in its map frame: position (m), unit quaternion `[w, x,
/// y, z]` of the sensor's axes into the map, covariance (row-major 6×6, position then attitude about the sensor's
/// axes) and the localiser's reset counter. Its code in `FusionSampleHeader.kind`, and the `kind` of
/// `fusion_publisher_new` and `fusion_publish`.
pub const FUSION_KIND_POSE: u32 = 10;
/// An attitude sample (`FusionAttitudeSample`): an AHRS's orientation: unit quaternion `[w, x, y, z]` of the
/// sensor's axes into the world frame (ENU), with the covariance of its error about the sensor's axes (rad²,
/// row-major 3×3). Its code in `FusionSampleHeader.kind`, and the `kind` of `fusion_publisher_new` and
/// `fusion_publish`.
pub const FUSION_KIND_ATTITUDE: u32 = 11;
/// Kind codes in use: `1..=FUSION_KIND_COUNT` (a larger code is no kind).
pub const FUSION_KIND_COUNT: u32 = 11;

/// `FusionStateSnapshot.model`: the `linear` model (6 states, a 6×6 covariance, then the auxiliary states of
/// `aux_states`).
pub const FUSION_MODEL_LINEAR: u32 = 1;
/// `FusionStateSnapshot.model`: the `ins` model (16 states, a 15×15 covariance, then the auxiliary states of
/// `aux_states`).
pub const FUSION_MODEL_INS: u32 = 2;

/// Publishes an imu sample: specific force (`ins`) or world acceleration (`linear`), m/s²; angular rate, rad/s.
/// `*reached` (if not NULL) is the number of readers it reached: 0 when no fusiond runs. The same as
/// `fusion_publish` with `FUSION_KIND_IMU`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_imu(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::ImuSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a position sample: a position fix, m ENU, with its covariance (m², row-major 3×3). `*reached` (if
/// not NULL) is the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_POSITION`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_position(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::PositionSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a velocity sample: a velocity, m/s ENU, with its covariance (m²/s², row-major 3×3). `*reached` (if
/// not NULL) is the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_VELOCITY`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_velocity(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::VelocitySample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a geodetic sample: a GNSS fix: WGS-84 latitude, longitude (deg), ellipsoidal height (m); ENU
/// covariance m²; the receiver's fix type (`FIX_*`), satellites used, HDOP and VDOP (0: not reported). `*reached`
/// (if not NULL) is the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_GEODETIC`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_geodetic(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::GeodeticSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes an odometry sample: forward speed from wheel odometry, m/s, with its variance. `*reached` (if not
/// NULL) is the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_ODOMETRY`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_odometry(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::OdometrySample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a heading sample: yaw, rad ENU (from east, counter-clockwise), with its variance. `*reached` (if not
/// NULL) is the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_HEADING`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_heading(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::HeadingSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a magnetometer sample: a magnetometer's field, µT in the sensor's axes (calibrated), with its
/// covariance (µT², row-major 3×3). `*reached` (if not NULL) is the number of readers it reached: 0 when no
/// fusiond runs. The same as `fusion_publish` with `FUSION_KIND_MAGNETOMETER`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_magnetometer(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::MagnetometerSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a twist sample: linear (m/s) and angular (rad/s) velocity in the sensor's axes, with their
/// covariance (row-major 6×6, linear then angular): visual or lidar odometry. `*reached` (if not NULL) is the
/// number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with `FUSION_KIND_TWIST`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_twist(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::TwistSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a barometer sample: static air pressure, Pa, with its variance (Pa²). `*reached` (if not NULL) is
/// the number of readers it reached: 0 when no fusiond runs. The same as `fusion_publish` with
/// `FUSION_KIND_BAROMETER`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_barometer(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::BarometerSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a pose sample: a localiser's pose in its map frame: position (m), unit quaternion `[w, x, y, z]` of
/// the sensor's axes into the map, covariance (row-major 6×6, position then attitude about the sensor's axes) and
/// the localiser's reset counter. `*reached` (if not NULL) is the number of readers it reached: 0 when no fusiond
/// runs. The same as `fusion_publish` with `FUSION_KIND_POSE`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_pose(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::PoseSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes an attitude sample: an AHRS's orientation: unit quaternion `[w, x, y, z]` of the sensor's axes into
/// the world frame (ENU), with the covariance of its error about the sensor's axes (rad², row-major 3×3).
/// `*reached` (if not NULL) is the number of readers it reached: 0 when no fusiond runs. The same as
/// `fusion_publish` with `FUSION_KIND_ATTITUDE`.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_attitude(
    publisher: *mut FusionPublisher,
    sample: *const fusion_shared::AttitudeSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}
