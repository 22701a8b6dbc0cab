//! Publishing samples from C: one `fusion_publish_<kind>` per sample kind, each
//! checking its pointers, the publisher's kind and that every value is finite.

use fusion_shared::{
    AttitudeSample, BarometerSample, GeodeticSample, HeadingSample, ImuSample, MagnetometerSample, OdometrySample,
    PoseSample, PositionSample, TwistSample, VelocitySample, WireSample,
};

use super::{Failure, FusionPublisher, FusionStatus, guard, null};
use crate::SamplePublisher;

/// The words (8 bytes each, after the header) of a payload that hold integers
/// rather than an `f64`: geodetic's fix type and satellites, pose's reset
/// counter. Every other word is an `f64` (checked in the tests).
pub(super) fn integer_words(kind: fusion_shared::SampleKind) -> &'static [usize] {
    use fusion_shared::SampleHeader;
    use std::mem::{offset_of, size_of};
    const GEODETIC: [usize; 1] = [(offset_of!(GeodeticSample, fix_type) - size_of::<SampleHeader>()) / 8];
    const POSE: [usize; 1] = [(offset_of!(PoseSample, reset_counter) - size_of::<SampleHeader>()) / 8];
    match kind {
        fusion_shared::SampleKind::Geodetic => &GEODETIC,
        fusion_shared::SampleKind::Pose => &POSE,
        _ => &[],
    }
}

/// Every `f64` of the payload of `sample` (the words after the header that
/// [`integer_words`] does not name) is finite.
pub(super) fn payload_is_finite<T: WireSample>(sample: &T) -> bool {
    let header = std::mem::size_of::<fusion_shared::SampleHeader>();
    let values = (std::mem::size_of::<T>() - header) / 8;
    let base = (sample as *const T).cast::<u8>();
    let integers = integer_words(T::KIND);
    (0..values).filter(|i| !integers.contains(i)).all(|i| {
        // SAFETY: within `sample`, which is `#[repr(C)]` with its f64 fields
        // right after the header (8-byte aligned); read unaligned all the same.
        let v = unsafe { base.add(header + 8 * i).cast::<f64>().read_unaligned() };
        v.is_finite()
    })
}

/// Why the integers of `sample` are out of their range, if they are.
pub(super) fn integers_out_of_range<T: WireSample>(sample: &T) -> Option<String> {
    use fusion_shared::{Sample, fix};
    match sample.into_sample() {
        Sample::Geodetic(g) if g.fix_type as usize >= fix::COUNT => Some(format!(
            "geodetic sample with fix type {}, which is no fix type code (0 to {})",
            g.fix_type,
            fix::COUNT - 1
        )),
        Sample::Geodetic(g) if !(0..=fix::MAX_SATELLITES).contains(&g.satellites) => Some(format!(
            "geodetic sample with {} satellites (0 to {}; 0: not reported)",
            g.satellites,
            fix::MAX_SATELLITES
        )),
        _ => None,
    }
}

/// Publishes `sample` as this publisher's next: the header's `t_ns` is the
/// caller's; sensor id, sequence number, kind and send time are stamped.
///
/// # Safety
/// Pointers null or valid.
unsafe fn publish<T: WireSample>(
    publisher: *mut FusionPublisher,
    sample: *const T,
    reached: *mut usize,
) -> FusionStatus {
    guard(|| {
        // SAFETY: null or a live publisher / a sample, by the caller's contract.
        let p = unsafe { publisher.as_mut() }.ok_or_else(|| null("publisher"))?;
        let sample = *unsafe { sample.as_ref() }.ok_or_else(|| null("sample"))?;
        let kind = p.kind;
        let typed = p.publisher.downcast_mut::<SamplePublisher<T>>().ok_or_else(|| {
            let name = fusion_shared::SampleKind::from_code(kind).map_or("unknown", |k| k.name());
            Failure(
                FusionStatus::FusionErrorWrongKind,
                format!("a {} sample given to a {name} publisher", T::KIND.name()),
            )
        })?;
        if !payload_is_finite(&sample) {
            return Err(Failure(
                FusionStatus::FusionErrorInvalidArgument,
                format!("{} sample with a NaN or infinite value", T::KIND.name()),
            ));
        }
        if let Some(why) = integers_out_of_range(&sample) {
            return Err(Failure(FusionStatus::FusionErrorInvalidArgument, why));
        }
        let n = typed.publish_next(sample)?;
        // SAFETY: null or writable, by the caller's contract.
        if let Some(r) = unsafe { reached.as_mut() } {
            *r = n;
        }
        Ok(FusionStatus::FusionOk)
    })
}

/// Publishes an IMU sample (see the type for what `accel_mps2` is per model).
/// `*reached` (if not NULL) is the number of readers it reached: 0 when no
/// fusiond runs.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid; `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_imu(
    publisher: *mut FusionPublisher,
    sample: *const ImuSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a position fix (m ENU, covariance m² row-major).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_position(
    publisher: *mut FusionPublisher,
    sample: *const PositionSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a velocity (m/s ENU, covariance m²/s² row-major).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_velocity(
    publisher: *mut FusionPublisher,
    sample: *const VelocitySample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a geodetic GNSS fix (WGS-84 degrees, height m; ENU covariance m²).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_geodetic(
    publisher: *mut FusionPublisher,
    sample: *const GeodeticSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a wheel-odometry forward speed (m/s, variance m²/s²).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_odometry(
    publisher: *mut FusionPublisher,
    sample: *const OdometrySample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a heading (yaw rad ENU, variance rad²).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_heading(
    publisher: *mut FusionPublisher,
    sample: *const HeadingSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a magnetometer's field (µT in the sensor's axes, covariance µT²).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_magnetometer(
    publisher: *mut FusionPublisher,
    sample: *const MagnetometerSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a twist (linear m/s and angular rad/s velocity in the sensor's
/// axes, row-major 6×6 covariance).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_twist(
    publisher: *mut FusionPublisher,
    sample: *const TwistSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a barometer's static pressure (Pa, variance Pa²).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_barometer(
    publisher: *mut FusionPublisher,
    sample: *const BarometerSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes a pose in the localiser's map frame (position m, unit quaternion
/// `[w, x, y, z]` of the sensor's axes into the map, row-major 6×6 covariance,
/// reset counter).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_pose(
    publisher: *mut FusionPublisher,
    sample: *const PoseSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}

/// Publishes an AHRS's orientation (unit quaternion `[w, x, y, z]` of the
/// sensor's axes into the world frame, ENU; row-major 3×3 covariance, rad²,
/// about the sensor's axes).
///
/// # Safety
/// As [`fusion_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish_attitude(
    publisher: *mut FusionPublisher,
    sample: *const AttitudeSample,
    reached: *mut usize,
) -> FusionStatus {
    // SAFETY: forwarded contract.
    unsafe { publish(publisher, sample, reached) }
}
