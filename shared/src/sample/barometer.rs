//! Barometer: static air pressure, from which the height follows.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The static air pressure a barometer measures, Pa, with its variance. fusiond
/// turns it into a pressure altitude (the International Standard Atmosphere's,
/// [`pressure_altitude_m`]) and fuses that against the height with a bias state.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "BarometerLine", into = "BarometerLine"))]
#[type_name("fusion.BarometerSample.v1")]
#[repr(C)]
pub struct BarometerSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Barometer`].
    pub header: SampleHeader,
    /// Static pressure, Pa; > 0 and at most [`MAX_PRESSURE_PA`].
    pub pressure_pa: f64,
    /// Variance of `pressure_pa`, Pa²; > 0.
    pub var_pa2: f64,
}

/// The highest pressure accepted, Pa (1.2 bar: far below sea level or a
/// blocked port under load).
pub const MAX_PRESSURE_PA: f64 = 120_000.0;

/// Standard sea-level pressure `p₀` of the International Standard Atmosphere, Pa.
pub const ISA_SEA_LEVEL_PA: f64 = 101_325.0;

/// The International Standard Atmosphere's altitude of `pressure_pa` in its
/// troposphere (ICAO Doc 7488, the barometric formula with the lapse rate
/// `L = 0.0065 K/m`, `T₀ = 288.15 K`, exponent `R L / (g M) = 0.190263`):
/// `h = T₀/L · (1 − (p/p₀)^0.190263)`, m. Valid to 11 km; a real atmosphere
/// differs by a nearly constant offset (the weather's), which is the
/// barometer's bias state.
pub fn pressure_altitude_m(pressure_pa: f64) -> f64 {
    44_330.769_230_769_23 * (1.0 - (pressure_pa / ISA_SEA_LEVEL_PA).powf(0.190_263))
}

/// `dh/dp` of [`pressure_altitude_m`] at `pressure_pa`, m/Pa (negative: about
/// −0.083 m/Pa at sea level).
pub fn pressure_altitude_slope(pressure_pa: f64) -> f64 {
    -44_330.769_230_769_23 * 0.190_263 * (pressure_pa / ISA_SEA_LEVEL_PA).powf(0.190_263 - 1.0) / ISA_SEA_LEVEL_PA
}

impl BarometerSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 1;

    /// A barometer's bias `b`, m (pressure altitude = height + `b`), one per
    /// barometer: the first's bit is 2, the others' follow the pose frame's.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind {
        what: "barometer bias",
        len: 1,
        states: &[
            (2, "baro_bias_m"),
            (64, "baro_bias_2_m"),
            (128, "baro_bias_3_m"),
            (256, "baro_bias_4_m"),
            (512, "baro_bias_5_m"),
            (1024, "baro_bias_6_m"),
        ],
    };

    /// A pressure (Pa, variance Pa²) of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(t_ns: u64, sensor: u32, seq: u64, pressure_pa: f64, var_pa2: f64) -> Self {
        Self { header: SampleHeader::new(SampleKind::Barometer, t_ns, sensor, seq), pressure_pa, var_pa2 }
    }
}

impl Default for BarometerSample {
    fn default() -> Self {
        Self::new(0, 0, 0, 0.0, 0.0)
    }
}

#[cfg(feature = "json")]
super::json_form!(BarometerSample, BarometerLine {
    /// Pa.
    pressure_pa: f64 => pressure_pa,
    /// Pa².
    var_pa2: f64 => var_pa2,
});

const _: () = {
    assert!(core::mem::size_of::<BarometerSample>() == 48);
    assert!(core::mem::align_of::<BarometerSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for BarometerSample {
    type Progress = ();
}

crate::wire_layout!(BarometerSample, "Static air pressure, Pa, with its variance (Pa²).", { header, pressure_pa, var_pa2 });

/// A `sensor_msgs/FluidPressure`, Pa.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for BarometerSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] = &[crate::ros_msgs::MessageType::FluidPressure];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs::{self as ros, Message};
        let Message::FluidPressure(p) = m else { return Err(ros::not_read("barometer")) };
        let t = p.header.t_ns()?;
        if p.variance == 0.0 {
            return Err("pressure variance unknown (0)".into());
        }
        Ok(BarometerSample::new(t, sensor, seq, p.fluid_pressure, p.variance))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The standard atmosphere's table values (ICAO): 0 m at 101325 Pa,
    /// 1000 m at 89874.6 Pa, 5000 m at 54019.9 Pa; the slope against a central
    /// difference.
    #[test]
    fn the_standard_atmosphere() {
        assert!(pressure_altitude_m(ISA_SEA_LEVEL_PA).abs() < 1e-9);
        assert!((pressure_altitude_m(89_874.6) - 1000.0).abs() < 0.5, "{}", pressure_altitude_m(89_874.6));
        assert!((pressure_altitude_m(54_019.9) - 5000.0).abs() < 2.0, "{}", pressure_altitude_m(54_019.9));
        let p = 95_000.0;
        let numeric = (pressure_altitude_m(p + 1.0) - pressure_altitude_m(p - 1.0)) / 2.0;
        assert!((pressure_altitude_slope(p) - numeric).abs() < 1e-8, "{} {numeric}", pressure_altitude_slope(p));
    }
}
