//! A simulated GNSS receiver reporting WGS-84 latitude, longitude and height: the
//! simulated position fixes ([`PositionSim`]: noise, delays, dropouts, outliers)
//! about a datum on the Earth (by default in Munich), turned into geodetic
//! coordinates exactly, with the same ENU covariance.

use fusion_shared::geodesy::Datum;
use fusion_shared::{GeodeticSample, Sample, SampleKind};

use super::AidingSim;
use super::position::{PositionConfig, PositionSim};
use super::scenario::Arrival;
use super::trajectory::CarTrajectory;

/// Geodetic GNSS simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GeodeticConfig {
    /// Where trajectory position 0 is on the Earth.
    pub datum: Datum,
    /// The fixes as in the local frame: rate, noise, delays, dropouts, outliers,
    /// sensor id.
    pub fix: PositionConfig,
}

impl Default for GeodeticConfig {
    fn default() -> Self {
        Self {
            // Theresienwiese, Munich, 519 m above the ellipsoid.
            datum: Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 },
            fix: PositionConfig { sensor: 3, ..Default::default() },
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
    datum: Datum,
}

impl GeodeticSim {
    /// Fixes on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: GeodeticConfig, start_ns: u64, seed: u64) -> Self {
        Self { fixes: PositionSim::new(trajectory, config.fix, start_ns, seed ^ SEED_SALT), datum: config.datum }
    }
}

impl Iterator for GeodeticSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let a = self.fixes.next()?;
        let Sample::Position(p) = a.sample else { return None };
        let h = p.header;
        let (lat, lon, height) = self.datum.to_geodetic(p.pos_m);
        let sample = GeodeticSample::new(h.t_ns, h.sensor, h.seq, lat, lon, height, p.cov_m2);
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

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

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
            let enu = Vector3::from(c.datum.to_enu(g.lat_deg, g.lon_deg, g.height_m));
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
