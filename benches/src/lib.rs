//! fusion-benches: benchmarks of fusiond.
//!
//! - `benches/filter.rs` (criterion): filter steps and replay throughput.
//! - `benches/latency.rs`: end-to-end latency beside raw iceoryx2 ([`latency`]).
//!
//! Run with `cargo bench -p fusion-benches`.

pub mod latency;

use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::config::Config;

/// The drive used by the throughput benchmarks: 1 kHz IMU, 10 Hz positions arriving
/// 20–120 ms late, `seconds` long.
pub fn bench_drive(seconds: f64) -> Scenario {
    let mut c = ScenarioConfig { seed: 7, duration_s: seconds, ..Default::default() };
    c.imu.rate_hz = 1000.0;
    c.imu.jitter_ns = 100_000;
    Scenario::generate(&c)
}

/// The linear-model config of the benchmarks (gating on).
pub fn linear_config() -> Config {
    Config::parse(
        "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
         initial_covariance_diagonal = [100,100,100,225,225,225]\n[gating]\nprobability = 0.999\n",
    )
    .expect("benchmark config is valid")
}
