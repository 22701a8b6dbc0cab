//! Runs what `fusiond run` does per IMU sample, without iceoryx2: engine insert,
//! health, and the snapshot filled in place (in a chunk that holds the previous
//! one, as a loaned chunk would). For an instruction-count profile under
//! callgrind of the daemon's own time:
//!
//! ```sh
//! cargo build --release -p fusion-benches --example daemon_steps
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out target/release/examples/daemon_steps linear 10000
//! callgrind_annotate --inclusive=yes /tmp/cg.out
//! ```

use std::hint::black_box;

use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Insert};
use fusion_daemon::health::HealthMonitor;
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_daemon::snapshot::{self, Input};
use fusion_shared::{ImuSample, Sample, StateSnapshot};

fn main() {
    let model = std::env::args().nth(1).unwrap_or_else(|| "linear".into());
    let n: u64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(10_000);
    if model == "ins" {
        let config = Config::parse(&fusion_benches::ins_config_text()).expect("valid");
        run(InsModel::from_config(&config).expect("ins"), &config, n, [0.0, 0.0, 9.80665]);
    } else {
        let config = fusion_benches::linear_config();
        run(LinearModel::from_config(&config).expect("linear"), &config, n, [0.0; 3]);
    }
}

#[inline(never)]
fn run<M: Model>(model: M, config: &Config, n: u64, accel: [f64; 3]) {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut health = HealthMonitor::new(config.health);
    let mut chunk = Box::new(StateSnapshot::default());
    let t0 = 1_000_000_000u64;
    for k in 0..n {
        let t = t0 + k * 1_000_000;
        let mut imu = ImuSample::new(t, 0, k, accel, [0.0; 3]);
        imu.header.sent_ns = t;
        let sample = Sample::Imu(imu);
        handle(&mut engine, &mut health, black_box(&mut chunk), &sample, t + 500);
    }
}

#[inline(never)]
fn handle<M: Model>(
    engine: &mut Engine<M>,
    health: &mut HealthMonitor,
    snap: &mut StateSnapshot,
    sample: &Sample,
    received_ns: u64,
) {
    let Insert::Processed { replayed, outcome } = engine.insert(sample, Some(received_ns), &mut |_| {}) else {
        return;
    };
    if let Some(slot) = engine.slot_of(sample.kind(), sample.sensor()) {
        health.record(slot, &outcome);
    }
    let initialised = engine.latest().is_some_and(|e| M::initialised(&e.state));
    let reinitialisations = engine.latest().map_or(0, |e| M::reinitialisations(&e.state));
    let now = health.evaluate(engine.sensors(), received_ns, initialised, reinitialisations);
    snapshot::fill(snap, engine, Some(Input { sample, received_ns, replayed }), now);
}
