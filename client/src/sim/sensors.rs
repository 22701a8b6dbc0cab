//! Simulated sensors: IMU, position fixes and velocities (GNSS Doppler) sampled
//! from a [`CarTrajectory`].
//!
//! Each sensor is an iterator of [`Arrival`]s in timestamp order, so the same
//! code serves a file writer (merge by arrival time) and live publishers (pace by
//! arrival time). All randomness comes from seeded ChaCha8 streams: the same
//! configuration and seed give the same samples, bit for bit.

use fusion_shared::{ImuSample, PositionSample, Sample, VelocitySample};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::trajectory::{CarTrajectory, TruthState};

/// A sample with the time it reaches the daemon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arrival {
    /// When the sample is published, ns on the same clock as its timestamp.
    pub arrival_ns: u64,
    /// The sample.
    pub sample: Sample,
    /// True for an injected gross outlier.
    pub outlier: bool,
}

/// IMU simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuConfig {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Timestamp jitter: uniform in ±this, ns (kept below half the period).
    pub jitter_ns: u64,
    /// White noise on each acceleration component, m/s² per sample.
    pub accel_noise_std: f64,
    /// White noise on each angular-rate component, rad/s per sample.
    pub gyro_noise_std: f64,
    /// Transport delay from time of validity to publication, ns.
    pub delay_ns: u64,
    /// Sensor id.
    pub sensor: u32,
    /// Gravity for [`ImuOutput::BodySpecificForce`], m/s².
    pub gravity_mps2: f64,
    /// Standard deviation of the accelerometer's turn-on bias (drawn once per run), m/s².
    pub accel_bias_std: f64,
    /// Standard deviation of the gyroscope's turn-on bias, rad/s.
    pub gyro_bias_std: f64,
    /// Accelerometer bias random walk σ_aw, m/s³/√Hz (Kalibr).
    pub accel_random_walk: f64,
    /// Gyroscope bias random walk σ_gw, rad/s²/√Hz (Kalibr).
    pub gyro_random_walk: f64,
}

impl ImuConfig {
    /// An IMU at `rate_hz` following Kalibr's model: white noise densities σ_a
    /// (m/s²/√Hz) and σ_g (rad/s/√Hz), giving per-sample standard deviations
    /// `σ √rate`, and bias random walks σ_aw, σ_gw.
    pub fn kalibr(rate_hz: f64, accel_density: f64, gyro_density: f64, accel_rw: f64, gyro_rw: f64) -> Self {
        Self {
            rate_hz,
            accel_noise_std: accel_density * rate_hz.sqrt(),
            gyro_noise_std: gyro_density * rate_hz.sqrt(),
            accel_random_walk: accel_rw,
            gyro_random_walk: gyro_rw,
            ..Self::default()
        }
    }
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self {
            rate_hz: 400.0,
            jitter_ns: 0,
            accel_noise_std: 0.05,
            gyro_noise_std: 0.001,
            delay_ns: 0,
            sensor: 0,
            gravity_mps2: 9.80665,
            accel_bias_std: 0.0,
            gyro_bias_std: 0.0,
            accel_random_walk: 0.0,
            gyro_random_walk: 0.0,
        }
    }
}

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
        }
    }
}

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
        }
    }
}

/// What the IMU measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImuOutput {
    /// `accel`: world-frame acceleration with gravity removed; `gyro`: body rates
    /// (the `linear` model's input; it ignores the gyro).
    WorldAcceleration,
    /// `accel`: body-frame specific force `f = Rᵀ (a − g)`; `gyro`: body angular
    /// rate: what a real strapdown IMU measures (the INS model's input).
    BodySpecificForce,
}

fn gaussian3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(StandardNormal.sample(rng), StandardNormal.sample(rng), StandardNormal.sample(rng))
}

fn to_ns(t_s: f64) -> u64 {
    (t_s * 1e9).round() as u64
}

/// Simulated IMU (an endless iterator; take what you need).
#[derive(Debug, Clone)]
pub struct ImuSim {
    trajectory: CarTrajectory,
    config: ImuConfig,
    output: ImuOutput,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
    bias_rng: ChaCha8Rng,
    accel_bias: Vector3<f64>,
    gyro_bias: Vector3<f64>,
    last_t_s: f64,
}

