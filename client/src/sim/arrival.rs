//! A sample with the time it reaches the daemon, and the draws every
//! simulated sensor makes: its schedule (when a sample is valid, how late it
//! is published) and its Gaussian noise.

use fusion_shared::Sample;
use nalgebra::Vector3;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

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

/// A standard normal 3-vector.
pub(crate) fn gaussian3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(StandardNormal.sample(rng), StandardNormal.sample(rng), StandardNormal.sample(rng))
}

/// When the `index`th sample of a sensor at `rate_hz` is valid (ns after the
/// start) and how long after that it is published (uniform in [min, max] ns,
/// drawn from `rng`).
pub(crate) fn schedule(
    rng: &mut ChaCha8Rng,
    index: u64,
    rate_hz: f64,
    delay_min_ns: u64,
    delay_max_ns: u64,
) -> (u64, u64) {
    let offset_ns = to_ns(index as f64 / rate_hz);
    (offset_ns, rng.random_range(delay_min_ns..=delay_max_ns.max(delay_min_ns)))
}

/// Seconds to ns, rounded.
pub(crate) fn to_ns(t_s: f64) -> u64 {
    (t_s * 1e9).round() as u64
}

/// A simulated sensor whose samples come at its rate, each published after
/// a delay and drawn from the sensor's own noise stream: what one sample
/// reads. [`SensorSim`] makes the endless stream of them.
pub trait Sensor: Clone {
    /// The kind of its samples.
    const KIND: fusion_shared::SampleKind;
    /// The salt of its noise stream (with its sensor id: adding a sensor
    /// leaves every other's samples unchanged).
    const SALT: u64;
    /// What the sensor carries from one sample to the next (a barometer's
    /// drifting offset); `()` for most.
    type Memory: Clone + std::fmt::Debug + Default;
    /// Its sensor id.
    fn sensor(&self) -> u32;
    /// Its rate, Hz, and the least and most delay of its samples, ns.
    fn timing(&self) -> (f64, u64, u64);
    /// What it carries before its first sample (the memory's default by default).
    fn memory(&self) -> Self::Memory {
        Self::Memory::default()
    }
    /// The sample `r` is of (its draws after the schedule's), or `None` when
    /// it is lost (dropped).
    fn read(&self, r: Reading<'_, Self::Memory>) -> Option<Sample>;
}

/// One sample's moment: the truth then, the stream's draws, the sample's
/// sequence number and stamp, and the sensor's memory.
pub struct Reading<'a, M> {
    /// The truth at the sample's time.
    pub truth: &'a crate::sim::TruthState,
    /// Its time, s of trajectory time.
    pub t_s: f64,
    /// Its stamp, ns.
    pub t_ns: u64,
    /// Its sequence number (lost ones included).
    pub seq: u64,
    /// The sensor's noise stream.
    pub rng: &'a mut ChaCha8Rng,
    /// What the sensor carries from sample to sample.
    pub memory: &'a mut M,
}

impl<M> Reading<'_, M> {
    /// A standard normal 3-vector from the sensor's stream.
    pub fn normal3(&mut self) -> Vector3<f64> {
        Vector3::from_fn(|_, _| StandardNormal.sample(&mut *self.rng))
    }

    /// A standard normal number from the sensor's stream.
    pub fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut *self.rng)
    }

    /// Whether the sample is lost, with `probability` (one draw, lost or not).
    pub fn lost(&mut self, probability: f64) -> bool {
        self.rng.random::<f64>() < probability
    }
}

/// The samples of a [`Sensor`] on a trajectory (an endless iterator; lost
/// samples are skipped, their sequence numbers with them).
#[derive(Debug, Clone)]
pub struct SensorSim<C: Sensor> {
    trajectory: crate::sim::CarTrajectory,
    config: C,
    memory: C::Memory,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
}

impl<C: Sensor> SensorSim<C> {
    /// Samples on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: crate::sim::CarTrajectory, config: C, start_ns: u64, seed: u64) -> Self {
        use rand::SeedableRng;
        let rng = ChaCha8Rng::seed_from_u64(seed ^ C::SALT ^ (u64::from(config.sensor()) << 40));
        let memory = config.memory();
        Self { trajectory, config, memory, start_ns, index: 0, rng }
    }
}

impl<C: Sensor> Iterator for SensorSim<C> {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let (rate_hz, delay_min_ns, delay_max_ns) = self.config.timing();
        loop {
            let (offset_ns, delay) = schedule(&mut self.rng, self.index, rate_hz, delay_min_ns, delay_max_ns);
            let seq = self.index;
            self.index += 1;
            let t_s = offset_ns as f64 * 1e-9;
            let truth = self.trajectory.at(t_s);
            let t_ns = self.start_ns + offset_ns;
            let r = Reading { truth: &truth, t_s, t_ns, seq, rng: &mut self.rng, memory: &mut self.memory };
            if let Some(sample) = self.config.read(r) {
                return Some(Arrival { arrival_ns: t_ns + delay, sample, outlier: false });
            }
        }
    }
}

/// A [`Sensor`]'s `sensor` and `timing` from the usual fields of its settings
/// (`sensor`, `rate_hz`, `delay_min_ns`, `delay_max_ns`).
macro_rules! usual_timing {
    () => {
        fn sensor(&self) -> u32 {
            self.sensor
        }

        fn timing(&self) -> (f64, u64, u64) {
            (self.rate_hz, self.delay_min_ns, self.delay_max_ns)
        }
    };
}
pub(crate) use usual_timing;
