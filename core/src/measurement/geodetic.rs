//! The geodetic GNSS fix: WGS-84 latitude, longitude and height, turned into the
//! world frame about the datum ([`crate::frames`]) exactly (geodetic → ECEF → ENU,
//! [`fusion_shared::geodesy`]), then fused as a position: `z = p + v`,
//! `v ~ N(0, R)`, R the sample's ENU covariance.
//!
//! The covariance is given in the ENU frame at the fix, whose axes differ from the
//! datum's by the angle between the two verticals (about 1 mrad per 6.4 km): at the
//! few-kilometre ranges of a local frame the rotation changes R by less than its
//! own uncertainty, so R is used as given.
//!
//! - `linear`: `H = [I 0]`, Joseph-form update.
//! - `ins`: `H` selects δp, `h(x) = p`; injected and reset as a position fix;
//!   with the antenna's lever arm `l`, `h(x) = p + R l` ([`super::lever_arm`]).
//!
//! The first valid fix sets the datum when none is configured.
//!
//! The receiver's quality (fix type, satellites, HDOP/VDOP) maps to the noise `R`
//! the fix is fused with, and refused fix types are refused, as the sensor's
//! `[sensor.quality]` says ([`quality`]).
//!
//! Validation: latitude in [−90°, 90°], longitude in [−180°, 180°], height within
//! [−1 km, 18 km] of the ellipsoid, all finite; covariance symmetric positive
//! definite; a known fix type code, satellites in 0..=255, HDOP and VDOP finite
//! in [0, 100] (0: not reported). Required by the health as a position source
//! (this or `position`).

#![allow(non_snake_case)]

pub mod quality;
use quality::GnssQuality;

use fusion_shared::geodesy::{self, Datum, InvalidGeodetic};
use fusion_shared::{GeodeticSample, PositionSample, SampleKind, fix};
use nalgebra::{Matrix3, Vector3};

use super::{Fuse, Kinematic, Limits, Measurement, Needed, Observation, Observe, Rejection, covariance3, lever_arm};
use crate::model::ins::{InsModel, InsState};
use crate::model::linear::{self, LinearModel, LinearState};
use crate::setting::ConfigError;
use crate::frames::Frames;
use crate::model::{Model, StepOutcome};

