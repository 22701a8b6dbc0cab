//! The IMU sample.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// One inertial measurement.
///
/// What `accel_mps2` means depends on the model the daemon runs: for `linear` it
/// is the world-frame (ENU) acceleration with gravity removed; for `ins` it is the
/// body-frame specific force `f = Rᵀ (a − g)`. `gyro_radps` is the body-frame
/// angular rate.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "ImuLine", into = "ImuLine"))]
#[type_name("fusion.ImuSample.v2")]
#[repr(C)]
pub struct ImuSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Imu`].
    pub header: SampleHeader,
    /// Acceleration or specific force, m/s² (see the type's docs for the frame).
    pub accel_mps2: [f64; 3],
    /// Angular rate, rad/s, body frame.
    pub gyro_radps: [f64; 3],
}

impl ImuSample {
    /// None: the IMU drives the propagation; it is no measurement update (and has
    /// no NIS).
    pub const INNOVATION_DIM: usize = 0;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A sample of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, accel_mps2: [f64; 3], gyro_radps: [f64; 3]) -> Self {
        Self { header: SampleHeader::new(SampleKind::Imu, t_ns, sensor, seq), accel_mps2, gyro_radps }
    }
}

impl Default for ImuSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [0.0; 3])
    }
}

#[cfg(feature = "json")]
super::json_form!(ImuSample, ImuLine {
    /// m/s².
    accel: [f64; 3] => accel_mps2,
    /// rad/s.
    gyro: [f64; 3] => gyro_radps,
});

const _: () = {
    assert!(core::mem::size_of::<ImuSample>() == 80);
    assert!(core::mem::align_of::<ImuSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for ImuSample {
    type Progress = ();
}

crate::wire_layout!(ImuSample, "Specific force (`ins`) or world acceleration (`linear`), m/s²; angular rate, rad/s.", { header, accel_mps2, gyro_radps });

/// A `sensor_msgs/Imu`'s specific force and angular rate (REP-145: `-1` in a covariance: not given).
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for ImuSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] = &[crate::ros_msgs::MessageType::Imu];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs::{self as ros, Message};
        let Message::Imu(imu) = m else { return Err(ros::not_read("imu")) };
        let t = imu.header.t_ns()?;
        if ros::not_given(&imu.angular_velocity_covariance) || ros::not_given(&imu.linear_acceleration_covariance) {
            return Err("angular velocity or acceleration not given (covariance[0] = -1)".into());
        }
        let (f, w) = (imu.linear_acceleration.array(), imu.angular_velocity.array());
        Ok(ImuSample::new(t, sensor, seq, f, w))
    }
}
