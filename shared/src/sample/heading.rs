//! Heading: the vehicle's yaw angle.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The yaw of the body frame in the world frame, as a dual-antenna GNSS receiver
/// or a tilt-compensated magnetometer (declination applied) gives it, with its
/// variance. Yaw is the ENU convention (REP-103): the angle of the body's forward
/// axis from east, counter-clockwise, in radians; any value is taken modulo 2π.
/// A compass heading (from north, clockwise) converts with
/// [`HeadingSample::from_compass`].
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "HeadingLine", into = "HeadingLine"))]
#[type_name("fusion.HeadingSample.v2")]
#[repr(C)]
pub struct HeadingSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Heading`].
    pub header: SampleHeader,
    /// Yaw, rad, ENU (from east, counter-clockwise); |yaw| ≤ 1000 (a wrapped angle
    /// or a few turns of an unwrapped one).
    pub yaw_rad: f64,
    /// Variance of `yaw_rad`, rad²; must be > 0.
    pub var_rad2: f64,
}

impl HeadingSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 1;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A yaw (rad, ENU) of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, yaw_rad: f64, var_rad2: f64) -> Self {
        Self { header: SampleHeader::new(SampleKind::Heading, t_ns, sensor, seq), yaw_rad, var_rad2 }
    }

    /// A sample from a compass heading: degrees from north, clockwise (NMEA `HDT`,
    /// u-blox `NAV-RELPOSNED` `relPosHeading`), with its standard deviation in
    /// degrees.
    pub fn from_compass(t_ns: u64, sensor: u32, seq: u64, heading_deg: f64, std_deg: f64) -> Self {
        let yaw = (90.0 - heading_deg).to_radians();
        let sd = std_deg.to_radians();
        Self::new(t_ns, sensor, seq, yaw, sd * sd)
    }
}

impl Default for HeadingSample {
    fn default() -> Self {
        Self::new(0, 0, 0, 0.0, 0.0)
    }
}

#[cfg(feature = "json")]
super::json_form!(HeadingSample, HeadingLine {
    /// rad, ENU yaw.
    yaw: f64 => yaw_rad,
    /// rad².
    var: f64 => var_rad2,
});

const _: () = {
    assert!(core::mem::size_of::<HeadingSample>() == 48);
    assert!(core::mem::align_of::<HeadingSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for HeadingSample {
    type Progress = ();
}

crate::wire_layout!(HeadingSample, "Yaw, rad ENU (from east, counter-clockwise), with its variance.", { header, yaw_rad, var_rad2 });

/// Not read from ROS messages.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for HeadingSample {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_compass_heading_is_yaw_from_east_counter_clockwise() {
        let east = HeadingSample::from_compass(0, 0, 0, 90.0, 1.0);
        assert!(east.yaw_rad.abs() < 1e-15);
        let north = HeadingSample::from_compass(0, 0, 0, 0.0, 1.0);
        assert!((north.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let south_west = HeadingSample::from_compass(0, 0, 0, 225.0, 2.0);
        assert!((south_west.yaw_rad + 135f64.to_radians()).abs() < 1e-15);
        assert!((south_west.var_rad2 - 2f64.to_radians().powi(2)).abs() < 1e-18);
    }
}