impl Measurement for GeodeticSample {
    const RANK: u8 = 1;
    /// The horizontal position, and the tilt through the accelerometer.
    fn observes(_: Option<&GnssQuality>) -> super::Observes {
        super::Observes { horizontal_position: true, tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Reinitialises;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = Some(Needed::Position);
    type Settings = GnssQuality;
    const TABLE: Option<&'static str> = Some("quality");
    const TABLE_DOC: &'static str = r#"#   [sensor.quality]                       # geodetic, optional: the receiver's fix type, DOPs -> noise
#   refuse = ["none"]                      # fix types not fused: unknown none 2d 3d dgnss rtk_float rtk_fixed
#   covariance_scale = 1.0                 # the reported covariance times this
#   uere_m = 0.0                           # > 0: HDOP x uere_m, VDOP x uere_m are floors too
#   min_satellites = 0                     # fewer satellites (when reported): refused
#   [sensor.quality.horizontal_floor_m]    # least horizontal sigma per fix type, m
#   rtk_fixed = 0.02
#   rtk_float = 0.3
#   "3d" = 1.5
#   [sensor.quality.vertical_floor_m]      # least vertical sigma per fix type, m
#   rtk_fixed = 0.03
#   rtk_float = 0.5
#   "3d" = 2.5
"#;

    fn settings(table: Option<&toml::Value>, key: &dyn Fn(&str) -> String) -> Result<Option<GnssQuality>, ConfigError> {
        let Some(table) = table else { return Ok(None) };
        GnssQuality::from_config(&super::read_table(table, key)?, key).map(Some)
    }

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        geodesy::check(self.lat_deg, self.lon_deg, self.height_m).map_err(|e| match e {
            InvalidGeodetic::NonFinite => Rejection::NonFinite,
            InvalidGeodetic::Latitude | InvalidGeodetic::Longitude | InvalidGeodetic::Height => Rejection::OutOfRange,
        })?;
        super::finite(&[self.hdop, self.vdop])?;
        let dop = 0.0..=MAX_DOP;
        if self.fix_type as usize >= fix::COUNT
            || !(0..=fix::MAX_SATELLITES).contains(&self.satellites)
            || !dop.contains(&self.hdop)
            || !dop.contains(&self.vdop)
        {
            return Err(Rejection::OutOfRange);
        }
        covariance3(&self.cov_enu_m2)
    }

    fn admit(&self, frames: &Frames) {
        // Checked by `validate`: a valid fix is a valid datum.
        if let Ok(d) = Datum::new(self.lat_deg, self.lon_deg, self.height_m) {
            frames.datum_or_set(d);
        }
    }
}

/// The largest dilution of precision accepted (a receiver reports 99.99 for
/// "no geometry").
pub const MAX_DOP: f64 = 100.0;

/// The fix as the position fix at its world-frame coordinates (m, ENU about the
/// datum), with the same header and the covariance its quality maps to; `None`
/// when its quality refuses it, and before any datum (never, once the engine
/// admitted the fix).
fn as_position(f: &GeodeticSample, frames: &Frames) -> Option<PositionSample> {
    let cov = super::settings::<GeodeticSample>(frames, f.header.sensor).copied().unwrap_or_default().noise(f).ok()?;
    let enu = frames.datum()?.to_enu(f.lat_deg, f.lon_deg, f.height_m);
    let h = f.header;
    Some(PositionSample::new(h.t_ns, h.sensor, h.seq, enu, cov))
}

/// Fused as the position fix ([`super::position`]), of the sensor's mount
/// (the INS: the point at its lever arm, [`super::lever_arm`]).
impl<M: Kinematic> Fuse<M> for GeodeticSample {
    fn fuse(&self, model: &M, s: &mut M::State) -> (StepOutcome, M::Correction) {
        let Some(p) = as_position(self, model.frames()) else { return (StepOutcome::Refused, M::Correction::default()) };
        let R = Matrix3::from_row_slice(&p.cov_m2);
        model.fuse_position(s, SampleKind::Geodetic, self.header.sensor, &Vector3::from(p.pos_m), &R)
    }
}

/// The position fix's ([`super::position`]) at the fix's ENU coordinates.
impl<const D: usize> Observe<InsModel<D>, 3, D> for GeodeticSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<3, D>> {
        let p = as_position(self, model.frames())?;
        let mount = model.frames().mount(SampleKind::Geodetic, self.header.sensor);
        let (h, H) = lever_arm::position(s, &mount.lever_arm);
        Some(Observation { y: Vector3::from(p.pos_m) - h, H, R: Matrix3::from_row_slice(&p.cov_m2) })
    }
}

