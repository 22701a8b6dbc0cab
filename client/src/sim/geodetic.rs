//! A simulated GNSS receiver reporting WGS-84 latitude, longitude and height:
//! the truth (ENU about a datum, by default in Munich) plus white noise, turned
//! into geodetic coordinates exactly, with its ENU covariance, arriving after
//! random delays.

use fusion_shared::geodesy::Datum;
use fusion_shared::{GeodeticSample, Sample, SampleKind};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::AidingSim;
use super::scenario::{Arrival, gaussian3, to_ns};
use super::trajectory::CarTrajectory;

/// Geodetic GNSS simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GeodeticConfig {
    /// Fix rate, Hz.
    pub rate_hz: f64,
    /// Where trajectory position 0 is on the Earth.
    pub datum: Datum,
    /// Standard deviation of the horizontal noise, m (reported in the covariance).
    pub noise_std_m: f64,
    /// Standard deviation of the vertical noise, m.
    pub vertical_noise_std_m: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for GeodeticConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            // Theresienwiese, Munich, 519 m above the ellipsoid.
            datum: Datum { latitude_deg: 48.1316, longitude_deg: 11.5494, height_m: 519.0 },
            noise_std_m: 0.5,
            vertical_noise_std_m: 0.8,
            delay_min_ns: 20_000_000,
            delay_max_ns: 120_000_000,
            sensor: 3,
        }
    }
}

/// Simulated geodetic fixes (an endless iterator).
#[derive(Debug, Clone)]
pub struct GeodeticSim {
    trajectory: CarTrajectory,
    config: GeodeticConfig,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
}

impl GeodeticSim {
    /// Fixes on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: GeodeticConfig, start_ns: u64, seed: u64) -> Self {
        // Its own stream: adding the sensor leaves every other sample unchanged.
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6765_6f00);
        Self { trajectory, config, start_ns, index: 0, rng }
    }
}

impl Iterator for GeodeticSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let c = &self.config;
        let offset_ns = to_ns(self.index as f64 / c.rate_hz);
        let delay = self.rng.random_range(c.delay_min_ns..=c.delay_max_ns.max(c.delay_min_ns));
        let noise = gaussian3(&mut self.rng);
        let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
        let std = Vector3::new(c.noise_std_m, c.noise_std_m, c.vertical_noise_std_m);
        let enu = truth.pos_m + noise.component_mul(&std);
        let (lat, lon, h) = c.datum.to_geodetic(enu.into());
        let var = std.component_mul(&std);
        let t_ns = self.start_ns + offset_ns;
        let cov = [var.x, 0.0, 0.0, 0.0, var.y, 0.0, 0.0, 0.0, var.z];
        let sample = GeodeticSample::new(t_ns, c.sensor, self.index, lat, lon, h, cov);
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Geodetic(sample), outlier: false })
    }
}

impl AidingSim for GeodeticConfig {
    fn kind(&self) -> SampleKind {
        SampleKind::Geodetic
    }

    fn sensor(&self) -> u32 {
        self.sensor
    }

    fn arrivals(&self, trajectory: &CarTrajectory, start_ns: u64, seed: u64) -> Box<dyn Iterator<Item = Arrival> + Send> {
        Box::new(GeodeticSim::new(trajectory.clone(), self.clone(), start_ns, seed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without noise, every fix is the truth: turned back into ENU about the
    /// datum it is the trajectory's position to a millimetre.
    #[test]
    fn noiseless_fixes_are_the_truth_in_geodetic_coordinates() {
        let c = GeodeticConfig { noise_std_m: 0.0, vertical_noise_std_m: 0.0, ..Default::default() };
        let traj = CarTrajectory::new(4);
        for a in GeodeticSim::new(traj.clone(), c.clone(), 0, 1).take(200) {
            let Sample::Geodetic(g) = a.sample else { panic!("{a:?}") };
            let enu = Vector3::from(c.datum.to_enu(g.lat_deg, g.lon_deg, g.height_m));
            let truth = traj.at(g.header.t_ns as f64 * 1e-9).pos_m;
            assert!((enu - truth).amax() < 1e-3, "{enu} {truth}");
        }
    }
}
