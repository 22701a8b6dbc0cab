//! The engine allocates nothing per sample in steady state, in order or late.
//!
//! A counting global allocator (this test binary only) counts every allocation
//! made on this thread while samples are inserted after a warm-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry, Insert};
use fusion_daemon::model::linear::LinearModel;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

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
    let before = ALLOCATIONS.with(Cell::get);
    let mut late = 0;
    for s in rest {
        if let Insert::Processed { replayed, .. } = engine.insert(s, Some(u64::MAX / 2), &mut sink) {
            late += (replayed > 0) as u64;
        }
    }
    let allocations = ALLOCATIONS.with(Cell::get) - before;
    assert!(late > 50, "the measured stretch must include late samples (rewinds), had {late}");
    assert!(finals > 5000);
    assert_eq!(allocations, 0, "allocations while inserting {} samples", rest.len());
}
