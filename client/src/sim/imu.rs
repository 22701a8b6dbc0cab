//! The simulated IMU: the truth's acceleration (world, gravity removed) or specific
//! force (body), and body angular rate, with white noise, turn-on biases and bias
//! random walks (Kalibr's model), at a fixed rate with optional timestamp jitter.

use fusion_shared::{ImuSample, Sample};
use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::arrival::{Arrival, gaussian3};
use super::trajectory::CarTrajectory;

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
    /// How the IMU is mounted: `C_bs`, body ← sensor (its axis convention and
    /// rotation); the IMU reports `C_bsᵀ` times the body-frame values.
    pub rotation: Matrix3<f64>,
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
            rotation: Matrix3::identity(),
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
        // Each IMU (by sensor id) draws its own noise and biases.
        let own = u64::from(config.sensor) << 40;
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x696d_7500 ^ own);
        // Biases draw from their own stream, so enabling them leaves the white noise unchanged.
        let mut bias_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6269_6173 ^ own);
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
        let (accel, gyro) = match self.output {
            ImuOutput::BodySpecificForce if self.config.rotation != Matrix3::identity() => {
                let to_sensor = self.config.rotation.transpose();
                (to_sensor * accel, to_sensor * gyro)
            }
            _ => (accel, gyro),
        };
        let sample = ImuSample::new(t_ns, self.config.sensor, self.index, accel.into(), gyro.into());
        self.index += 1;
        Some(Arrival { arrival_ns: t_ns + self.config.delay_ns, sample: Sample::Imu(sample), outlier: false })
    }
}

/// `fusion-sim`'s flags of the IMUs.
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct ImuFlags {
    /// IMU rate, Hz.
    #[arg(long, default_value_t = 400.0)]
    pub imu_rate: f64,
    /// One IMU per mount (sensor ids 0, 1, …): its axes and its rotation into
    /// the body frame, `AXES:ROLL,PITCH,YAW` (degrees, body ← IMU, as in the
    /// config's `[[sensor]]`), e.g. `frd:3,-2,90`. Default: one IMU, `flu:0,0,0`.
    #[arg(long)]
    pub imu_mount: Vec<String>,
    /// IMU timestamp jitter, ± µs.
    #[arg(long, default_value_t = 0)]
    pub imu_jitter_us: u64,
    /// IMU acceleration noise, m/s² per sample.
    #[arg(long, default_value_t = 0.05)]
    pub accel_noise: f64,
    /// IMU angular-rate noise, rad/s per sample.
    #[arg(long, default_value_t = 0.001)]
    pub gyro_noise: f64,
    /// Standard deviation of the accelerometer's turn-on bias, m/s² (body output).
    #[arg(long, default_value_t = 0.0)]
    pub accel_bias: f64,
    /// Standard deviation of the gyroscope's turn-on bias, rad/s.
    #[arg(long, default_value_t = 0.0)]
    pub gyro_bias: f64,
    /// Accelerometer bias random walk, m/s³/√Hz (Kalibr).
    #[arg(long, default_value_t = 0.0)]
    pub accel_random_walk: f64,
    /// Gyroscope bias random walk, rad/s²/√Hz (Kalibr).
    #[arg(long, default_value_t = 0.0)]
    pub gyro_random_walk: f64,
    /// What the IMU measures: `world` acceleration with gravity removed (the
    /// linear model) or `body` specific force and angular rate (a real IMU).
    #[arg(long, value_enum, default_value_t = ImuOutputFlag::World)]
    pub imu_output: ImuOutputFlag,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::ImuSample {
    type Flags = ImuFlags;

    fn apply(
        f: &ImuFlags,
        _drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        let c_imu = &mut c.imu;
        c_imu.rate_hz = f.imu_rate;
        c_imu.jitter_ns = f.imu_jitter_us * 1000;
        c_imu.accel_noise_std = f.accel_noise;
        c_imu.gyro_noise_std = f.gyro_noise;
        c_imu.accel_bias_std = f.accel_bias;
        c_imu.gyro_bias_std = f.gyro_bias;
        c_imu.accel_random_walk = f.accel_random_walk;
        c_imu.gyro_random_walk = f.gyro_random_walk;
        c.imu_output = match f.imu_output {
            ImuOutputFlag::World => ImuOutput::WorldAcceleration,
            ImuOutputFlag::Body => ImuOutput::BodySpecificForce,
        };
        let mounts = if f.imu_mount.is_empty() { vec!["flu:0,0,0".to_string()] } else { f.imu_mount.clone() };
        for (i, mount) in mounts.iter().enumerate() {
            let rotation = super::flags::parse_mount("--imu-mount", mount)?;
            let imu = ImuConfig { sensor: i as u32, rotation, ..c.imu.clone() };
            if i == 0 {
                c.imu = imu;
            } else {
                c.extra_imus.push(imu);
            }
        }
        Ok(())
    }
}

/// What `fusion-sim`'s IMU measures (`--imu-output`).
#[cfg(feature = "cli")]
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ImuOutputFlag {
    /// World acceleration with gravity removed (the linear model).
    World,
    /// Body specific force and angular rate (a real IMU).
    Body,
}
