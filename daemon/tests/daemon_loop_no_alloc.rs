//! The live daemon loop allocates nothing per sample in steady state: receive,
//! engine (in order and late), health, snapshot, publish, notify, housekeeping
//! and the event-mode wait, with real iceoryx2 services.
//!
//! `fusiond run`'s loop (`fusion_daemon::ipc::run`) runs on a thread of this test
//! binary, whose global allocator counts the allocations of that thread only
//! (the summary thread and the publishing test thread are not counted). Samples
//! go in lockstep from a client, so every sample is known to be processed.
//!
//! Publishing used to cost one allocation per snapshot: iceoryx2 0.10's
//! `ipc::Service` creates an `Rc` for every loaned chunk's shared state
//! (`port/details/chunk_mut_shared_state.rs`). fusiond's ports use
//! `fusion_shared::transport::Ipc`, which recycles that state's storage, so the
//! loop must not allocate at all; the sizes are reported when it does.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Once};
use std::time::{Duration, Instant};

use fusion_client::{Client, ImuSample, PositionSample, StateSubscriber, now_ns};
use fusion_daemon::config::Config;
use fusion_daemon::ipc::{RunOptions, WaitMode, run};
use fusion_shared::service;

struct Counting;

thread_local! {
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}
/// Sizes of the counted allocations: (size + 1, count) pairs, first come first served.
static SIZES: [(AtomicU64, AtomicU64); 8] = [const { (AtomicU64::new(0), AtomicU64::new(0)) }; 8];

fn count(size: usize) {
    // `try_with`: thread-locals may be gone while a thread exits.
    if COUNTED.try_with(Cell::get).unwrap_or(false) {
        let key = size as u64 + 1;
        for (k, n) in &SIZES {
            if k.compare_exchange(0, key, Ordering::Relaxed, Ordering::Relaxed).is_ok()
                || k.load(Ordering::Relaxed) == key
            {
                n.fetch_add(1, Ordering::Relaxed);
                return;
            }
        }
    }
}

