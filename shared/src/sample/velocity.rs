//! The velocity measurement (GNSS Doppler velocity).

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// One velocity measurement in the world frame with its covariance, as a GNSS
/// receiver derives it from Doppler shifts (for example u-blox `NAV-PVT`
/// `velN/velE/velD` with `sAcc`, turned into ENU).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "VelocityLine", into = "VelocityLine"))]
#[type_name("fusion.VelocitySample.v2")]
#[repr(C)]
pub struct VelocitySample {
    /// Time, sensor, sequence number, kind [`SampleKind::Velocity`].
    pub header: SampleHeader,
    /// Velocity, m/s, world frame ENU.
    pub vel_mps: [f64; 3],
    /// Covariance of `vel_mps`, m²/s², row-major 3×3; must be symmetric positive definite.
    pub cov_m2ps2: [f64; 9],
}

impl VelocitySample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 3;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A measurement of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, vel_mps: [f64; 3], cov_m2ps2: [f64; 9]) -> Self {
        Self { header: SampleHeader::new(SampleKind::Velocity, t_ns, sensor, seq), vel_mps, cov_m2ps2 }
    }
}

impl Default for VelocitySample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [0.0; 9])
    }
}

#[cfg(feature = "json")]
super::json_form!(VelocitySample, VelocityLine {
    /// m/s, ENU.
    vel: [f64; 3] => vel_mps,
    /// m²/s², row-major.
    cov: [f64; 9] => cov_m2ps2,
});

const _: () = {
    assert!(core::mem::size_of::<VelocitySample>() == 128);
    assert!(core::mem::align_of::<VelocitySample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for VelocitySample {
    type Progress = ();
}

crate::wire_layout!(VelocitySample, "A velocity, m/s ENU, with its covariance (m²/s², row-major 3×3).", { header, vel_mps, cov_m2ps2 });

/// Not read from ROS messages.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for VelocitySample {}
