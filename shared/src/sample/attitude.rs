//! Attitude: the orientation an AHRS (an IMU with its own attitude filter:
//! Microstrain, Xsens, VectorNav, BNO055) reports.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The orientation of the sensor's axes in the world frame (ENU, REP-103), as an
/// AHRS reports it (a ROS `sensor_msgs/Imu` `orientation` with its
/// `orientation_covariance`), with the 3×3 covariance of its error about the
/// sensor's own axes. Its mounting on the body is configuration (`[[sensor]]
/// axes`, `rotation_rpy_deg`); `[sensor.attitude] yaw = false` fuses roll and
/// pitch only (a magnetic yaw indoors).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "AttitudeLine", into = "AttitudeLine"))]
#[type_name("fusion.AttitudeSample.v1")]
#[repr(C)]
pub struct AttitudeSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Attitude`].
    pub header: SampleHeader,
    /// Rotation of the sensor's axes into the world frame, `[w, x, y, z]`; unit
    /// norm (within 10⁻³).
    pub orientation_wxyz: [f64; 4],
    /// Covariance of the attitude error, rad², row-major 3×3: a small rotation
    /// about the sensor's own axes (`q_true = q ⊗ Exp(δθ)`); symmetric positive
    /// definite.
    pub cov_rad2: [f64; 9],
}

impl AttitudeSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS (2 for a sensor whose yaw is not fused).
    pub const INNOVATION_DIM: usize = 3;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// An orientation (`[w, x, y, z]`, sensor axes into ENU) of sensor `sensor`
    /// with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, orientation_wxyz: [f64; 4], cov_rad2: [f64; 9]) -> Self {
        Self { header: SampleHeader::new(SampleKind::Attitude, t_ns, sensor, seq), orientation_wxyz, cov_rad2 }
    }

    /// A sample with the same standard deviation `std_rad` about each axis.
    pub fn with_std(t_ns: u64, sensor: u32, seq: u64, orientation_wxyz: [f64; 4], std_rad: f64) -> Self {
        let v = std_rad * std_rad;
        Self::new(t_ns, sensor, seq, orientation_wxyz, [v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v])
    }
}

impl Default for AttitudeSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [1.0, 0.0, 0.0, 0.0], [0.0; 9])
    }
}

#[cfg(feature = "json")]
super::json_form!(AttitudeSample, AttitudeLine {
    /// `[w, x, y, z]`, sensor axes into ENU.
    orientation: [f64; 4] => orientation_wxyz,
    /// rad², row-major 3×3, about the sensor's axes.
    cov: [f64; 9] => cov_rad2,
});

const _: () = {
    assert!(core::mem::size_of::<AttitudeSample>() == 136);
    assert!(core::mem::align_of::<AttitudeSample>() == 8);
};

#[cfg(all(test, feature = "json"))]
mod tests {
    use super::*;
    use crate::Sample;
    use crate::jsonl::{format_sample, parse_sample};

    #[test]
    fn json_lines_carry_the_orientation_and_its_covariance() {
        let s = Sample::Attitude(AttitudeSample::with_std(5, 3, 9, [0.6, 0.0, 0.0, 0.8], 0.01));
        let line = format_sample(&s);
        assert!(
            line.starts_with("{\"attitude\":{\"t_ns\":5,\"sensor\":3,\"seq\":9,\"orientation\":[0.6,0.0,0.0,0.8]"),
            "{line}"
        );
        assert_eq!(parse_sample(&line).unwrap(), s);
    }
}

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for AttitudeSample {
    type Progress = ();
}

crate::wire_layout!(AttitudeSample, "An AHRS's orientation: unit quaternion `[w, x, y, z]` of the sensor's axes into the world frame (ENU), with the covariance of its error about the sensor's axes (rad², row-major 3×3).", { header, orientation_wxyz, cov_rad2 });

/// A `sensor_msgs/Imu`'s orientation, its covariance taken from the world's axes to the sensor's (REP-145).
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for AttitudeSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] = &[crate::ros_msgs::MessageType::Imu];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs::{self as ros, Message};
        let Message::Imu(imu) = m else { return Err(ros::not_read("attitude")) };
        let t = imu.header.t_ns()?;
        if ros::not_given(&imu.orientation_covariance) {
            return Err("orientation not given (orientation_covariance[0] = -1)".into());
        }
        if ros::unknown(&imu.orientation_covariance) {
            return Err("orientation covariance unknown (all zero)".into());
        }
        let cov = ros::to_sensor_axes(&imu.orientation.matrix(), &imu.orientation_covariance);
        Ok(AttitudeSample::new(t, sensor, seq, imu.orientation.wxyz(), cov))
    }
}
