//! Wheel odometry: the vehicle's forward speed.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The forward speed of the vehicle at the odometry's reference point (for
/// example the middle of the rear axle, whose position in the body frame is the
/// sensor's configured lever arm), along the body's forward axis, as wheel
/// encoders or a CAN speed signal give it, with its variance. A signed speed:
/// negative when reversing. The sideways and vertical body velocity are not
/// measured (the `ins` model's motion constraint covers them).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "OdometryLine", into = "OdometryLine"))]
#[type_name("fusion.OdometrySample.v2")]
#[repr(C)]
pub struct OdometrySample {
    /// Time, sensor, sequence number, kind [`SampleKind::Odometry`].
    pub header: SampleHeader,
    /// Forward speed, m/s, body frame (negative: reversing).
    pub speed_mps: f64,
    /// Variance of `speed_mps`, m²/s²; must be > 0.
    pub var_m2ps2: f64,
}

impl OdometrySample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 1;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A speed of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, speed_mps: f64, var_m2ps2: f64) -> Self {
        Self { header: SampleHeader::new(SampleKind::Odometry, t_ns, sensor, seq), speed_mps, var_m2ps2 }
    }
}

impl Default for OdometrySample {
    fn default() -> Self {
        Self::new(0, 0, 0, 0.0, 0.0)
    }
}

#[cfg(feature = "json")]
super::json_form!(OdometrySample, OdometryLine {
    /// m/s, forward.
    speed: f64 => speed_mps,
    /// m²/s².
    var: f64 => var_m2ps2,
});

const _: () = {
    assert!(core::mem::size_of::<OdometrySample>() == 48);
    assert!(core::mem::align_of::<OdometrySample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for OdometrySample {
    type Progress = ();
}

crate::wire_layout!(OdometrySample, "Forward speed from wheel odometry, m/s, with its variance.", { header, speed_mps, var_m2ps2 });

/// The forward speed (`linear.x`) of a twist, an odometry's or a stamped one, with its variance.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for OdometrySample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] =
        &[crate::ros_msgs::MessageType::Odometry, crate::ros_msgs::MessageType::TwistWithCovarianceStamped];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs as ros;
        let Some(twist) = m.twist() else { return Err(ros::not_read("odometry")) };
        let t = m.t_ns()?;
        Ok(OdometrySample::new(t, sensor, seq, twist.twist.linear.x, twist.covariance[0][0]))
    }
}
