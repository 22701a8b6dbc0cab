//! The engine allocates nothing per sample in steady state, in order or late.
//!
//! The counting allocator of [`fusion_benches::alloc`] counts every allocation
//! made on this thread while samples are inserted after a warm-up.

use fusion_benches::alloc::{Counting, count_this_thread, sizes};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry, Insert};
use fusion_daemon::model::linear::LinearModel;

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steady_state_insertion_allocates_nothing() {
    let mut c = ScenarioConfig { seed: 2, duration_s: 10.0, ..Default::default() };
    c.imu.rate_hz = 1000.0;
    c.position.outlier_probability = 0.05;
    let samples: Vec<_> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let text = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
                initial_covariance_diagonal = [100,100,100,225,225,225]\n[gating]\nprobability = 0.999\n";
    let config = Config::parse(text).unwrap();
    let mut engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let mut finals = 0u64;
    let mut sink = |_: &Entry<_>| finals += 1;

    // Warm-up: two seconds fill the 1 s history and every sensor slot.
    let (warm, rest) = samples.split_at(samples.len() / 5);
    for s in warm {
        engine.insert(s, None, &mut sink);
    }
    count_this_thread();
    let before = sizes();
    let mut late = 0;
    for s in rest {
        if let Insert::Processed { replayed, .. } = engine.insert(s, Some(s.header().t_ns), &mut sink) {
            late += (replayed > 0) as u64;
        }
    }
    let after = sizes();
    assert!(late > 50, "the measured stretch must include late samples (rewinds), had {late}");
    assert!(finals > 5000);
    assert_eq!(after, before, "allocations (size, count) while inserting {} samples", rest.len());
}
