//! WGS-84 geodesy: geodetic coordinates ↔ the local ENU frame of a datum.
//!
//! fusiond estimates in a local east-north-up frame whose origin is a datum
//! (latitude, longitude, height above the WGS-84 ellipsoid). Geodetic fixes are
//! turned into that frame exactly, through Earth-centred Earth-fixed coordinates,
//! not by a flat-earth approximation:
//!
//! ```text
//! ECEF:  X = (N + h) cos φ cos λ,  Y = (N + h) cos φ sin λ,  Z = (N (1 − e²) + h) sin φ,
//!        N = a / √(1 − e² sin² φ)
//! ENU:   [e n u]ᵀ = R(φ₀, λ₀) · (X − X₀),
//!        R = [[−sin λ₀, cos λ₀, 0], [−sin φ₀ cos λ₀, −sin φ₀ sin λ₀, cos φ₀], [cos φ₀ cos λ₀, cos φ₀ sin λ₀, sin φ₀]]
//! ```
//!
//! (IOGP/EPSG Guidance Note 7-2, methods 9602 and 9837.) The inverse goes back
//! through ECEF with the `map_3d` crate's closed-form ECEF → geodetic conversion.
//! The tests check both directions against the guidance note's worked example and
//! against PROJ at high latitude, across the antimeridian and south of the equator,
//! to 1 mm.
//!
//! A snapshot carries its datum ([`crate::StateSnapshot::datum`]), so any reader
//! can turn the estimated position back into latitude, longitude and height.

use map_3d::{Ellipsoid, enu2geodetic, geodetic2enu};

/// The origin of the local ENU frame: a point on or near the WGS-84 ellipsoid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Datum {
    /// Geodetic latitude, degrees, in [−90, 90].
    pub latitude_deg: f64,
    /// Longitude, degrees, in [−180, 180].
    pub longitude_deg: f64,
    /// Height above the WGS-84 ellipsoid, m.
    pub height_m: f64,
}

/// Why geodetic coordinates are not usable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum InvalidGeodetic {
    /// A coordinate is NaN or infinite.
    #[error("a coordinate is not finite")]
    NonFinite,
    /// Latitude outside [−90°, 90°].
    #[error("latitude outside [-90, 90] degrees")]
    Latitude,
    /// Longitude outside [−180°, 180°].
    #[error("longitude outside [-180, 180] degrees")]
    Longitude,
    /// Height outside [−[`MAX_DEPTH_M`], [`MAX_HEIGHT_M`]] about the ellipsoid.
    #[error("height outside [-{MAX_DEPTH_M}, {MAX_HEIGHT_M}] m about the ellipsoid")]
    Height,
}

/// Lowest height accepted, m below the ellipsoid (the geoid is at most ~106 m
/// below it; deeper is a receiver fault, not a vehicle).
pub const MAX_DEPTH_M: f64 = 1_000.0;
/// Highest height accepted, m above the ellipsoid (what a GNSS receiver's export
/// limits allow a vehicle to report).
pub const MAX_HEIGHT_M: f64 = 18_000.0;

/// Checks latitude, longitude (degrees) and height above the ellipsoid (m).
pub fn check(latitude_deg: f64, longitude_deg: f64, height_m: f64) -> Result<(), InvalidGeodetic> {
    if !(latitude_deg.is_finite() && longitude_deg.is_finite() && height_m.is_finite()) {
        return Err(InvalidGeodetic::NonFinite);
    }
    if !(-90.0..=90.0).contains(&latitude_deg) {
        return Err(InvalidGeodetic::Latitude);
    }
    if !(-180.0..=180.0).contains(&longitude_deg) {
        return Err(InvalidGeodetic::Longitude);
    }
    if !(-MAX_DEPTH_M..=MAX_HEIGHT_M).contains(&height_m) {
        return Err(InvalidGeodetic::Height);
    }
    Ok(())
}

impl Datum {
    /// A datum at latitude, longitude (degrees) and height above the ellipsoid (m),
    /// checked as a fix is ([`check`]).
    pub fn new(latitude_deg: f64, longitude_deg: f64, height_m: f64) -> Result<Self, InvalidGeodetic> {
        check(latitude_deg, longitude_deg, height_m)?;
        Ok(Self { latitude_deg, longitude_deg, height_m })
    }

