//! Simulated velocities (GNSS Doppler): the true world-frame velocity of the
//! antenna plus white noise with its covariance, arriving after random delays.

use fusion_shared::{Sample, VelocitySample};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::arrival::{Arrival, gaussian3, schedule};
use super::trajectory::CarTrajectory;

/// Velocity (GNSS Doppler) simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the horizontal noise, m/s (reported in the covariance).
    pub noise_std_mps: f64,
    /// Standard deviation of the vertical noise, m/s.
    pub vertical_noise_std_mps: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
    /// Position of the antenna in the body frame, m: the velocities are of the
    /// point `p + R l`, `v + R (ω × l)`.
    pub lever_arm_m: [f64; 3],
    /// How late the receiver's clock is, ns: a velocity valid at `t` is stamped
    /// `t + clock_lag_ns` (as [`super::PositionConfig::clock_lag_ns`]).
    pub clock_lag_ns: u64,
}

impl Default for VelocityConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            noise_std_mps: 0.05,
            vertical_noise_std_mps: 0.1,
            delay_min_ns: 20_000_000,
            delay_max_ns: 120_000_000,
            sensor: 2,
            lever_arm_m: [0.0; 3],
            clock_lag_ns: 0,
        }
    }
}

/// Simulated velocities (an endless iterator): the true world-frame velocity plus
/// white noise, with the noise's covariance.
#[derive(Debug, Clone)]
pub struct VelocitySim {
    trajectory: CarTrajectory,
    config: VelocityConfig,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
}

impl VelocitySim {
    /// Velocities on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: VelocityConfig, start_ns: u64, seed: u64) -> Self {
        // Its own stream: adding the sensor leaves every other sample unchanged.
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7665_6c00);
        Self { trajectory, config, start_ns, index: 0, rng }
    }
}

impl Iterator for VelocitySim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let c = &self.config;
        let (offset_ns, delay) = schedule(&mut self.rng, self.index, c.rate_hz, c.delay_min_ns, c.delay_max_ns);
        let noise = gaussian3(&mut self.rng);
        let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
        let std = Vector3::new(c.noise_std_mps, c.noise_std_mps, c.vertical_noise_std_mps);
        let vel = truth.antenna_velocity(&Vector3::from(c.lever_arm_m)) + noise.component_mul(&std);
        let var = std.component_mul(&std);
        let t_ns = self.start_ns + offset_ns + c.clock_lag_ns;
        let cov = [var.x, 0.0, 0.0, 0.0, var.y, 0.0, 0.0, 0.0, var.z];
        let sample = VelocitySample::new(t_ns, c.sensor, self.index, vel.into(), cov);
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Velocity(sample), outlier: false })
    }
}

super::aiding_sim!(VelocityConfig, VelocitySim, Velocity);

/// `fusion-sim`'s flags of the GNSS velocities (the position fixes' receiver: its delays, its antenna, its clock).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct VelocityFlags {
    /// Velocity (GNSS Doppler) rate, Hz; 0: no velocity sensor.
    #[arg(long, default_value_t = 0.0)]
    pub velocity_rate: f64,
    /// Horizontal velocity noise, m/s (vertical: 2×).
    #[arg(long, default_value_t = 0.05)]
    pub velocity_noise: f64,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::VelocitySample {
    type Flags = VelocityFlags;

    fn apply(
        f: &VelocityFlags,
        _drive: &super::flags::DriveFlags,
        all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.velocity_rate <= 0.0 {
            return Ok(());
        }
        let fix = &c.position;
        // One GNSS receiver: its velocities carry the id of its geodetic fixes.
        let defaults = VelocityConfig::default();
        let gnss = super::GeodeticConfig::default().fix.sensor;
        let sensor = if all.geodetic.geodetic_rate > 0.0 { gnss } else { defaults.sensor };
        c.aiding.push(Arc::new(VelocityConfig {
            rate_hz: f.velocity_rate,
            noise_std_mps: f.velocity_noise,
            vertical_noise_std_mps: 2.0 * f.velocity_noise,
            delay_min_ns: fix.delay_min_ns,
            delay_max_ns: fix.delay_max_ns,
            sensor,
            lever_arm_m: fix.lever_arm_m,
            clock_lag_ns: fix.clock_lag_ns,
        }));
        Ok(())
    }
}
