//! A simulated GNSS receiver reporting WGS-84 latitude, longitude and height: the
//! simulated position fixes ([`PositionSim`]: noise, delays, dropouts, outliers)
//! about a datum on the Earth (by default in Munich), turned into geodetic
//! coordinates exactly, with the same ENU covariance; or, in phases of its
//! fix type ([`FixPhase`]: RTK fixed, float, single point, no fix), with that
//! phase's noise and what the receiver reports of it (its fix type, satellites,
//! DOPs and an accuracy that, as real receivers', may be optimistic).

use fusion_shared::geodesy::Datum;
use fusion_shared::{GeodeticSample, PositionSample, Sample, SampleKind, fix};
use nalgebra::Vector3;

use super::AidingSim;
use super::position::{PositionConfig, PositionSim};
use super::arrival::Arrival;
use super::trajectory::CarTrajectory;

/// Geodetic GNSS simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GeodeticConfig {
    /// Where trajectory position 0 is on the Earth.
    pub datum: Datum,
    /// The fixes as in the local frame: rate, noise, delays, dropouts, outliers,
    /// sensor id.
    pub fix: PositionConfig,
    /// The receiver's fix type over the drive, in order of `at_s`; none: every
    /// fix has `fix`'s noise, reports it exactly and no quality.
    pub phases: Vec<FixPhase>,
}

/// A stretch of the drive in one fix type, from `at_s` (trajectory time, s) to
/// the next phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixPhase {
    /// Where it starts, s.
    pub at_s: f64,
    /// Fix type ([`fix`]).
    pub fix_type: u32,
    /// The fixes' true horizontal and vertical noise (1σ), m.
    pub noise_std_m: [f64; 2],
    /// The horizontal and vertical accuracy the receiver reports (1σ), m.
    pub reported_std_m: [f64; 2],
    /// Satellites used.
    pub satellites: i32,
    /// HDOP and VDOP.
    pub dop: [f64; 2],
}

impl FixPhase {
    /// RTK fixed: 2 cm (3 cm vertical), reported 1.4 cm (2 cm).
    pub const fn rtk_fixed(at_s: f64) -> Self {
        Self::new(at_s, fix::RTK_FIXED, [0.02, 0.03], [0.014, 0.02], 24, [0.6, 1.0])
    }
    /// RTK float: 0.3 m (0.5 m), reported 5 cm (8 cm): the receiver has not caught
    /// up with the lost ambiguities.
    pub const fn rtk_float(at_s: f64) -> Self {
        Self::new(at_s, fix::RTK_FLOAT, [0.3, 0.5], [0.05, 0.08], 18, [0.8, 1.3])
    }
    /// A single-point 3-D fix: 1.5 m (2.5 m), reported 0.8 m (1.2 m).
    pub const fn single(at_s: f64) -> Self {
        Self::new(at_s, fix::THREE_D, [1.5, 2.5], [0.8, 1.2], 11, [1.2, 2.0])
    }
    /// No fix, the receiver sending its last solution anyway: 10 m (15 m),
    /// reported 5 m (8 m).
    pub const fn none(at_s: f64) -> Self {
        Self::new(at_s, fix::NONE, [10.0, 15.0], [5.0, 8.0], 3, [6.0, 9.0])
    }

    const fn new(
        at_s: f64,
        fix_type: u32,
        noise_std_m: [f64; 2],
        reported_std_m: [f64; 2],
        satellites: i32,
        dop: [f64; 2],
    ) -> Self {
        Self { at_s, fix_type, noise_std_m, reported_std_m, satellites, dop }
    }
}

impl std::str::FromStr for FixPhase {
    type Err = String;

    /// `AT:TYPE`: from AT s on, fix type `rtk_fixed`, `rtk_float`, `3d` or `none`.
    fn from_str(text: &str) -> Result<Self, String> {
        let (at, kind) = text.split_once(':').ok_or_else(|| format!("{text:?}: expected AT:TYPE"))?;
        let at_s: f64 = at.parse().map_err(|_| format!("{at:?} is not a number of seconds"))?;
        if !(at_s.is_finite() && at_s >= 0.0) {
            return Err(format!("{at:?}: the start must be a number of seconds >= 0"));
        }
        Ok(match kind {
            "rtk_fixed" => Self::rtk_fixed(at_s),
            "rtk_float" => Self::rtk_float(at_s),
            "3d" => Self::single(at_s),
            "none" => Self::none(at_s),
            _ => return Err(format!("{kind:?}: the fix type is one of rtk_fixed, rtk_float, 3d, none")),
        })
    }
}