    /// The local ENU coordinates (m) of a geodetic point (degrees, m above the
    /// ellipsoid): WGS-84 geodetic → ECEF → ENU about this datum.
    pub fn to_enu(&self, latitude_deg: f64, longitude_deg: f64, height_m: f64) -> [f64; 3] {
        let (e, n, u) = geodetic2enu(
            latitude_deg.to_radians(),
            longitude_deg.to_radians(),
            height_m,
            self.latitude_deg.to_radians(),
            self.longitude_deg.to_radians(),
            self.height_m,
            Ellipsoid::WGS84,
        );
        [e, n, u]
    }

    /// The geodetic coordinates (latitude and longitude in degrees, longitude in
    /// (−180, 180], height above the ellipsoid in m) of a point in the local ENU
    /// frame (m): ENU → ECEF → WGS-84 geodetic.
    pub fn to_geodetic(&self, enu_m: [f64; 3]) -> (f64, f64, f64) {
        let (lat, lon, h) = enu2geodetic(
            enu_m[0],
            enu_m[1],
            enu_m[2],
            self.latitude_deg.to_radians(),
            self.longitude_deg.to_radians(),
            self.height_m,
            Ellipsoid::WGS84,
        );
        (lat.to_degrees(), lon.to_degrees(), h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dms(d: f64, m: f64, s: f64) -> f64 {
        d + m / 60.0 + s / 3600.0
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
    }

    /// IOGP/EPSG Guidance Note 7-2, method 9837 (geographic/topocentric), worked
    /// example: origin 55°N 5°E 200 m; point 53°48'33.820"N 2°07'46.380"E 73.0 m.
    #[test]
    fn the_epsg_worked_example_to_a_millimetre() {
        let origin = Datum::new(55.0, 5.0, 200.0).unwrap();
        let (lat, lon) = (dms(53.0, 48.0, 33.820), dms(2.0, 7.0, 46.380));
        let enu = origin.to_enu(lat, lon, 73.0);
        assert!(close(enu, [-189_013.869, -128_642.040, -4_220.171], 1e-3), "{enu:?}");
        let (la, lo, h) = origin.to_geodetic(enu);
        // 1e-8 degree is about 1 mm.
        assert!((la - lat).abs() < 1e-8 && (lo - lon).abs() < 1e-8 && (h - 73.0).abs() < 1e-3, "{la} {lo} {h}");
    }

    /// Reference ENU coordinates from PROJ 9.5.1 (`+proj=cart +ellps=WGS84` then
    /// `+proj=topocentric`): Svalbard (78°N), a datum east of the antimeridian
    /// with a point west of it, and Sydney (south of the equator).
    #[test]
    fn high_latitude_antimeridian_and_south_match_proj_to_a_millimetre() {
        let cases = [
            ((78.2232, 15.6267, 30.0), (78.25, 15.5, 450.0), [-2881.6598, 2995.4708, 418.6499]),
            ((-16.80, 179.99, 10.0), (-16.79, -179.98, 25.0), [3198.1237, 1106.4328, 14.1019]),
            ((-33.8568, 151.2153, 5.0), (-33.80, 151.30, 120.0), [7843.4270, 6297.1038, 107.0627]),
        ];
        for ((lat0, lon0, h0), (lat, lon, h), expected) in cases {
            let datum = Datum::new(lat0, lon0, h0).unwrap();
            let enu = datum.to_enu(lat, lon, h);
            assert!(close(enu, expected, 1e-3), "{enu:?} against {expected:?}");
            let (la, lo, hh) = datum.to_geodetic(enu);
            assert!((la - lat).abs() < 1e-8 && (lo - lon).abs() < 1e-8 && (hh - h).abs() < 1e-3, "{la} {lo} {hh}");
        }
    }

    #[test]
    fn impossible_coordinates_have_their_reason() {
        assert_eq!(check(90.5, 0.0, 0.0), Err(InvalidGeodetic::Latitude));
        assert_eq!(check(-91.0, 0.0, 0.0), Err(InvalidGeodetic::Latitude));
        assert_eq!(check(0.0, 180.01, 0.0), Err(InvalidGeodetic::Longitude));
        assert_eq!(check(0.0, -200.0, 0.0), Err(InvalidGeodetic::Longitude));
        assert_eq!(check(f64::NAN, 0.0, 0.0), Err(InvalidGeodetic::NonFinite));
        assert_eq!(check(0.0, 0.0, 1e7), Err(InvalidGeodetic::Height));
        assert_eq!(check(0.0, 0.0, -5_000.0), Err(InvalidGeodetic::Height));
        assert!(check(-90.0, 180.0, -50.0).is_ok());
    }
}