/// The position fix's at the fix's ENU coordinates: `y = z − p`
/// ([`linear::block`]).
impl Observe<LinearModel, 3, { linear::N }> for GeodeticSample {
    fn observe(&self, model: &LinearModel, s: &LinearState) -> Option<Observation<3, { linear::N }>> {
        let p = as_position(self, model.frames())?;
        let (h, H) = linear::block(s, 0);
        Some(Observation { y: Vector3::from(p.pos_m) - h, H, R: Matrix3::from_row_slice(&p.cov_m2) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::model::ins::InsModel;
    use crate::model::linear::LinearModel;

    const COV: [f64; 9] = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let fix = |lat, lon, h, cov| GeodeticSample::new(0, 0, 0, lat, lon, h, cov).validate(&limits);
        assert_eq!(fix(48.1, 11.6, 520.0, COV), Ok(()));
        assert_eq!(fix(90.01, 11.6, 520.0, COV), Err(Rejection::OutOfRange));
        assert_eq!(fix(-95.0, 11.6, 520.0, COV), Err(Rejection::OutOfRange));
        assert_eq!(fix(48.1, 180.5, 520.0, COV), Err(Rejection::OutOfRange));
        assert_eq!(fix(48.1, -181.0, 520.0, COV), Err(Rejection::OutOfRange));
        assert_eq!(fix(48.1, 11.6, 1e8, COV), Err(Rejection::OutOfRange));
        assert_eq!(fix(f64::NAN, 11.6, 520.0, COV), Err(Rejection::NonFinite));
        let mut indefinite = COV;
        indefinite[1] = 1.0;
        indefinite[3] = 1.0;
        assert_eq!(fix(48.1, 11.6, 520.0, indefinite), Err(Rejection::CovarianceNotPositiveDefinite));
        // The receiver's quality.
        let q = |code, sats, hdop, vdop| {
            GeodeticSample::new(0, 0, 0, 48.1, 11.6, 520.0, COV).with_quality(code, sats, hdop, vdop).validate(&limits)
        };
        assert_eq!(q(fix::RTK_FIXED, 24, 0.6, 1.1), Ok(()));
        assert_eq!(q(fix::UNKNOWN, 0, 0.0, 0.0), Ok(()), "nothing reported");
        assert_eq!(q(7, 24, 0.6, 1.1), Err(Rejection::OutOfRange), "a fix type out of range");
        assert_eq!(q(u32::MAX, 24, 0.6, 1.1), Err(Rejection::OutOfRange));
        assert_eq!(q(fix::THREE_D, -3, 0.6, 1.1), Err(Rejection::OutOfRange), "negative satellites");
        assert_eq!(q(fix::THREE_D, 300, 0.6, 1.1), Err(Rejection::OutOfRange));
        assert_eq!(q(fix::THREE_D, 9, f64::NAN, 1.1), Err(Rejection::NonFinite), "NaN HDOP");
        assert_eq!(q(fix::THREE_D, 9, 0.9, f64::INFINITY), Err(Rejection::NonFinite));
        assert_eq!(q(fix::THREE_D, 9, -0.5, 1.1), Err(Rejection::OutOfRange));
        assert_eq!(q(fix::THREE_D, 9, 0.9, 1e4), Err(Rejection::OutOfRange));
    }

    /// With the datum at the fix, a geodetic fix is the position fix at the origin;
    /// elsewhere it is the position fix at its exact ENU coordinates: both give the
    /// same estimate to rounding.
    #[test]
    fn a_geodetic_fix_is_fused_as_the_position_fix_at_its_enu_coordinates() {
        let m = LinearModel::new(0.5, [0.0; 6], [100.0; 6], None).unwrap();
        let datum = Datum::new(48.137, 11.575, 519.0).unwrap();
        let (lat, lon, h) = datum.to_geodetic([120.0, -40.0, 3.0]);
        let fix = GeodeticSample::new(5, 0, 0, lat, lon, h, COV);
        // The first fix sets the datum when none is configured.
        assert!(m.frames().datum().is_none());
        fix.admit(m.frames());
        assert_eq!(m.frames().datum(), Some(&Datum::new(lat, lon, h).unwrap()));

        let configured = LinearModel::new(0.5, [0.0; 6], [100.0; 6], None).unwrap().with_frames(Frames::new(Some(datum)));
        fix.admit(configured.frames());
        assert_eq!(configured.frames().datum(), Some(&datum), "a configured datum stays");
        let mut s = configured.initial_state();
        let (out, ()) = fix.fuse(&configured, &mut s);
        let mut reference = configured.initial_state();
        let pos = PositionSample::new(5, 0, 0, datum.to_enu(lat, lon, h), COV);
        let (ref_out, ()) = pos.fuse(&configured, &mut reference);
        assert!(matches!(out, StepOutcome::Fused { .. }) && matches!(ref_out, StepOutcome::Fused { .. }));
        let (x, xr) = (s.filter().x(), reference.filter().x());
        assert!((x - xr).amax() < 1e-9, "{x} {xr}");
        assert!((x[0] - 120.0 * 100.0 / 100.25).abs() < 1e-6, "{}", x[0]);
    }

    /// Without a datum (a fix the engine never admitted) the update is refused,
    /// never fused in a wrong frame.
    #[test]
    fn without_a_datum_nothing_is_fused() {
        let m = InsModel::new(
            crate::model::ins::ImuNoise {
                accelerometer_noise_density: 0.02,
                gyroscope_noise_density: 0.001,
                accelerometer_random_walk: 0.001,
                gyroscope_random_walk: 1e-5,
            },
            9.80665,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0; 15],
            None,
            0,
        )
        .unwrap();
        let mut s = m.initial_state();
        let before = s;
        let (out, injected) = GeodeticSample::new(5, 0, 0, 48.0, 11.0, 500.0, COV).fuse(&m, &mut s);
        assert_eq!((out, injected), (StepOutcome::Refused, None));
        assert_eq!(s, before);
    }
}
