//! fusion-benches: benchmarks of fusiond.
//!
//! - `benches/filter.rs` (criterion): filter steps and replay throughput.
//! - `benches/latency.rs`: end-to-end latency beside raw iceoryx2 ([`latency`]), and
//!   the live loop's allocations per sample ([`alloc`]).
//!
//! Run with `cargo bench -p fusion-benches`.

pub mod alloc;
pub mod latency;
pub mod precision;

use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::config::Config;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::{ImuSample, PositionSample, Sample};

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

/// The `ins` model of the filter-step benchmarks: Kalibr MEMS noise, moving at
/// 9 m/s, gating on.
pub fn ins_model() -> InsModel {
    let config = Config::parse(&ins_config_text()).expect("benchmark config is valid");
    InsModel::from_config(&config).expect("benchmark config is an ins config")
}

/// The config text of [`ins_model`].
pub fn ins_config_text() -> String {
    String::from(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
         initial_state = [0,0,0, 9,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
         initial_covariance_diagonal = [1,1,1, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
         [gating]\nprobability = 0.999\n",
    )
}

/// An IMU sample at `t_ns` for [`ins_model`]: specific force near gravity, a slow turn.
pub fn ins_imu(t_ns: u64) -> Sample {
    Sample::Imu(ImuSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t_ns, 0, 0),
        accel_mps2: [0.3, 0.1, 9.81],
        gyro_radps: [0.01, -0.02, 0.2],
    })
}

/// A position fix at `t_ns` for [`ins_model`], 4.5 cm off the start.
pub fn ins_fix(t_ns: u64) -> Sample {
    Sample::Position(PositionSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t_ns, 0, 0),
        pos_m: [0.045, 0.0, 0.0],
        cov_m2: [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64],
    })
}
