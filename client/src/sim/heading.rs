//! Simulated heading (a dual-antenna GNSS receiver): the true yaw plus white
//! noise, wrapped into (−π, π], arriving after a delay.

use std::f64::consts::PI;

use fusion_shared::{HeadingSample, Sample};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::arrival::{Arrival, schedule};
use super::trajectory::CarTrajectory;

/// Heading simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadingConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the white noise, rad (reported in the variance).
    pub noise_std_rad: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for HeadingConfig {
    fn default() -> Self {
        Self {
            rate_hz: 5.0,
            noise_std_rad: 0.5f64.to_radians(),
            delay_min_ns: 20_000_000,
            delay_max_ns: 120_000_000,
            sensor: 0,
        }
    }
}

/// Simulated headings (an endless iterator).
#[derive(Debug, Clone)]
pub struct HeadingSim {
    trajectory: CarTrajectory,
    config: HeadingConfig,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
}

impl HeadingSim {
    /// Headings on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: HeadingConfig, start_ns: u64, seed: u64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6864_6700 ^ (u64::from(config.sensor) << 40));
        Self { trajectory, config, start_ns, index: 0, rng }
    }
}

impl Iterator for HeadingSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let c = &self.config;
        let (offset_ns, delay) = schedule(&mut self.rng, self.index, c.rate_hz, c.delay_min_ns, c.delay_max_ns);
        let noise: f64 = StandardNormal.sample(&mut self.rng);
        let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
        let mut yaw = truth.yaw_rad() + noise * c.noise_std_rad;
        if yaw > PI {
            yaw -= 2.0 * PI;
        } else if yaw <= -PI {
            yaw += 2.0 * PI;
        }
        let t_ns = self.start_ns + offset_ns;
        let sample = HeadingSample::new(t_ns, c.sensor, self.index, yaw, c.noise_std_rad.powi(2));
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Heading(sample), outlier: false })
    }
}

super::aiding_sim!(HeadingConfig, HeadingSim, Heading);
