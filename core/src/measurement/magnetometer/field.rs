//! The Earth's magnetic field a magnetometer is fused against, and the check
//! that refuses disturbed samples (`[sensor.magnetic]` of a sensor with kind
//! `magnetometer`).
//!
//! The field is given by its declination `D` (east of true north positive), its
//! inclination `I` (below the horizontal positive: about +64° in central Europe,
//! −60° in Australia) and its strength `B`, as the World Magnetic Model gives
//! them for the site (NOAA's calculator, `geomag`). In the world frame (ENU):
//!
//! ```text
//! m_w = B [cos I sin D,  cos I cos D,  −sin I]
//! ```
//!
//! A sample is disturbed (a passing lorry, a steel bridge, the vehicle's own
//! motors) when its strength is off by more than `max_strength_deviation` of `B`,
//! or, once the attitude is known, its inclination in the estimated world frame
//! is off by more than `max_inclination_deviation_deg`: it is refused and
//! counted as refused, and the estimate is unchanged (PX4 EKF2 checks the same
//! two, `EKF2_MAG_CHECK`).

use nalgebra::Vector3;
use serde::Deserialize;

use crate::setting::{ConfigError, invalid};

/// `[sensor.magnetic]` as written.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagneticConfig {
    /// Declination, degrees east of true north.
    pub declination_deg: f64,
    /// Inclination (dip), degrees below the horizontal.
    pub inclination_deg: f64,
    /// Total intensity, µT.
    pub strength_ut: f64,
    /// Largest relative deviation of a sample's strength from `strength_ut`
    /// (default 0.15).
    #[serde(default = "MagneticConfig::default_strength_deviation")]
    pub max_strength_deviation: f64,
    /// Largest deviation of a sample's inclination from `inclination_deg`,
    /// degrees (default 10).
    #[serde(default = "MagneticConfig::default_inclination_deviation")]
    pub max_inclination_deviation_deg: f64,
}

impl MagneticConfig {
    fn default_strength_deviation() -> f64 {
        0.15
    }
    fn default_inclination_deviation() -> f64 {
        10.0
    }
}

/// The checked field of a magnetometer's site and its disturbance limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EarthField {
    /// The field in the world frame (ENU), µT.
    pub world_ut: Vector3<f64>,
    /// Its strength, µT.
    pub strength_ut: f64,
    /// Its inclination, rad (below the horizontal positive).
    pub inclination_rad: f64,
    /// Largest relative strength deviation of a sample.
    pub max_strength_deviation: f64,
    /// Largest inclination deviation of a sample, rad.
    pub max_inclination_deviation_rad: f64,
}

/// Why a sample is taken for a disturbed one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Disturbance {
    /// Its strength is off.
    Strength,
    /// Its inclination is off.
    Inclination,
}

impl EarthField {
    /// The field of `c`, checked: finite, declination within ±180°, inclination
    /// within ±90°, strength in (0, 1000] µT, the limits > 0; an error names the
    /// key (`key(field)`).
    pub fn from_config(c: &MagneticConfig, key: impl Fn(&str) -> String) -> Result<Self, ConfigError> {
        let check = |name: &str, v: f64, ok: bool, what: &str| {
            if v.is_finite() && ok { Ok(()) } else { Err(invalid(key(name), format!("must be {what}, got {v}"))) }
        };
        check("declination_deg", c.declination_deg, c.declination_deg.abs() <= 180.0, "within ±180°")?;
        check("inclination_deg", c.inclination_deg, c.inclination_deg.abs() <= 90.0, "within ±90°")?;
        check("strength_ut", c.strength_ut, c.strength_ut > 0.0 && c.strength_ut <= 1000.0, "in (0, 1000] µT")?;
        let dev = c.max_strength_deviation;
        check("max_strength_deviation", dev, dev > 0.0 && dev < 1.0, "in (0, 1)")?;
        let inc = c.max_inclination_deviation_deg;
        check("max_inclination_deviation_deg", inc, inc > 0.0 && inc <= 90.0, "in (0, 90]°")?;
        let world = fusion_shared::sample::earth_field_enu(c.declination_deg, c.inclination_deg, c.strength_ut);
        Ok(Self {
            world_ut: Vector3::from(world),
            strength_ut: c.strength_ut,
            inclination_rad: c.inclination_deg.to_radians(),
            max_strength_deviation: dev,
            max_inclination_deviation_rad: inc.to_radians(),
        })
    }

