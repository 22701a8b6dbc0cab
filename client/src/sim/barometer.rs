//! Simulated barometer: the static pressure of the standard atmosphere at the
//! true height of its port, with an offset (the weather's) that drifts as a
//! random walk, white noise, random dropouts, arriving after a delay.

use fusion_shared::{SampleKind, BarometerSample, ISA_SEA_LEVEL_PA, Sample};
use nalgebra::Vector3;

use super::arrival::{Reading, Sensor, SensorSim};

/// Barometer simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BarometerConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the pressure's white noise, Pa (1 Pa ≈ 8 cm).
    pub noise_pa: f64,
    /// The pressure altitude of the world frame's origin at the start, m: the
    /// site's altitude and the weather's offset.
    pub origin_altitude_m: f64,
    /// Random-walk density of that offset, m/√s (the weather; 0: constant).
    pub drift_m: f64,
    /// The port's position in the body frame, m.
    pub lever_arm_m: [f64; 3],
    /// Probability that a sample is lost.
    pub dropout_probability: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for BarometerConfig {
    fn default() -> Self {
        Self {
            rate_hz: 20.0,
            noise_pa: 3.0,
            origin_altitude_m: 500.0,
            drift_m: 0.0,
            lever_arm_m: [0.0; 3],
            dropout_probability: 0.0,
            delay_min_ns: 5_000_000,
            delay_max_ns: 20_000_000,
            sensor: 0,
        }
    }
}

/// The standard atmosphere's pressure at pressure altitude `h`, Pa (the
/// inverse of [`fusion_shared::pressure_altitude_m`]).
pub fn isa_pressure_pa(h: f64) -> f64 {
    ISA_SEA_LEVEL_PA * (1.0 - h / 44_330.769_230_769_23).powf(1.0 / 0.190_263)
}

/// Simulated barometer samples (an endless iterator); the memory is the weather's offset, m.
pub type BarometerSim = SensorSim<BarometerConfig>;

impl Sensor for BarometerConfig {
    const KIND: SampleKind = SampleKind::Barometer;
    const SALT: u64 = 0x6261_726f;
    type Memory = f64;

    super::arrival::usual_timing!();

    fn memory(&self) -> f64 {
        self.origin_altitude_m
    }

    fn read(&self, mut r: Reading<'_, f64>) -> Option<Sample> {
        let c = self;
        let noise = r.normal();
        let walk = r.normal();
        // The weather's offset, a random walk.
        *r.memory += walk * c.drift_m / c.rate_hz.sqrt();
        if r.lost(c.dropout_probability) {
            return None;
        }
        let port = r.truth.pos_m + r.truth.attitude * Vector3::from(c.lever_arm_m);
        let pressure = isa_pressure_pa(*r.memory + port.z) + noise * c.noise_pa;
        Some(Sample::Barometer(BarometerSample::new(r.t_ns, c.sensor, r.seq, pressure, c.noise_pa * c.noise_pa)))
    }
}



/// `fusion-sim`'s flags of the barometer.
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct BarometerFlags {
    /// Barometer rate, Hz; 0: none (sensor id 0; `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    pub barometer_rate: f64,
    /// Barometer noise, Pa (1 Pa is about 8 cm of height).
    #[arg(long, default_value_t = 3.0)]
    pub barometer_noise_pa: f64,
    /// The barometer's port in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub barometer_lever_arm: Option<Vec<f64>>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::BarometerSample {
    type Flags = BarometerFlags;

    fn apply(
        f: &BarometerFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.barometer_rate <= 0.0 {
            return Ok(());
        }
        let arm = super::flags::triple("--barometer-lever-arm", f.barometer_lever_arm.as_deref())?;
        c.aiding.push(Arc::new(BarometerConfig {
            rate_hz: f.barometer_rate,
            noise_pa: f.barometer_noise_pa,
            lever_arm_m: arm.unwrap_or([0.0; 3]),
            dropout_probability: drive.dropouts,
            ..Default::default()
        }));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::CarTrajectory;

    /// Without noise the pressure altitude of a sample is the port's height
    /// plus the origin's altitude.
    #[test]
    fn it_reads_the_height_of_its_port() {
        let trajectory = CarTrajectory::new(4);
        let arm = Vector3::new(0.2, 0.0, 0.5);
        let c = BarometerConfig { noise_pa: 0.0, lever_arm_m: arm.into(), ..Default::default() };
        for a in BarometerSim::new(trajectory.clone(), c, 0, 1).take(50) {
            let Sample::Barometer(s) = a.sample else { panic!() };
            let truth = trajectory.at(s.header.t_ns as f64 * 1e-9);
            let h = fusion_shared::pressure_altitude_m(s.pressure_pa);
            let port = truth.pos_m.z + (truth.attitude * arm).z;
            assert!((h - 500.0 - port).abs() < 1e-6, "{h} vs {port}");
        }
    }
}
