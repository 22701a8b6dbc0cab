//! The position fix.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// One position fix with its covariance.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "PositionLine", into = "PositionLine"))]
#[type_name("fusion.PositionSample.v2")]
#[repr(C)]
pub struct PositionSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Position`].
    pub header: SampleHeader,
    /// Position, m, world frame ENU.
    pub pos_m: [f64; 3],
    /// Covariance of `pos_m`, m², row-major 3×3; must be symmetric positive definite.
    pub cov_m2: [f64; 9],
}

impl PositionSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 3;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A fix of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, pos_m: [f64; 3], cov_m2: [f64; 9]) -> Self {
        Self { header: SampleHeader::new(SampleKind::Position, t_ns, sensor, seq), pos_m, cov_m2 }
    }
}

impl Default for PositionSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [0.0; 9])
    }
}

#[cfg(feature = "json")]
super::json_form!(PositionSample, PositionLine {
    /// m, ENU.
    pos: [f64; 3] => pos_m,
    /// m², row-major.
    cov: [f64; 9] => cov_m2,
});

const _: () = {
    assert!(core::mem::size_of::<PositionSample>() == 128);
    assert!(core::mem::align_of::<PositionSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for PositionSample {
    type Progress = ();
}

crate::wire_layout!(PositionSample, "A position fix, m ENU, with its covariance (m², row-major 3×3).", { header, pos_m, cov_m2 });

/// Not read from ROS messages.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for PositionSample {}
