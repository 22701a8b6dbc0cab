//! Allocations of fusiond's live loop per processed sample, in steady state:
//! receive, engine (in order and late), health, snapshot, publish, notify,
//! housekeeping and the wait, with real iceoryx2 services.
//!
//! The loop (`fusion_daemon::ipc::run`, what `fusiond run` runs) runs on a
//! thread of the calling binary, whose global allocator must be [`Counting`]:
//! it counts the allocations of that thread only (not the summary thread's, not
//! the publishing client's). Samples go in lockstep from a client, so every
//! sample is known to be processed when the window closes. Used by the latency
//! bench (its allocation row) and by `benches/tests/daemon_loop_no_alloc.rs`.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use fusion_client::{Client, ImuSample, PositionSample, SampleKind, StateSubscriber, VelocitySample, now_ns};
use fusion_daemon::config::Config;
use fusion_daemon::ipc::{RunOptions, WaitMode, run};
use fusion_shared::service;

/// A global allocator (the system's) that counts, by size, the allocations of
/// the threads that asked for it ([`count_this_thread`]).
pub struct Counting;

thread_local! {
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

/// Counted allocations: (size + 1, count) pairs, first come first served.
static SIZES: [(AtomicU64, AtomicU64); 8] = [const { (AtomicU64::new(0), AtomicU64::new(0)) }; 8];
/// Counted allocations of sizes beyond the 8 kept.
static OTHER: AtomicU64 = AtomicU64::new(0);

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
        OTHER.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: every call is passed on to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Counts the calling thread's allocations from now on (if the binary's global
/// allocator is [`Counting`]).
pub fn count_this_thread() {
    COUNTED.with(|c| c.set(true));
}

/// The (size, count) pairs counted so far; size `u64::MAX` stands for any
/// size beyond the eight tracked.
pub fn sizes() -> Vec<(u64, u64)> {
    let mut out: Vec<(u64, u64)> = SIZES
        .iter()
        .filter(|(k, _)| k.load(Ordering::Relaxed) != 0)
        .map(|(k, n)| (k.load(Ordering::Relaxed) - 1, n.load(Ordering::Relaxed)))
        .collect();
    let other = OTHER.load(Ordering::Relaxed);
    if other > 0 {
        out.push((u64::MAX, other));
    }
    out
}

/// What the loop allocated while the measured samples went through.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Window {
    /// (size, count) of the allocations, by size.
    pub sizes: Vec<(u64, u64)>,
    /// Samples (IMU, position and velocity) processed in the window.
    pub samples: u64,
    /// Snapshots published in the window.
    pub snapshots: u64,
}

impl Window {
    /// Allocations in the window.
    pub fn allocations(&self) -> u64 {
        self.sizes.iter().map(|s| s.1).sum()
    }
}

/// What [`steady_state`] runs.
#[derive(Debug, Clone)]
pub struct Scenario<'a> {
    /// Namespace of the services (unique per run).
    pub namespace: &'a str,
    /// fusiond config (TOML).
    pub config: &'a str,
    /// The loop's wait mode.
    pub wait: WaitMode,
    /// Specific force of every IMU sample (at rest).
    pub accel_mps2: [f64; 3],
    /// iceoryx2 domain of the client (the loop reads `FUSION_DOMAIN` itself);
    /// `None`: the default.
    pub domain: Option<&'a str>,
    /// IMU samples before the window and in it.
    pub warm: u64,
    /// IMU samples in the window.
    pub measured: u64,
    /// Also a second IMU (sensor 1, at rest along +z) at every instant, a
    /// geodetic fix (sensor 3) with every 10th and odometry (sensor 0) with every
    /// 20th: the sensor set of `VEHICLE_CONFIG`.
    pub vehicle: bool,
    /// Also the largest state's barometer and poses
    /// ([`crate::latency::vehicle21_extras`], for `VEHICLE21_CONFIG`).
    pub extras: bool,
}

/// Runs the daemon loop on a counted thread, feeds `warm` then `measured` IMU
/// samples (1 kHz sample time, a fix every 10th, every 50th fix 100 ms late,
/// an idle gap of 12 ms every 100th so the loop waits and does its
/// housekeeping) and returns what the loop allocated while the measured ones
/// went through.
pub fn steady_state(s: &Scenario<'_>) -> anyhow::Result<Window> {
    let config = Config::parse(s.config).context("config")?;
    let shutdown = Arc::new(AtomicBool::new(false));
    let options = RunOptions {
        namespace: s.namespace.to_string(),
        wait: s.wait,
        summary_interval: Duration::from_millis(50),
        cpu: None,
        stall: None,
        config_text: Some(s.config.to_string()),
    };
    let daemon = {
        let shutdown = Arc::clone(&shutdown);
        std::thread::spawn(move || {
            count_this_thread();
            run(&config, &options, &shutdown)
        })
    };
    let fed = feed(s);
    shutdown.store(true, Ordering::Relaxed);
    let report = daemon.join().map_err(|_| anyhow::anyhow!("the daemon loop panicked"))??;
    let (before, after, window_snapshots, fed_samples, window_samples) = fed?;
    anyhow::ensure!(report.received == fed_samples, "{} samples fed, {} received", fed_samples, report.received);
    let sizes = after
        .iter()
        .map(|&(size, n)| (size, n - before.iter().find(|b| b.0 == size).map_or(0, |b| b.1)))
        .filter(|&(_, n)| n > 0)
        .collect();
    Ok(Window { sizes, samples: window_samples, snapshots: window_snapshots })
}

