//! The geodetic GNSS fix.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// One GNSS position fix in WGS-84 geodetic coordinates, as a receiver reports it
/// (for example u-blox `NAV-PVT` `lat`/`lon`/`height`, NMEA `GGA` with the geoid
/// separation added back), with its covariance in the local east-north-up frame at
/// the fix (a receiver's horizontal and vertical accuracy give
/// `diag(h², h², v²)`; a full 3×3 is accepted). fusiond turns it into its local ENU
/// frame about the datum ([`crate::geodesy::Datum`]) exactly, through ECEF.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "GeodeticLine", into = "GeodeticLine"))]
#[type_name("fusion.GeodeticSample.v2")]
#[repr(C)]
pub struct GeodeticSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Geodetic`].
    pub header: SampleHeader,
    /// Geodetic latitude, degrees (WGS-84), in [−90, 90].
    pub lat_deg: f64,
    /// Longitude, degrees (WGS-84), in [−180, 180].
    pub lon_deg: f64,
    /// Height above the WGS-84 ellipsoid (not above mean sea level), m.
    pub height_m: f64,
    /// Covariance of the position in the local ENU frame, m², row-major 3×3; must
    /// be symmetric positive definite.
    pub cov_enu_m2: [f64; 9],
}

impl GeodeticSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 3;

    /// A fix of sensor `sensor` with sequence number `seq` at `t_ns`: latitude and
    /// longitude (degrees), height above the ellipsoid (m), ENU covariance (m²).
    pub const fn new(
        t_ns: u64,
        sensor: u32,
        seq: u64,
        lat_deg: f64,
        lon_deg: f64,
        height_m: f64,
        cov_enu_m2: [f64; 9],
    ) -> Self {
        Self {
            header: SampleHeader::new(SampleKind::Geodetic, t_ns, sensor, seq),
            lat_deg,
            lon_deg,
            height_m,
            cov_enu_m2,
        }
    }
}

impl Default for GeodeticSample {
    fn default() -> Self {
        Self::new(0, 0, 0, 0.0, 0.0, 0.0, [0.0; 9])
    }
}

#[cfg(feature = "json")]
super::json_form!(GeodeticSample, GeodeticLine {
    /// Degrees.
    lat: f64 => lat_deg,
    /// Degrees.
    lon: f64 => lon_deg,
    /// m above the WGS-84 ellipsoid.
    height: f64 => height_m,
    /// m², ENU, row-major.
    cov: [f64; 9] => cov_enu_m2,
});

const _: () = {
    assert!(core::mem::size_of::<GeodeticSample>() == 128);
    assert!(core::mem::align_of::<GeodeticSample>() == 8);
};
