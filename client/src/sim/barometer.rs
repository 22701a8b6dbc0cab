//! Simulated barometer: the static pressure of the standard atmosphere at the
//! true height of its port, with an offset (the weather's) that drifts as a
//! random walk, white noise, random dropouts, arriving after a delay.

use fusion_shared::{BarometerSample, ISA_SEA_LEVEL_PA, Sample};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::arrival::{Arrival, schedule};
use super::trajectory::CarTrajectory;

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

/// Simulated barometer samples (an endless iterator).
#[derive(Debug, Clone)]
pub struct BarometerSim {
    trajectory: CarTrajectory,
    config: BarometerConfig,
    start_ns: u64,
    index: u64,
    offset_m: f64,
    rng: ChaCha8Rng,
}

impl BarometerSim {
    /// Samples on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: BarometerConfig, start_ns: u64, seed: u64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6261_726f ^ (u64::from(config.sensor) << 40));
        let offset_m = config.origin_altitude_m;
        Self { trajectory, config, start_ns, index: 0, offset_m, rng }
    }
}

impl Iterator for BarometerSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        loop {
            let c = &self.config;
            let (offset_ns, delay) = schedule(&mut self.rng, self.index, c.rate_hz, c.delay_min_ns, c.delay_max_ns);
            let noise: f64 = StandardNormal.sample(&mut self.rng);
            let walk: f64 = StandardNormal.sample(&mut self.rng);
            self.offset_m += walk * c.drift_m / c.rate_hz.sqrt();
            let lost = self.rng.random::<f64>() < c.dropout_probability;
            let seq = self.index;
            self.index += 1;
            if lost {
                continue;
            }
            let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
            let port = truth.pos_m + truth.attitude * Vector3::from(c.lever_arm_m);
            let pressure = isa_pressure_pa(self.offset_m + port.z) + noise * c.noise_pa;
            let t_ns = self.start_ns + offset_ns;
            let sample = BarometerSample::new(t_ns, c.sensor, seq, pressure, c.noise_pa * c.noise_pa);
            return Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Barometer(sample), outlier: false });
        }
    }
}

super::aiding_sim!(BarometerConfig, BarometerSim, Barometer);

#[cfg(test)]
mod tests {
    use super::*;

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
