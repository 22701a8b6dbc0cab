//! The geodetic GNSS fix.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// One GNSS position fix in WGS-84 geodetic coordinates, as a receiver reports it
/// (for example u-blox `NAV-PVT` `lat`/`lon`/`height`, NMEA `GGA` with the geoid
/// separation added back), with its covariance in the local east-north-up frame at
/// the fix (a receiver's horizontal and vertical accuracy give
/// `diag(h², h², v²)`; a full 3×3 is accepted). fusiond turns it into its local ENU
/// frame about the datum ([`crate::geodesy::Datum`]) exactly, through ECEF.
///
/// The receiver's own view of the fix's quality comes with it: its fix type
/// ([`fix`]), the satellites used and its dilutions of precision. fusiond maps
/// them to the noise it fuses the fix with and refuses the fix types it is
/// configured to refuse (`[sensor.quality]`). A field a receiver does not report
/// is 0.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "GeodeticLine", into = "GeodeticLine"))]
#[type_name("fusion.GeodeticSample.v3")]
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
    /// be symmetric positive definite. The receiver's own accuracy estimate.
    pub cov_enu_m2: [f64; 9],
    /// Fix type, a code of [`fix`] (0: not reported).
    pub fix_type: u32,
    /// Satellites used in the fix (0: not reported; at most
    /// [`fix::MAX_SATELLITES`]).
    pub satellites: i32,
    /// Horizontal dilution of precision (0: not reported).
    pub hdop: f64,
    /// Vertical dilution of precision (0: not reported).
    pub vdop: f64,
}

/// Fix types of [`GeodeticSample::fix_type`] (u-blox `NAV-PVT` `fixType` with
/// `carrSoln`, NMEA `GGA` quality), best last.
pub mod fix {
    /// Not reported: the fix is taken as it comes.
    pub const UNKNOWN: u32 = 0;
    /// No fix (a receiver that reports a position anyway: dead reckoning, the
    /// last fix).
    pub const NONE: u32 = 1;
    /// 2-D fix (height held).
    pub const TWO_D: u32 = 2;
    /// 3-D fix, single point (SPS).
    pub const THREE_D: u32 = 3;
    /// Differential (DGNSS, SBAS).
    pub const DGNSS: u32 = 4;
    /// RTK with float ambiguities (decimetres).
    pub const RTK_FLOAT: u32 = 5;
    /// RTK with fixed ambiguities (centimetres).
    pub const RTK_FIXED: u32 = 6;
    /// Codes 0..COUNT are fix types; anything else is refused as out of range.
    pub const COUNT: usize = 7;
    /// Each code's name (as in the configuration), by code.
    pub const NAMES: [&str; COUNT] = ["unknown", "none", "2d", "3d", "dgnss", "rtk_float", "rtk_fixed"];
    /// The most satellites a fix can use (every constellation's, with room).
    pub const MAX_SATELLITES: i32 = 255;

    /// The name of a code ("invalid" for none).
    pub const fn name(code: u32) -> &'static str {
        if (code as usize) < COUNT { NAMES[code as usize] } else { "invalid" }
    }

    /// The code of a name.
    pub fn from_name(name: &str) -> Option<u32> {
        NAMES.iter().position(|n| *n == name).map(|i| i as u32)
    }
}

impl GeodeticSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 3;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A fix of sensor `sensor` with sequence number `seq` at `t_ns`: latitude and
    /// longitude (degrees), height above the ellipsoid (m), ENU covariance (m²);
    /// no quality reported (see [`with_quality`](Self::with_quality)).
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
            fix_type: fix::UNKNOWN,
            satellites: 0,
            hdop: 0.0,
            vdop: 0.0,
        }
    }

    /// The same fix with the receiver's quality: fix type ([`fix`]), satellites
    /// used, HDOP and VDOP.
    pub const fn with_quality(mut self, fix_type: u32, satellites: i32, hdop: f64, vdop: f64) -> Self {
        self.fix_type = fix_type;
        self.satellites = satellites;
        self.hdop = hdop;
        self.vdop = vdop;
        self
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
    /// Fix type: 0 not reported, 1 none, 2 2-D, 3 3-D, 4 DGNSS, 5 RTK float, 6 RTK
    /// fixed. Absent in recordings before `fusion.GeodeticSample.v3`.
    #[serde(default)]
    fix: u32 => fix_type,
    /// Satellites used (0: not reported).
    #[serde(default)]
    sats: i32 => satellites,
    /// Horizontal dilution of precision (0: not reported).
    #[serde(default)]
    hdop: f64 => hdop,
    /// Vertical dilution of precision (0: not reported).
    #[serde(default)]
    vdop: f64 => vdop,
});

const _: () = {
    assert!(core::mem::size_of::<GeodeticSample>() == 152);
    assert!(core::mem::align_of::<GeodeticSample>() == 8);
};

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for GeodeticSample {
    type Progress = ();
}

crate::wire_layout!(GeodeticSample, "A GNSS fix: WGS-84 latitude, longitude (deg), ellipsoidal height (m); ENU covariance m²; the receiver's fix type (`FIX_*`), satellites used, HDOP and VDOP (0: not reported).", { header, lat_deg, lon_deg, height_m, cov_enu_m2, fix_type, satellites, hdop, vdop });

/// A `sensor_msgs/NavSatFix` (no fix: none; SBAS or GBAS: DGNSS).
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for GeodeticSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] = &[crate::ros_msgs::MessageType::NavSatFix];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs::{self as ros, Message};
        use crate::sample::fix;
        let Message::NavSatFix(f) = m else { return Err(ros::not_read("geodetic")) };
        let t = f.header.t_ns()?;
        let fix_type = match f.status.status {
            s if s < 0 => return Err("no fix (status -1)".into()),
            0 => fix::THREE_D,
            _ => fix::DGNSS,
        };
        if f.position_covariance_type == 0 {
            return Err("position covariance unknown (position_covariance_type 0)".into());
        }
        let s = GeodeticSample::new(t, sensor, seq, f.latitude, f.longitude, f.altitude, f.position_covariance);
        Ok(s.with_quality(fix_type, 0, 0.0, 0.0))
    }
}