/// The (size, count) pairs counted so far.
fn sizes() -> Vec<(u64, u64)> {
    SIZES
        .iter()
        .filter(|(k, _)| k.load(Ordering::Relaxed) != 0)
        .map(|(k, n)| (k.load(Ordering::Relaxed) - 1, n.load(Ordering::Relaxed)))
        .collect()
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// One iceoryx2 domain for this binary (the daemon reads it from the environment).
fn domain() -> String {
    static SET: Once = Once::new();
    let domain = format!("fa{}", std::process::id());
    SET.call_once(|| {
        // SAFETY: called once, before any thread of this binary reads the environment
        // (both tests pass through here before they start a daemon).
        unsafe { std::env::set_var(service::DOMAIN_ENV, &domain) };
    });
    domain
}

const LINEAR: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
    initial_covariance_diagonal = [100,100,100,10,10,10]\n[gating]\nprobability = 0.999\n";
const INS: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
    initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
    initial_covariance_diagonal = [1,1,1, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
    [gating]\nprobability = 0.999\n";

/// Waits for the snapshot of IMU sample `seq` (kind 0) or fix `seq` (kind 1);
/// returns the snapshot's own sequence number.
fn await_snapshot(reader: &mut StateSubscriber, kind: u32, seq: u64) -> u64 {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no snapshot for kind {kind} seq {seq}");
        if let Some(s) = reader.wait_next(left).unwrap()
            && s.input_kind == kind
            && s.input_seq == seq
        {
            return s.seq;
        }
    }
}

/// What the loop allocated while the measured samples went through.
struct Window {
    /// (size, count) of the allocations.
    sizes: Vec<(u64, u64)>,
    /// Snapshots published meanwhile.
    snapshots: u64,
}

/// Runs the daemon loop on a counted thread, feeds `warm` then `measured` IMU
/// samples (1 kHz sample time, a fix every 10th, every 50th fix 100 ms late) and
/// returns the allocations the loop made while the measured ones went through.
fn allocations_in_steady_state(namespace: &str, config: &str, wait: WaitMode, imu: [f64; 3]) -> Window {
    let domain = domain();
    let config = Config::parse(config).unwrap();
    let shutdown = Arc::new(AtomicBool::new(false));
    let options =
        RunOptions { namespace: namespace.to_string(), wait, summary_interval: Duration::from_millis(50), cpu: None };
    let daemon = {
        let shutdown = Arc::clone(&shutdown);
        std::thread::spawn(move || {
            COUNTED.with(|c| c.set(true));
            run(&config, &options, &shutdown)
        })
    };
    let client = {
        let started = Instant::now();
        loop {
            let client = Client::connect_in_domain(namespace, Some(&domain)).unwrap();
            if client.state_subscriber().is_ok() {
                break client;
            }
            assert!(started.elapsed() < Duration::from_secs(20), "daemon did not start");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let mut reader = client.state_subscriber_with_buffer(service::STATE_BUFFER).unwrap();
    let mut imu_pub = client.imu_publisher(0).unwrap();
    let mut pos_pub = client.position_publisher(1).unwrap();
    imu_pub.set_wake(true);
    pos_pub.set_wake(true);
    std::thread::sleep(Duration::from_millis(100));

    // Sample time starts 10 s in the past, so no timestamp is ever in the future.
    let t0 = now_ns() - 10_000_000_000;
    let (warm, measured) = (2500u64, 2500u64);
    let mut fixes = 0u64;
    let mut before = Vec::new();
    let (mut first_seq, mut last_seq) = (0, 0);
    for k in 0..(warm + measured) {
        if k == warm {
            before = sizes();
            first_seq = last_seq;
        }
        let t = t0 + k * 1_000_000;
        imu_pub.publish_sample(ImuSample { t_ns: t, seq: k, accel_mps2: imu, ..Default::default() }).unwrap();
        last_seq = await_snapshot(&mut reader, 0, k);
        if k % 10 == 5 {
            let late = if fixes % 50 == 49 { 100_000_000 } else { 0 };
            let fix = PositionSample {
                t_ns: t - late,
                seq: fixes,
                pos_m: [0.0; 3],
                cov_m2: [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64],
                ..Default::default()
            };
            pos_pub.publish_sample(fix).unwrap();
            last_seq = await_snapshot(&mut reader, 1, fixes);
            fixes += 1;
        }
        if k % 100 == 0 {
            // Idle gaps: the loop spins or sleeps on its event, and housekeeping runs.
            std::thread::sleep(Duration::from_millis(12));
        }
    }
    let after = sizes();
    shutdown.store(true, Ordering::Relaxed);
    let report = daemon.join().unwrap().unwrap();
    assert_eq!(report.received, warm + measured + fixes, "every sample reached the loop");
    let sizes = after
        .iter()
        .map(|&(size, n)| (size, n - before.iter().find(|b| b.0 == size).map_or(0, |b| b.1)))
        .filter(|&(_, n)| n > 0)
        .collect();
    Window { sizes, snapshots: last_seq - first_seq }
}

/// The loop allocated nothing while the window's snapshots went out.
fn check(w: &Window, what: &str) {
    assert!(w.snapshots >= 2750, "{what}: {} snapshots in the window", w.snapshots);
    assert!(w.sizes.is_empty(), "{what}: allocations (size, count) {:?} over {} snapshots", w.sizes, w.snapshots);
}

#[test]
fn the_daemon_loop_allocates_nothing_per_sample() {
    // One scenario after the other: the counters are per process.
    let spin = allocations_in_steady_state("alloc-spin", LINEAR, WaitMode::Spin, [0.0; 3]);
    check(&spin, "linear, spin");
    let event = allocations_in_steady_state("alloc-event", INS, WaitMode::Event, [0.0, 0.0, 9.80665]);
    check(&event, "ins, event");
    eprintln!(
        "allocations in the loop: linear spin {:?} over {} snapshots; ins event {:?} over {} snapshots",
        spin.sizes, spin.snapshots, event.sizes, event.snapshots
    );
}