impl Default for GeodeticConfig {
    fn default() -> Self {
        Self {
            // Theresienwiese, Munich, 519 m above the ellipsoid.
            datum: Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 },
            fix: PositionConfig { sensor: 3, ..Default::default() },
            phases: Vec::new(),
        }
    }
}

/// Seed salt: the geodetic receiver draws its own noise, not a position
/// sensor's of the same run.
const SEED_SALT: u64 = 0x6765_6f00;

/// Simulated geodetic fixes (an endless iterator; dropped fixes are skipped).
#[derive(Debug, Clone)]
pub struct GeodeticSim {
    fixes: PositionSim,
    trajectory: CarTrajectory,
    config: GeodeticConfig,
    start_ns: u64,
}

impl GeodeticSim {
    /// Fixes on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: GeodeticConfig, start_ns: u64, seed: u64) -> Self {
        let fixes = PositionSim::new(trajectory.clone(), config.fix.clone(), start_ns, seed ^ SEED_SALT);
        Self { fixes, trajectory, config, start_ns }
    }

    /// The fix `pos_m` (ENU, m; the antenna's, with `fix`'s noise) and its
    /// reported covariance, as the receiver in its phase at trajectory time
    /// `t_s` gives them: the error scaled to the phase's noise (an outlier
    /// stays as it is), the phase's reported accuracy, and the quality.
    fn in_phase(&self, t_s: f64, p: &PositionSample, outlier: bool) -> ([f64; 3], [f64; 9], Option<FixPhase>) {
        let (c, pos_m) = (&self.config.fix, p.pos_m);
        let Some(phase) = self.config.phases.iter().rev().find(|q| q.at_s <= t_s) else { return (pos_m, p.cov_m2, None) };
        let truth = self.trajectory.at(t_s).antenna_position(&Vector3::from(c.lever_arm_m));
        let ratio = |true_sd: f64, sd: f64| if sd > 0.0 { true_sd / sd } else { 0.0 };
        let (h, v) = (ratio(phase.noise_std_m[0], c.noise_std_m), ratio(phase.noise_std_m[1], c.vertical_noise_std_m));
        let err = Vector3::from(pos_m) - truth;
        let pos = if outlier { Vector3::from(pos_m) } else { truth + Vector3::new(err.x * h, err.y * h, err.z * v) };
        let [rh, rv] = phase.reported_std_m.map(|s| s * s);
        (pos.into(), [rh, 0.0, 0.0, 0.0, rh, 0.0, 0.0, 0.0, rv], Some(*phase))
    }
}

impl Iterator for GeodeticSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let a = self.fixes.next()?;
        let Sample::Position(p) = a.sample else { return None };
        let h = p.header;
        let t_s = (h.t_ns - self.start_ns - self.config.fix.clock_lag_ns) as f64 * 1e-9;
        let (pos, cov, phase) = self.in_phase(t_s, &p, a.outlier);
        let (lat, lon, height) = self.config.datum.to_geodetic(pos);
        let mut sample = GeodeticSample::new(h.t_ns, h.sensor, h.seq, lat, lon, height, cov);
        if let Some(q) = phase {
            sample = sample.with_quality(q.fix_type, q.satellites, q.dop[0], q.dop[1]);
        }
        Some(Arrival { sample: Sample::Geodetic(sample), ..a })
    }
}

impl AidingSim for GeodeticConfig {
    fn kind(&self) -> SampleKind {
        SampleKind::Geodetic
    }

    fn sensor(&self) -> u32 {
        self.fix.sensor
    }

    fn arrivals(
        &self,
        trajectory: &CarTrajectory,
        start_ns: u64,
        seed: u64,
    ) -> Box<dyn Iterator<Item = Arrival> + Send> {
        Box::new(GeodeticSim::new(trajectory.clone(), self.clone(), start_ns, seed))
    }
}


