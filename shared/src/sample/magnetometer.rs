//! Magnetometer: the magnetic field vector in the sensor's axes.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The magnetic field a three-axis magnetometer measures, in its own axes (its
/// mounting into the body frame is configuration: `[[sensor]] axes`,
/// `rotation_rpy_deg`), calibrated for hard and soft iron (the publisher's
/// calibration, as PX4's and ArduPilot's drivers publish it), in microtesla,
/// with its covariance. The Earth's field is about 25–65 µT.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "MagnetometerLine", into = "MagnetometerLine"))]
#[type_name("fusion.MagnetometerSample.v2")]
#[repr(C)]
pub struct MagnetometerSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Magnetometer`].
    pub header: SampleHeader,
    /// Field, µT, sensor axes; |field| ≤ 1000 µT.
    pub field_ut: [f64; 3],
    /// Covariance of `field_ut`, µT², row-major 3×3; symmetric positive definite.
    pub cov_ut2: [f64; 9],
}

impl MagnetometerSample {
    /// Values one sample gives a measurement update (the 3-D field; fused as a
    /// heading, one): the χ² degrees of freedom of its NIS.
    pub const INNOVATION_DIM: usize = 3;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A field (µT, sensor axes) of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, field_ut: [f64; 3], cov_ut2: [f64; 9]) -> Self {
        Self { header: SampleHeader::new(SampleKind::Magnetometer, t_ns, sensor, seq), field_ut, cov_ut2 }
    }
}

/// The Earth's field in the world frame (ENU), µT, from its declination (degrees
/// east of true north), inclination (degrees below the horizontal) and strength
/// (µT), as the World Magnetic Model gives them for a site:
/// `B [cos I sin D, cos I cos D, −sin I]`.
pub fn earth_field_enu(declination_deg: f64, inclination_deg: f64, strength_ut: f64) -> [f64; 3] {
    let (d, i) = (declination_deg.to_radians(), inclination_deg.to_radians());
    [strength_ut * i.cos() * d.sin(), strength_ut * i.cos() * d.cos(), -strength_ut * i.sin()]
}

impl Default for MagnetometerSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [0.0; 9])
    }
}

#[cfg(feature = "json")]
super::json_form!(MagnetometerSample, MagnetometerLine {
    /// µT, sensor axes.
    field: [f64; 3] => field_ut,
    /// µT², row-major 3×3.
    cov: [f64; 9] => cov_ut2,
});

const _: () = {
    assert!(core::mem::size_of::<MagnetometerSample>() == 128);
    assert!(core::mem::align_of::<MagnetometerSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for MagnetometerSample {
    type Progress = ();
}

crate::wire_layout!(MagnetometerSample, "A magnetometer's field, µT in the sensor's axes (calibrated), with its covariance (µT², row-major 3×3).", { header, field_ut, cov_ut2 });

/// A `sensor_msgs/MagneticField`, T → µT.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for MagnetometerSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] = &[crate::ros_msgs::MessageType::MagneticField];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs::{self as ros, Message};
        let Message::MagneticField(f) = m else { return Err(ros::not_read("magnetometer")) };
        let t = f.header.t_ns()?;
        if ros::unknown(&f.magnetic_field_covariance) {
            return Err("field covariance unknown (all zero)".into());
        }
        // Tesla → µT.
        let field = f.magnetic_field.array().map(|v| v * 1e6);
        let cov = f.magnetic_field_covariance.map(|v| v * 1e12);
        Ok(MagnetometerSample::new(t, sensor, seq, field, cov))
    }
}