/// The client side of [`steady_state`]: counts before and after the window,
/// snapshots in it, samples fed in all, samples fed in the window.
type Fed = (Vec<(u64, u64)>, Vec<(u64, u64)>, u64, u64, u64);

fn feed(s: &Scenario<'_>) -> anyhow::Result<Fed> {
    let client = {
        let started = Instant::now();
        loop {
            let client = Client::connect_in_domain(s.namespace, s.domain)?;
            if client.state_subscriber().is_ok() {
                break client;
            }
            anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "the daemon loop did not start");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let mut reader = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    let mut imu_pub = client.imu_publisher(0)?;
    let mut pos_pub = client.position_publisher(1)?;
    let mut vel_pub = client.publisher::<fusion_client::VelocitySample>(2)?;
    let mut imu_b = client.imu_publisher(1)?;
    let mut geo_pub = client.publisher::<fusion_shared::GeodeticSample>(3)?;
    let mut odo_pub = client.publisher::<fusion_shared::OdometrySample>(0)?;
    let mut baro_pub = client.publisher::<fusion_shared::BarometerSample>(0)?;
    let mut pose_pub = client.publisher::<fusion_shared::PoseSample>(0)?;
    baro_pub.set_wake(true);
    pose_pub.set_wake(true);
    imu_pub.set_wake(true);
    pos_pub.set_wake(true);
    vel_pub.set_wake(true);
    imu_b.set_wake(true);
    geo_pub.set_wake(true);
    odo_pub.set_wake(true);
    let mut extra = 0u64;
    std::thread::sleep(Duration::from_millis(100));

    // Sample time starts 1 s in the past and is held back to the clock, so no
    // timestamp is ever in the future (nor older than `validation.max_past_ns`).
    let t0 = now_ns() - 1_000_000_000;
    let mut fixes = 0u64;
    let mut before = Vec::new();
    let (mut first_seq, mut last_seq) = (0, 0);
    let mut fed_before_window = 0;
    for k in 0..(s.warm + s.measured) {
        if k == s.warm {
            before = sizes();
            first_seq = last_seq;
            fed_before_window = k + 2 * fixes + extra;
        }
        let t = t0 + k * 1_000_000;
        while now_ns() < t {
            std::thread::sleep(Duration::from_micros(200));
        }
        imu_pub.publish_sample(ImuSample::new(t, 0, k, s.accel_mps2, [0.0; 3]))?;
        if s.vehicle {
            // Both IMUs of the instant, then its snapshot (after the sample
            // that completes it, whichever fusiond took last).
            imu_b.publish_sample(ImuSample::new(t, 1, k, [0.0, 0.0, 9.80665], [0.0; 3]))?;
            last_seq = await_snapshot(&mut reader, SampleKind::Imu as u32, k)?;
            extra += 1;
            if k % 10 == 3 {
                let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
                geo_pub.publish_sample(fusion_shared::GeodeticSample::new(
                    t,
                    3,
                    k / 10,
                    48.1316,
                    11.5494,
                    519.0,
                    cov,
                ))?;
                last_seq = await_snapshot(&mut reader, SampleKind::Geodetic as u32, k / 10)?;
                extra += 1;
            }
            if k % 20 == 7 {
                odo_pub.publish_sample(fusion_shared::OdometrySample::new(t, 0, k / 20, 0.0, 0.01))?;
                last_seq = await_snapshot(&mut reader, SampleKind::Odometry as u32, k / 20)?;
                extra += 1;
            }
        } else {
            last_seq = await_snapshot(&mut reader, SampleKind::Imu as u32, k)?;
        }
        if let Some(sample) = crate::latency::vehicle21_extras(t, k).filter(|_| s.extras) {
            match sample {
                fusion_shared::Sample::Barometer(b) => baro_pub.publish_sample(b)?,
                fusion_shared::Sample::Pose(p) => pose_pub.publish_sample(p)?,
                other => anyhow::bail!("no publisher for a {} sample", other.kind().name()),
            };
            last_seq = await_snapshot(&mut reader, sample.kind() as u32, sample.header().seq)?;
            extra += 1;
        }
        if k % 10 == 5 {
            let late = if fixes % 50 == 49 { 100_000_000 } else { 0 };
            let fix =
                PositionSample::new(t - late, 1, fixes, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64]);
            pos_pub.publish_sample(fix)?;
            await_snapshot(&mut reader, SampleKind::Position as u32, fixes)?;
            // A GNSS velocity with every fix (the vehicle at rest).
            let vel =
                VelocitySample::new(t - late, 2, fixes, [0.0; 3], [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04]);
            vel_pub.publish_sample(vel)?;
            last_seq = await_snapshot(&mut reader, SampleKind::Velocity as u32, fixes)?;
            fixes += 1;
        }
        if k % 100 == 0 {
            // Idle gaps: the loop spins or sleeps on its event, and housekeeping runs.
            std::thread::sleep(Duration::from_millis(12));
        }
    }
    let fed = s.warm + s.measured + 2 * fixes + extra;
    Ok((before, sizes(), last_seq - first_seq, fed, fed - fed_before_window))
}

/// Waits for the snapshot of the sample of kind code `kind` with sequence number `seq`;
/// returns the snapshot's own sequence number.
fn await_snapshot(reader: &mut StateSubscriber, kind: u32, seq: u64) -> anyhow::Result<u64> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        anyhow::ensure!(!left.is_zero(), "no snapshot for kind {kind} seq {seq}");
        if let Some(snap) = reader.wait_next(left)?
            && snap.input_kind == kind
            && snap.input_seq == seq
        {
            return Ok(snap.seq);
        }
    }
}