    /// Checks a sample's strength, and with `world` (the sample in the
    /// estimated world frame, when the attitude is known) its inclination.
    pub fn check(&self, strength_ut: f64, world: Option<&Vector3<f64>>) -> Result<(), Disturbance> {
        if (strength_ut / self.strength_ut - 1.0).abs() > self.max_strength_deviation {
            return Err(Disturbance::Strength);
        }
        if let Some(w) = world {
            let inclination = (-w.z / strength_ut).clamp(-1.0, 1.0).asin();
            if (inclination - self.inclination_rad).abs() > self.max_inclination_deviation_rad {
                return Err(Disturbance::Inclination);
            }
        }
        Ok(())
    }
}

/// Munich's field (WMM 2025) with the default limits, for tests.
#[cfg(test)]
pub(crate) const MUNICH: MagneticConfig = MagneticConfig {
    declination_deg: 3.5,
    inclination_deg: 64.5,
    strength_ut: 48.5,
    max_strength_deviation: 0.15,
    max_inclination_deviation_deg: 10.0,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_field_points_north_east_and_down() {
        let f = EarthField::from_config(&MUNICH, |k| k.to_string()).unwrap();
        let w = f.world_ut;
        assert!((w.norm() - 48.5).abs() < 1e-12);
        assert!(w.x > 0.0 && w.y > 0.0 && w.z < 0.0, "{w}");
        assert!((w.x.atan2(w.y).to_degrees() - 3.5).abs() < 1e-12, "declination east of north");
        assert!(((-w.z / 48.5).asin().to_degrees() - 64.5).abs() < 1e-12);
    }

    #[test]
    fn disturbed_samples_are_found_by_strength_and_inclination() {
        let f = EarthField::from_config(&MUNICH, |k| k.to_string()).unwrap();
        let w = f.world_ut;
        assert_eq!(f.check(48.5, Some(&w)), Ok(()));
        assert_eq!(f.check(48.5 * 1.2, None), Err(Disturbance::Strength));
        assert_eq!(f.check(48.5 * 0.8, None), Err(Disturbance::Strength));
        assert_eq!(f.check(48.5 * 1.1, None), Ok(()));
        // The same strength, tilted 15° towards the horizontal.
        let flatter = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), -15f64.to_radians()) * w;
        assert_eq!(f.check(48.5, Some(&flatter)), Err(Disturbance::Inclination));
        assert_eq!(f.check(48.5, None), Ok(()), "without the attitude the inclination is not checked");
    }

    #[test]
    fn every_bad_key_is_named() {
        let err = |c: MagneticConfig| {
            EarthField::from_config(&c, |k| format!("sensor.magnetic.{k}")).unwrap_err().to_string()
        };
        assert!(err(MagneticConfig { declination_deg: 200.0, ..MUNICH }).contains("declination_deg"));
        assert!(err(MagneticConfig { inclination_deg: f64::NAN, ..MUNICH }).contains("inclination_deg"));
        assert!(err(MagneticConfig { strength_ut: 0.0, ..MUNICH }).contains("strength_ut"));
        assert!(err(MagneticConfig { max_strength_deviation: 1.0, ..MUNICH }).contains("max_strength_deviation"));
        assert!(err(MagneticConfig { max_inclination_deviation_deg: 0.0, ..MUNICH }).contains("inclination_deviation"));
    }
}
