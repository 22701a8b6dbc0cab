//! Simulated position fixes (GNSS): the truth plus white noise with its covariance,
//! arriving after random delays, with optional dropouts and gross outliers, of a
//! point at a lever arm from the IMU (the antenna).

use fusion_shared::{PositionSample, Sample};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::arrival::{Arrival, gaussian3, to_ns};
use super::trajectory::CarTrajectory;

/// Position simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionConfig {
    /// Fix rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the horizontal noise, m (reported in the covariance).
    pub noise_std_m: f64,
    /// Standard deviation of the vertical noise, m.
    pub vertical_noise_std_m: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Probability that a fix is lost.
    pub dropout_probability: f64,
    /// Probability that a fix is a gross outlier.
    pub outlier_probability: f64,
    /// Size of an outlier's error, m (random direction).
    pub outlier_m: f64,
    /// Sensor id.
    pub sensor: u32,
    /// Position of the antenna in the body frame, m: the fixes are of the point
    /// `p + R l`.
    pub lever_arm_m: [f64; 3],
    /// How late the receiver's clock is, ns: a fix valid at `t` is stamped
    /// `t + clock_lag_ns` (what `[[sensor]] time_offset_ns` undoes).
    pub clock_lag_ns: u64,
}

impl Default for PositionConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            noise_std_m: 0.5,
            vertical_noise_std_m: 0.8,
            delay_min_ns: 20_000_000,
            delay_max_ns: 120_000_000,
            dropout_probability: 0.0,
            outlier_probability: 0.0,
            outlier_m: 30.0,
            sensor: 1,
            lever_arm_m: [0.0; 3],
            clock_lag_ns: 0,
        }
    }
}

/// Simulated position fixes (an endless iterator; dropped fixes are skipped).
#[derive(Debug, Clone)]
pub struct PositionSim {
    trajectory: CarTrajectory,
    config: PositionConfig,
    start_ns: u64,
    index: u64,
    seq: u64,
    rng: ChaCha8Rng,
}

impl PositionSim {
    /// Fixes on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: PositionConfig, start_ns: u64, seed: u64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x706f_7300);
        Self { trajectory, config, start_ns, index: 0, seq: 0, rng }
    }
}

impl Iterator for PositionSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        loop {
            let offset_ns = to_ns(self.index as f64 / self.config.rate_hz);
            self.index += 1;
            let c = &self.config;
            // Draw every random number of a fix whether or not it is used, so a
            // change of one probability does not shift the whole stream.
            let dropped = self.rng.random::<f64>() < c.dropout_probability;
            let outlier = self.rng.random::<f64>() < c.outlier_probability;
            let delay = self.rng.random_range(c.delay_min_ns..=c.delay_max_ns.max(c.delay_min_ns));
            let noise = gaussian3(&mut self.rng);
            let direction = gaussian3(&mut self.rng).normalize();
            if dropped {
                continue;
            }
            let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
            let std = Vector3::new(c.noise_std_m, c.noise_std_m, c.vertical_noise_std_m);
            let mut pos = truth.antenna_position(&Vector3::from(c.lever_arm_m)) + noise.component_mul(&std);
            if outlier {
                pos += direction * c.outlier_m;
            }
            let var = std.component_mul(&std);
            let t_ns = self.start_ns + offset_ns + c.clock_lag_ns;
            let cov = [var.x, 0.0, 0.0, 0.0, var.y, 0.0, 0.0, 0.0, var.z];
            let sample = PositionSample::new(t_ns, c.sensor, self.seq, pos.into(), cov);
            self.seq += 1;
            return Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Position(sample), outlier });
        }
    }
}

super::aiding_sim!(PositionConfig, PositionSim, Position);

/// `fusion-sim`'s flags of the position fixes (at the GNSS antenna's lever arm).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct PositionFlags {
    /// Position rate, Hz.
    #[arg(long, default_value_t = 10.0)]
    pub position_rate: f64,
    /// Horizontal position noise, m (vertical: 1.6×).
    #[arg(long, default_value_t = 0.5)]
    pub position_noise: f64,
    /// Smallest position delay, ms.
    #[arg(long, default_value_t = 20)]
    pub position_delay_min_ms: u64,
    /// Largest position delay, ms.
    #[arg(long, default_value_t = 120)]
    pub position_delay_max_ms: u64,
    /// The GNSS antenna's lever arm (position, velocity, geodetic fixes): x,y,z
    /// in the body frame, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub lever_arm: Option<Vec<f64>>,
    /// How late the position or GNSS receiver's clock is, ms: a fix valid at `t` is
    /// stamped `t + LAG` (what `[[sensor]] time_offset_ns` undoes).
    #[arg(long, default_value_t = 0)]
    pub fix_clock_lag_ms: u64,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::PositionSample {
    type Flags = PositionFlags;

    fn apply(
        f: &PositionFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        c.position.rate_hz = f.position_rate;
        c.position.noise_std_m = f.position_noise;
        c.position.vertical_noise_std_m = 1.6 * f.position_noise;
        c.position.delay_min_ns = f.position_delay_min_ms * 1_000_000;
        c.position.delay_max_ns = f.position_delay_max_ms * 1_000_000;
        c.position.dropout_probability = drive.dropouts;
        c.position.outlier_probability = drive.outliers;
        c.position.lever_arm_m = super::flags::triple("--lever-arm", f.lever_arm.as_deref())?.unwrap_or([0.0; 3]);
        c.position.clock_lag_ns = f.fix_clock_lag_ms.saturating_mul(1_000_000);
        Ok(())
    }
}