impl ImuSim {
    /// An IMU on `trajectory` whose first sample is at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: ImuConfig, output: ImuOutput, start_ns: u64, seed: u64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x696d_7500);
        // Biases draw from their own stream, so enabling them leaves the white noise unchanged.
        let mut bias_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6269_6173);
        let accel_bias = gaussian3(&mut bias_rng) * config.accel_bias_std;
        let gyro_bias = gaussian3(&mut bias_rng) * config.gyro_bias_std;
        Self { trajectory, config, output, start_ns, index: 0, rng, bias_rng, accel_bias, gyro_bias, last_t_s: 0.0 }
    }

    /// The current accelerometer and gyroscope biases (body frame).
    pub fn biases(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.accel_bias, self.gyro_bias)
    }
}

impl Iterator for ImuSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let period_ns = 1e9 / self.config.rate_hz;
        let max_jitter = (self.config.jitter_ns as f64).min(0.45 * period_ns);
        let jitter = if max_jitter > 0.0 { self.rng.random_range(-max_jitter..=max_jitter) } else { 0.0 };
        let offset_ns = (self.index as f64 * period_ns + jitter).max(0.0).round() as u64;
        let t_ns = self.start_ns + offset_ns;
        let t_s = offset_ns as f64 * 1e-9;
        let truth = self.trajectory.at(t_s);
        // Bias random walk (Kalibr): b(t + dt) = b(t) + σ_w √dt · N(0, I).
        let dt = (t_s - self.last_t_s).max(0.0);
        self.last_t_s = t_s;
        if self.config.accel_random_walk > 0.0 || self.config.gyro_random_walk > 0.0 {
            self.accel_bias += gaussian3(&mut self.bias_rng) * (self.config.accel_random_walk * dt.sqrt());
            self.gyro_bias += gaussian3(&mut self.bias_rng) * (self.config.gyro_random_walk * dt.sqrt());
        }
        let accel = match self.output {
            ImuOutput::WorldAcceleration => truth.acc_mps2,
            ImuOutput::BodySpecificForce => truth.specific_force_mps2(self.config.gravity_mps2) + self.accel_bias,
        } + gaussian3(&mut self.rng) * self.config.accel_noise_std;
        let gyro = truth.omega_body_radps + self.gyro_bias + gaussian3(&mut self.rng) * self.config.gyro_noise_std;
        let sample = ImuSample::new(t_ns, self.config.sensor, self.index, accel.into(), gyro.into());
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + self.config.delay_ns, sample: Sample::Imu(sample), outlier: false })
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
            let mut pos = truth.pos_m + noise.component_mul(&std);
            if outlier {
                pos += direction * c.outlier_m;
            }
            let var = std.component_mul(&std);
            let t_ns = self.start_ns + offset_ns;
            let cov = [var.x, 0.0, 0.0, 0.0, var.y, 0.0, 0.0, 0.0, var.z];
            let sample = PositionSample::new(t_ns, c.sensor, self.seq, pos.into(), cov);
            self.seq += 1;
            return Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Position(sample), outlier });
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
        let offset_ns = to_ns(self.index as f64 / c.rate_hz);
        let delay = self.rng.random_range(c.delay_min_ns..=c.delay_max_ns.max(c.delay_min_ns));
        let noise = gaussian3(&mut self.rng);
        let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
        let std = Vector3::new(c.noise_std_mps, c.noise_std_mps, c.vertical_noise_std_mps);
        let vel = truth.vel_mps + noise.component_mul(&std);
        let var = std.component_mul(&std);
        let t_ns = self.start_ns + offset_ns;
        let cov = [var.x, 0.0, 0.0, 0.0, var.y, 0.0, 0.0, 0.0, var.z];
        let sample = VelocitySample::new(t_ns, c.sensor, self.index, vel.into(), cov);
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Velocity(sample), outlier: false })
    }
}

/// A whole recorded drive: IMU and position samples merged in arrival order.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The truth behind the samples.
    pub trajectory: CarTrajectory,
    /// Trajectory time 0, ns.
    pub start_ns: u64,
    /// Samples in arrival order (ties: timestamp order).
    pub arrivals: Vec<Arrival>,
}

