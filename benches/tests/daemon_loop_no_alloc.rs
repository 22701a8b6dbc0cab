//! The live daemon loop allocates nothing per sample in steady state: receive,
//! engine (in order and late), health, snapshot, publish, notify, housekeeping
//! and the event-mode wait, with real iceoryx2 services
//! ([`fusion_benches::alloc`] runs `fusiond run`'s loop on a counted thread).
//!
//! Publishing used to cost one allocation per snapshot: iceoryx2 0.10's
//! `ipc::Service` creates an `Rc` for every loaned chunk's shared state
//! (`port/details/chunk_mut_shared_state.rs`). fusiond's ports use
//! `fusion_shared::transport::Ipc`, which recycles that state's storage, so the
//! loop must not allocate at all; the sizes are reported when it does.

use std::sync::Once;

#[path = "../../daemon/tests/common/heartbeat.rs"]
mod heartbeat;

use fusion_benches::alloc::{Counting, Scenario, Window, count_this_thread, sizes, steady_state};
use fusion_benches::latency::{INS_CONFIG, LINEAR_CONFIG, VEHICLE_CONFIG, VEHICLE_IMUS_AT_REST, VEHICLE21_CONFIG};
use fusion_daemon::ipc::WaitMode;
use fusion_shared::service;

#[global_allocator]
static GLOBAL: Counting = Counting;

/// One iceoryx2 domain for this binary (the daemon loop reads it from the environment).
fn domain() -> String {
    static SET: Once = Once::new();
    let domain = format!("fa{}", std::process::id());
    SET.call_once(|| {
        // SAFETY: called once, before any thread of this binary reads the environment
        // (the test passes through here before it starts a daemon loop).
        unsafe { std::env::set_var(service::DOMAIN_ENV, &domain) };
    });
    domain
}

/// The loop allocated nothing while the window's snapshots went out.
fn check(w: &Window, what: &str) {
    assert!(w.snapshots >= 2750, "{what}: {} snapshots in the window", w.snapshots);
    assert!(w.sizes.is_empty(), "{what}: allocations (size, count) {:?} over {} snapshots", w.sizes, w.snapshots);
}

#[test]
fn the_daemon_loop_allocates_nothing_per_sample() {
    let _beat = heartbeat::Heartbeat::start("daemon loop allocations", std::time::Duration::from_secs(15));
    let domain = domain();
    let scenario = |namespace, config, wait, accel_mps2| Scenario {
        namespace,
        config,
        wait,
        accel_mps2,
        domain: Some(&domain),
        warm: 2500,
        measured: 2500,
        vehicle: false,
        extras: false,
    };
    // The counter sees a counted thread's allocation (then it is left out of the
    // windows below, which count differences).
    std::thread::spawn(|| {
        count_this_thread();
        std::hint::black_box(vec![0u8; 4321]);
    })
    .join()
    .unwrap();
    assert!(sizes().contains(&(4321, 1)), "{:?}", sizes());
    // One scenario after the other: the counters are per process.
    let spin = steady_state(&scenario("alloc-spin", LINEAR_CONFIG, WaitMode::Spin, [0.0; 3])).unwrap();
    check(&spin, "linear, spin");
    let event = steady_state(&scenario("alloc-event", INS_CONFIG, WaitMode::Event, [0.0, 0.0, 9.80665])).unwrap();
    check(&event, "ins, event");
    // Two IMUs averaged, geodetic fixes with a lever arm, odometry.
    let vehicle = Scenario {
        vehicle: true,
        ..scenario("alloc-vehicle", VEHICLE_CONFIG, WaitMode::Spin, VEHICLE_IMUS_AT_REST[0])
    };
    let vehicle = steady_state(&vehicle).unwrap();
    check(&vehicle, "vehicle, spin");
    // One snapshot per IMU instant: about one fewer than samples an instant.
    assert!(
        vehicle.samples >= vehicle.snapshots + 2400,
        "{} snapshots for {} samples",
        vehicle.snapshots,
        vehicle.samples
    );
    // The largest state (21 error states): a barometer's bias and a pose
    // sensor's map frame set from their first samples, then fused.
    let largest = Scenario {
        vehicle: true,
        extras: true,
        ..scenario("alloc-vehicle21", VEHICLE21_CONFIG, WaitMode::Event, VEHICLE_IMUS_AT_REST[0])
    };
    let largest = steady_state(&largest).unwrap();
    check(&largest, "vehicle with 21 states, event");
    eprintln!(
        "allocations in the loop: linear spin {:?} over {} snapshots; ins event {:?} over {} snapshots; \
         vehicle spin {:?} over {} snapshots; 21 states event {:?} over {} snapshots",
        spin.sizes,
        spin.snapshots,
        event.sizes,
        event.snapshots,
        vehicle.sizes,
        vehicle.snapshots,
        largest.sizes,
        largest.snapshots
    );
}
