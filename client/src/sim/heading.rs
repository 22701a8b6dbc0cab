//! Simulated heading (a dual-antenna GNSS receiver): the true yaw plus white
//! noise, wrapped into (−π, π], arriving after a delay.

use std::f64::consts::PI;

use fusion_shared::{SampleKind, HeadingSample, Sample};

use super::arrival::{Reading, Sensor, SensorSim};

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
pub type HeadingSim = SensorSim<HeadingConfig>;

impl Sensor for HeadingConfig {
    const KIND: SampleKind = SampleKind::Heading;
    const SALT: u64 = 0x6864_6700;
    type Memory = ();

    super::arrival::usual_timing!();

    fn read(&self, mut r: Reading<'_, ()>) -> Option<Sample> {
        let c = self;
        let noise = r.normal();
        let mut yaw = r.truth.yaw_rad() + noise * c.noise_std_rad;
        if yaw > PI {
            yaw -= 2.0 * PI;
        } else if yaw <= -PI {
            yaw += 2.0 * PI;
        }
        Some(Sample::Heading(HeadingSample::new(r.t_ns, c.sensor, r.seq, yaw, c.noise_std_rad.powi(2))))
    }
}

/// `fusion-sim`'s flags of the heading (dual-antenna GNSS).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct HeadingFlags {
    /// Heading (dual-antenna GNSS) rate, Hz; 0: none.
    #[arg(long, default_value_t = 0.0)]
    pub heading_rate: f64,
    /// Heading noise, degrees.
    #[arg(long, default_value_t = 0.5)]
    pub heading_noise_deg: f64,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::HeadingSample {
    type Flags = HeadingFlags;

    fn apply(
        f: &HeadingFlags,
        _drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.heading_rate > 0.0 {
            c.aiding.push(Arc::new(HeadingConfig {
                rate_hz: f.heading_rate,
                noise_std_rad: f.heading_noise_deg.to_radians(),
                ..Default::default()
            }));
        }
        Ok(())
    }
}