/// `fusion-sim`'s flags of the geodetic fixes (the position fixes' receiver, its datum and its fix phases).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct GeodeticFlags {
    /// Geodetic GNSS (latitude, longitude, height) rate, Hz; 0: no such receiver.
    #[arg(long, default_value_t = 0.0)]
    pub geodetic_rate: f64,
    /// Horizontal noise of the geodetic fixes, m (vertical: 1.6×).
    #[arg(long, default_value_t = 0.5)]
    pub geodetic_noise: f64,
    /// Where trajectory position 0 is: latitude (deg), longitude (deg), height
    /// above the WGS-84 ellipsoid (m) (default: Munich, 48.1316,11.5494,519).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub datum: Option<Vec<f64>>,
    /// The GNSS receiver's fix type from AT s into the drive on, `AT:TYPE` with
    /// TYPE `rtk_fixed` (2 cm, reported 1.4 cm), `rtk_float` (0.3 m, reported
    /// 5 cm), `3d` (1.5 m, reported 0.8 m) or `none` (10 m); the geodetic fixes
    /// then carry the fix type, satellites and DOPs. Repeatable, in order.
    #[arg(long, value_name = "AT:TYPE")]
    pub fix_phase: Vec<FixPhase>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::GeodeticSample {
    type Flags = GeodeticFlags;

    fn apply(
        f: &GeodeticFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.geodetic_rate <= 0.0 {
            return Ok(());
        }
        let fix = &c.position;
        let mut g = GeodeticConfig::default();
        g.fix = PositionConfig {
            rate_hz: f.geodetic_rate,
            noise_std_m: f.geodetic_noise,
            vertical_noise_std_m: 1.6 * f.geodetic_noise,
            delay_min_ns: fix.delay_min_ns,
            delay_max_ns: fix.delay_max_ns,
            dropout_probability: drive.dropouts,
            outlier_probability: drive.outliers,
            lever_arm_m: fix.lever_arm_m,
            clock_lag_ns: fix.clock_lag_ns,
            ..g.fix
        };
        if let Some([lat, lon, h]) = super::flags::triple("--datum", f.datum.as_deref())? {
            g.datum = fusion_shared::geodesy::Datum::new(lat, lon, h).map_err(|e| anyhow::anyhow!("--datum: {e}"))?;
        }
        if f.fix_phase.windows(2).any(|w| w[1].at_s < w[0].at_s) {
            anyhow::bail!("--fix-phase: give the phases in order of their start");
        }
        g.phases = f.fix_phase.clone();
        c.aiding.push(Arc::new(g));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without noise, every fix is the truth: turned back into ENU about the
    /// datum it is the trajectory's position to a millimetre.
    #[test]
    fn noiseless_fixes_are_the_truth_in_geodetic_coordinates() {
        let fix = PositionConfig { noise_std_m: 0.0, vertical_noise_std_m: 0.0, ..Default::default() };
        let c = GeodeticConfig { fix, ..Default::default() };
        let traj = CarTrajectory::new(4);
        for a in GeodeticSim::new(traj.clone(), c.clone(), 0, 1).take(200) {
            let Sample::Geodetic(g) = a.sample else { panic!("{a:?}") };
            let enu = nalgebra::Vector3::from(c.datum.to_enu(g.lat_deg, g.lon_deg, g.height_m));
            let truth = traj.at(g.header.t_ns as f64 * 1e-9).pos_m;
            assert!((enu - truth).amax() < 1e-3, "{enu} {truth}");
        }
    }

    /// The receiver's noise is its own, not that of a position sensor of the same seed.
    #[test]
    fn its_noise_is_not_the_position_sensors() {
        let traj = CarTrajectory::new(4);
        let c = GeodeticConfig::default();
        let geo = GeodeticSim::new(traj.clone(), c.clone(), 0, 1).next().unwrap();
        let pos = PositionSim::new(traj, c.fix.clone(), 0, 1).next().unwrap();
        let (Sample::Geodetic(g), Sample::Position(p)) = (geo.sample, pos.sample) else { panic!() };
        assert_ne!(c.datum.to_enu(g.lat_deg, g.lon_deg, g.height_m)[0], p.pos_m[0]);
    }
}
