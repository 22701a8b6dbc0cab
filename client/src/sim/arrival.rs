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
