//! Simulated wheel odometry: the true forward speed of the body at the
//! odometry's reference point (the rear axle), with a wheel-radius scale error
//! and white noise, arriving after a short delay; 0 while the car stands (no
//! encoder ticks).

use fusion_shared::{SampleKind, OdometrySample, Sample};
use nalgebra::Vector3;

use super::arrival::{Reading, Sensor, SensorSim};

/// Wheel odometry simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the white noise, m/s.
    pub noise_std_mps: f64,
    /// Relative scale error (wheel radius, tyre wear): the reported speed is
    /// `(1 + scale_error)` times the true one.
    pub scale_error: f64,
    /// Whether the reported variance covers the scale error as well as the
    /// noise, `noise_std_mps² + (scale_error · speed)²` (an odometry tuned for
    /// a filter that does not estimate the scale), or the noise only,
    /// `noise_std_mps²` (for one that does: `[model.odometry_scale]`).
    pub scale_in_variance: bool,
    /// Position of the reference point in the body frame, m.
    pub lever_arm_m: [f64; 3],
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for OdometryConfig {
    fn default() -> Self {
        Self {
            rate_hz: 50.0,
            noise_std_mps: 0.05,
            scale_error: 0.002,
            scale_in_variance: true,
            lever_arm_m: [-1.3, 0.0, -0.3],
            delay_min_ns: 2_000_000,
            delay_max_ns: 10_000_000,
            sensor: 0,
        }
    }
}

/// Simulated odometry (an endless iterator).
pub type OdometrySim = SensorSim<OdometryConfig>;

impl Sensor for OdometryConfig {
    const KIND: SampleKind = SampleKind::Odometry;
    const SALT: u64 = 0x6f64_6f00;
    type Memory = ();

    super::arrival::usual_timing!();

    fn read(&self, mut r: Reading<'_, ()>) -> Option<Sample> {
        let c = self;
        let noise = r.normal();
        let truth = r.truth;
        let true_speed = truth.body_velocity(&Vector3::from(c.lever_arm_m)).x;
        // A wheel that does not turn gives no encoder ticks: exactly 0.
        let standing = truth.vel_mps == Vector3::zeros() && truth.omega_body_radps == Vector3::zeros();
        let speed = if standing { 0.0 } else { true_speed * (1.0 + c.scale_error) + noise * c.noise_std_mps };
        // What a calibrated odometry reports: its noise and, unless the filter
        // estimates the scale, its scale uncertainty.
        let scale_var = if c.scale_in_variance { (c.scale_error * true_speed).powi(2) } else { 0.0 };
        let var = c.noise_std_mps.powi(2) + scale_var;
        Some(Sample::Odometry(OdometrySample::new(r.t_ns, c.sensor, r.seq, speed, var)))
    }
}

/// `fusion-sim`'s flags of the wheel odometry.
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct OdometryFlags {
    /// Wheel odometry rate, Hz; 0: none.
    #[arg(long, default_value_t = 0.0)]
    pub odometry_rate: f64,
    /// Odometry speed noise, m/s.
    #[arg(long, default_value_t = 0.05)]
    pub odometry_noise: f64,
    /// Odometry relative scale error (e.g. 0.002: 0.2 % fast).
    #[arg(long, default_value_t = 0.002, allow_hyphen_values = true)]
    pub odometry_scale_error: f64,
    /// Report only the noise in the odometry's variance, not the scale error
    /// too (for a fusiond that estimates the scale: `[model.odometry_scale]`).
    #[arg(long)]
    pub odometry_noise_only_variance: bool,
    /// Odometry reference point (rear axle) in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub odometry_lever_arm: Option<Vec<f64>>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::OdometrySample {
    type Flags = OdometryFlags;

    fn apply(
        f: &OdometryFlags,
        _drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.odometry_rate <= 0.0 {
            return Ok(());
        }
        let defaults = OdometryConfig::default();
        let arm = super::flags::triple("--odometry-lever-arm", f.odometry_lever_arm.as_deref())?;
        c.aiding.push(Arc::new(OdometryConfig {
            rate_hz: f.odometry_rate,
            noise_std_mps: f.odometry_noise,
            scale_error: f.odometry_scale_error,
            scale_in_variance: !f.odometry_noise_only_variance,
            lever_arm_m: arm.unwrap_or(defaults.lever_arm_m),
            ..defaults
        }));
        Ok(())
    }
}