/// Settings of a recorded drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioConfig {
    /// Seed of the trajectory and all noise.
    pub seed: u64,
    /// Length, s.
    pub duration_s: f64,
    /// Trajectory time 0, ns.
    pub start_ns: u64,
    /// IMU settings.
    pub imu: ImuConfig,
    /// What the IMU measures.
    pub imu_output: ImuOutput,
    /// Position settings.
    pub position: PositionConfig,
    /// Velocity sensor, if any.
    pub velocity: Option<VelocityConfig>,
}

impl Default for ScenarioConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            duration_s: 20.0,
            start_ns: 1_000_000_000,
            imu: ImuConfig::default(),
            imu_output: ImuOutput::WorldAcceleration,
            position: PositionConfig::default(),
            velocity: None,
        }
    }
}

impl Scenario {
    /// Simulates a drive.
    pub fn generate(config: &ScenarioConfig) -> Self {
        let trajectory = CarTrajectory::new(config.seed);
        let end_ns = config.start_ns + to_ns(config.duration_s);
        let imu = ImuSim::new(trajectory.clone(), config.imu.clone(), config.imu_output, config.start_ns, config.seed)
            .take_while(|a| a.sample.t_ns() <= end_ns);
        let pos = PositionSim::new(trajectory.clone(), config.position.clone(), config.start_ns, config.seed)
            .take_while(|a| a.sample.t_ns() <= end_ns);
        let vel = config.velocity.iter().flat_map(|v| {
            VelocitySim::new(trajectory.clone(), v.clone(), config.start_ns, config.seed)
                .take_while(|a| a.sample.t_ns() <= end_ns)
        });
        let mut arrivals: Vec<Arrival> = imu.chain(pos).chain(vel).collect();
        arrivals.sort_by_key(|a| (a.arrival_ns, a.sample.t_ns()));
        Self { trajectory, start_ns: config.start_ns, arrivals }
    }

    /// The truth at a sample time, ns.
    pub fn truth_at(&self, t_ns: u64) -> TruthState {
        self.trajectory.at((t_ns as f64 - self.start_ns as f64) * 1e-9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_arrive_late_and_out_of_order() {
        let s = Scenario::generate(&ScenarioConfig {
            imu: ImuConfig { rate_hz: 200.0, jitter_ns: 500_000, ..Default::default() },
            ..Default::default()
        });
        let n_imu = s.arrivals.iter().filter(|a| matches!(a.sample, Sample::Imu(_))).count();
        let n_pos = s.arrivals.len() - n_imu;
        // 20 s at 200 Hz; the last one may jitter past the end.
        assert!((4000..=4001).contains(&n_imu) && n_pos == 201, "{n_imu} {n_pos}");
        // Arrival order differs from timestamp order.
        let out_of_order = s.arrivals.windows(2).filter(|w| w[1].sample.t_ns() < w[0].sample.t_ns()).count();
        assert!(out_of_order > 150);
        for a in &s.arrivals {
            let delay = a.arrival_ns - a.sample.t_ns();
            if let Sample::Position(_) = a.sample {
                assert!((20_000_000..=120_000_000).contains(&delay));
            }
        }
    }

    #[test]
    fn outliers_are_flagged_and_far_off() {
        let s = Scenario::generate(&ScenarioConfig {
            position: PositionConfig { outlier_probability: 0.1, dropout_probability: 0.1, ..Default::default() },
            ..Default::default()
        });
        let mut outliers = 0;
        for a in &s.arrivals {
            if let Sample::Position(p) = a.sample {
                let err = (Vector3::from(p.pos_m) - s.truth_at(p.header.t_ns).pos_m).norm();
                assert_eq!(a.outlier, err > 10.0, "err {err}");
                outliers += a.outlier as usize;
            }
        }
        assert!(outliers > 5);
    }

    #[test]
    fn the_same_seed_gives_the_same_drive() {
        let c = ScenarioConfig { duration_s: 2.0, ..Default::default() };
        assert_eq!(Scenario::generate(&c).arrivals, Scenario::generate(&c).arrivals);
    }
}
