//! Latency of fusiond beside the floor set by raw iceoryx2, measured in one run,
//! with late-data cost, throughput and the daemon loop's allocations per sample:
//! tables on stdout and `target/fusion-bench/latency.json` (numbers in ns).
//! `FUSION_BENCH_QUICK=1` takes a short sample; `FUSION_BENCH_IMU_HZ` sets the IMU
//! rate of the end-to-end rows (default 1000); `FUSION_BENCH_SAMPLES` the samples per
//! latency row (default 10 000, quick 1 000); `FUSION_BENCH_FUSIOND=PATH` runs that
//! fusiond binary instead of building one; `FUSION_BENCH_ONLY=late,e2e` runs only
//! the sections named (of `e2e`, `late`, `throughput`, `alloc`, `record`) after
//! the raw floor. See docs/performance.md.

#![allow(missing_docs)]

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::Context;
use fusion_benches::alloc::{Counting, Scenario, Window, steady_state};
use fusion_benches::latency::pingpong::RawRelay;
use fusion_benches::latency::{
    ChildGuard, EndToEnd, INS_CONFIG, LINEAR_CONFIG, LateCost, Mode, Pinger, Prober, PublisherPlan, Trial,
    VEHICLE_CONFIG, VEHICLE_IMUS_AT_REST, VEHICLE_LATE_CONFIG, VEHICLE21_CONFIG, fan_out_reader, histogram, late_data,
    ping, pong, publisher, raw_throughput, start_daemon, throughput,
};
use fusion_client::{Client, ImuSample, StateSnapshot};
use fusion_daemon::ipc::WaitMode;
use hdrhistogram::Histogram;
use iceoryx2::service::port_factory::PortFactory as _;
use report::{Row, print_report};

#[path = "latency/report.rs"]
mod report;

/// Counts the allocations of the daemon loop run in this process (section 6).
#[global_allocator]
static GLOBAL: Counting = Counting;

/// The IMU values each model is fed: at rest (linear: a small world acceleration;
/// ins: gravity along body z).
fn imu_value(model: &str) -> ([f64; 3], [f64; 3]) {
    if model == "ins" { ([0.0, 0.0, 9.80665], [0.0; 3]) } else { ([0.0; 3], [0.0; 3]) }
}

/// The config of a row set: `linear`, `ins`, `vehicle` (`ins` with two IMUs,
/// geodetic GNSS with a lever arm and odometry) or `vehicle-late` (the same with
/// GNSS velocity, the GNSS samples 80–120 ms late and the odometry 10–30 ms),
/// `vehicle21` (the largest state: the vehicle set with the odometry scale, a
/// barometer and a pose sensor's estimated map frame, 21 error states);
/// `vehicle-receipt` is `vehicle` with the IMU samples stamped on receipt
/// ([`Prober::stamped_on_receipt`]).
fn config_of(model: &str) -> &'static str {
    match model {
        "ins" => INS_CONFIG,
        "vehicle" | "vehicle-receipt" => VEHICLE_CONFIG,
        "vehicle-late" => VEHICLE_LATE_CONFIG,
        "vehicle21" => VEHICLE21_CONFIG,
        _ => LINEAR_CONFIG,
    }
}

/// A running daemon and a connected client, torn down (process and its files)
/// when dropped, also on error.
struct Rig {
    client: Client,
    daemon: ChildGuard,
    config_path: PathBuf,
}

impl Drop for Rig {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.config_path);
    }
}

fn start_rig(fusiond: &std::path::Path, namespace: &str, model: &str, mode: Mode) -> anyhow::Result<Rig> {
    start_rig_with(fusiond, namespace, config_of(model), mode)
}

/// The throughput rows measure what the daemon can take: without the per-sensor
/// rate limit, which would drop (cheaply) most of a 100 kHz sensor's samples.
const UNLIMITED_RATE: &str = "[validation]\nmax_rate_hz = 1.0e9\nmax_burst = 1_000_000\n";

fn start_rig_with(fusiond: &std::path::Path, namespace: &str, config: &str, mode: Mode) -> anyhow::Result<Rig> {
    let dir = std::env::temp_dir();
    let daemon = start_daemon(fusiond, &dir, config, namespace, mode)?;
    let config_path = dir.join(format!("{namespace}.toml"));
    let client = Client::connect(namespace)?;
    let started = Instant::now();
    while client.state_subscriber().is_err() {
        anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "fusiond did not start");
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(Rig { client, daemon, config_path })
}

/// Starts this binary as the pong side of a raw ping-pong on `base`, answering with
/// an `ImuSample` or (`snapshot`) a `StateSnapshot`.
fn spawn_pong(base: &str, mode: Mode, snapshot: bool) -> anyhow::Result<ChildGuard> {
    spawn_pong_as(base, mode, if snapshot { "snapshot" } else { "imu" })
}

/// [`spawn_pong`] with its payload named: `imu`, `snapshot`, or `relay` (a
/// snapshot, with fusiond's buffers: the throughput floor).
fn spawn_pong_as(base: &str, mode: Mode, payload: &str) -> anyhow::Result<ChildGuard> {
    let child = Command::new(std::env::current_exe()?)
        .env("FUSION_BENCH_PONG", base)
        .env("FUSION_BENCH_MODE", mode.name())
        .env("FUSION_BENCH_PONG_PAYLOAD", payload)
        .stdout(Stdio::null())
        .spawn()?;
    Ok(ChildGuard(child))
}

/// Starts this binary as the publisher process of `plan` into `namespace`.
fn spawn_publisher(namespace: &str, model: &str, plan: PublisherPlan) -> anyhow::Result<ChildGuard> {
    let child = Command::new(std::env::current_exe()?)
        .env("FUSION_BENCH_PUBLISHER", namespace)
        .env("FUSION_BENCH_MODEL", model)
        .envs(plan.to_env())
        .stdout(Stdio::null())
        .spawn()?;
    Ok(ChildGuard(child))
}

/// Starts `fusionctl record` on `namespace` into `mcap` and waits until it reads
/// the snapshots; dropping the guard stops it (SIGTERM: a clean finish).
fn start_recorder(
    fusionctl: &std::path::Path,
    namespace: &str,
    mcap: &std::path::Path,
    client: &Client,
) -> anyhow::Result<ChildGuard> {
    let child = Command::new(fusionctl)
        .args(["record", "--no-compression", "--namespace", namespace, "--output"])
        .arg(mcap)
        .stderr(Stdio::null())
        .spawn()?;
    let recorder = ChildGuard(child);
    let config = fusion_shared::service::iceoryx_config(None).map_err(anyhow::Error::msg)?;
    let node = fusion_shared::service::create_node("bench-probe", &config).map_err(anyhow::Error::msg)?;
    let state = fusion_shared::service::state_service(&node, client.names(), None)?;
    let readers = || state.dynamic_config().number_of_subscribers();
    let before = readers();
    let started = Instant::now();
    while readers() <= before {
        anyhow::ensure!(started.elapsed() < Duration::from_secs(10), "fusionctl record did not subscribe");
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(recorder)
}

fn main() -> anyhow::Result<()> {
    // Roles of this same binary, re-executed: the pong side and the publisher process.
    if let Ok(base) = std::env::var("FUSION_BENCH_PONG") {
        let mode = Mode::parse(&std::env::var("FUSION_BENCH_MODE")?).context("mode")?;
        return match std::env::var("FUSION_BENCH_PONG_PAYLOAD").as_deref() {
            Ok("snapshot") => pong::<StateSnapshot>(&base, mode, false),
            // The throughput floor's relay: fusiond's buffers.
            Ok("relay") => pong::<StateSnapshot>(&base, mode, true),
            _ => pong::<ImuSample>(&base, mode, false),
        };
    }
    if let Ok(namespace) = std::env::var("FUSION_BENCH_PUBLISHER") {
        let model = std::env::var("FUSION_BENCH_MODEL")?;
        return publisher(&namespace, PublisherPlan::from_env()?, imu_value(&model));
    }
    // `cargo bench` passes --bench; with a filter argument that excludes "latency", do nothing.
    let filters: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    if !filters.is_empty() && !filters.iter().any(|f| "latency".contains(f.as_str()) || f.contains("latency")) {
        return Ok(());
    }
    let started = Instant::now();
    let run = Run::from_env()?;
    let mut rows = raw_rows(&run)?;
    if run.only("e2e") {
        rows.extend(e2e_rows(&run)?);
    }
    let (late_rows, throughput_rows) = late_and_throughput(&run)?;
    let alloc_rows = if run.only("alloc") { alloc_rows(&run)? } else { Vec::new() };
    let record_rows = if run.only("record") { record_rows(&run)? } else { Vec::new() };
    print_report(&rows, &late_rows, &throughput_rows, &alloc_rows, run.quick, &run.out_dir)?;
    print_record_rows(&record_rows, run.imu_hz);
    println!("whole run: {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// One run's settings (from the environment, see the crate docs) and where
/// its binaries and outputs are.
struct Run {
    quick: bool,
    /// Samples per latency row.
    count: u64,
    imu_hz: f64,
    /// The sections to run besides the raw floor (all unless named).
    sections: Option<String>,
    root: PathBuf,
    target: PathBuf,
    /// The daemon binary under test.
    fusiond: PathBuf,
    out_dir: PathBuf,
    pid: u32,
    /// Latency rows run in `blocks` blocks of `per_block` samples (after `warm`),
    /// taking turns with blocks of their baseline.
    blocks: u64,
    per_block: u64,
    warm: u64,
}

impl Run {
    fn from_env() -> anyhow::Result<Self> {
        let quick = std::env::var("FUSION_BENCH_QUICK").is_ok_and(|v| v != "0");
        let count: u64 = std::env::var("FUSION_BENCH_SAMPLES").ok().and_then(|v| v.parse().ok()).unwrap_or(if quick {
            1_000
        } else {
            10_000
        });
        let imu_hz: f64 = std::env::var("FUSION_BENCH_IMU_HZ").ok().and_then(|v| v.parse().ok()).unwrap_or(1000.0);
        // The daemon binary, built as cargo bench builds (release), or the one
        // `FUSION_BENCH_FUSIOND` names (to compare two builds on the same machine).
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let target = std::env::var("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|_| root.join("target"));
        let fusiond = match std::env::var("FUSION_BENCH_FUSIOND") {
            Ok(path) => PathBuf::from(path),
            Err(_) => build(&root, &target, &["-p", "fusion-daemon", "--bin", "fusiond"], "fusiond")?,
        };
        let out_dir = target.join("fusion-bench");
        std::fs::create_dir_all(&out_dir)?;
        let blocks = 10;
        let per_block = (count / blocks).max(1);
        Ok(Self {
            quick,
            count,
            imu_hz,
            sections: std::env::var("FUSION_BENCH_ONLY").ok(),
            root,
            target,
            fusiond,
            out_dir,
            pid: std::process::id(),
            blocks,
            per_block,
            warm: (per_block / 10).max(5),
        })
    }

    /// Whether `section` runs (every one unless `FUSION_BENCH_ONLY` names some).
    fn only(&self, section: &str) -> bool {
        self.sections.as_deref().is_none_or(|list| list.split(',').any(|s| s.trim() == section))
    }
}

/// Builds `binary` with `package_args` in release, as cargo bench builds.
fn build(
    root: &std::path::Path,
    target: &std::path::Path,
    package_args: &[&str],
    binary: &str,
) -> anyhow::Result<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status =
        Command::new(cargo).args(["build", "--quiet", "--release"]).args(package_args).current_dir(root).status()?;
    anyhow::ensure!(status.success(), "building {binary} failed");
    Ok(target.join("release").join(binary))
}

/// 1. Raw iceoryx2 ping-pong alone, paced like the end-to-end rows.
fn raw_rows(run: &Run) -> anyhow::Result<Vec<Row>> {
    let Run { count, imu_hz, pid, blocks, per_block, warm, .. } = *run;
    // 1. Raw iceoryx2 ping-pong alone, paced like the end-to-end rows. Busy-poll also
    //    with a 4.2 KB answer (what fusiond answers with), in blocks taking turns.
    let mut rows = Vec::new();
    for mode in [Mode::Spin, Mode::Event] {
        let base = format!("fusion-bench-{pid}-raw-{}", mode.name());
        let name = format!("raw iceoryx2 ping-pong, {} (one way)", mode.name());
        let pong = spawn_pong(&base, mode, false)?;
        if mode == Mode::Event {
            let h = ping(&base, mode, count, imu_hz)?;
            rows.push(Row {
                name,
                mode,
                one_way: true,
                h,
                legs: None,
                raw_rtt: None,
                raw_pair_rtt: None,
                block_ratios: Vec::new(),
            });
            continue;
        }
        let big_base = format!("{base}-snapshot");
        let big_pong = spawn_pong(&big_base, mode, true)?;
        let mut small = Pinger::<ImuSample>::connect(&base, mode)?;
        let mut big = Pinger::<StateSnapshot>::connect(&big_base, mode)?;
        let (mut small_rtt, mut big_rtt, mut block_ratios) = (histogram(), histogram(), Vec::new());
        for _ in 0..blocks {
            big_pong.pause()?;
            pong.resume()?;
            let mut block = histogram();
            small.run(per_block + warm, warm, imu_hz, &mut block)?;
            small_rtt.add(&block)?;
            pong.pause()?;
            big_pong.resume()?;
            let mut big_block = histogram();
            big.run(per_block + warm, warm, imu_hz, &mut big_block)?;
            big_rtt.add(&big_block)?;
            block_ratios.push(big_block.value_at_quantile(0.5) as f64 / block.value_at_quantile(0.5) as f64);
        }
        pong.resume()?;
        small.finish()?;
        big.finish()?;
        rows.push(Row {
            name,
            mode,
            one_way: true,
            h: small_rtt.clone(),
            legs: None,
            raw_rtt: None,
            raw_pair_rtt: None,
            block_ratios: Vec::new(),
        });
        rows.push(Row {
            name: format!("raw, {}, 4.2 KB answer (half round trip)", mode.name()),
            mode,
            one_way: true,
            h: big_rtt,
            legs: None,
            raw_rtt: Some(small_rtt),
            raw_pair_rtt: None,
            block_ratios,
        });
    }
    Ok(rows)
}

/// 2. End to end (see the section's comment).
fn e2e_rows(run: &Run) -> anyhow::Result<Vec<Row>> {
    let Run { count, imu_hz, pid, blocks, per_block, warm, .. } = *run;
    let fusiond = &run.fusiond;
    let mut rows = Vec::new();
    // 2. End to end, publisher and reader in one process, in blocks that take
    //    turns with blocks of raw ping-pong (the other side paused); then the
    //    fan-out case with the publisher in a process of its own.
    for model in ["linear", "ins", "vehicle", "vehicle-receipt", "vehicle-late", "vehicle21"] {
        for mode in [Mode::Spin, Mode::Event] {
            let namespace = format!("fusion-bench-{pid}-{model}-{}", mode.name());
            let rig = start_rig(fusiond, &namespace, model, mode)?;
            let base = format!("{namespace}-raw");
            let pong = spawn_pong(&base, mode, false)?;
            let mut pinger = Pinger::<ImuSample>::connect(&base, mode)?;
            // The vehicle rows are per instant of two IMU samples: beside the raw
            // round trip, one that carries the same two-sample traffic.
            let per_instant = if model.starts_with("vehicle") { 2 } else { 1 };
            let mut prober = match model {
                "vehicle" => Prober::vehicle(&rig.client, mode)?,
                "vehicle-receipt" => Prober::vehicle(&rig.client, mode)?.stamped_on_receipt(),
                "vehicle-late" => Prober::vehicle_late(&rig.client, mode)?,
                "vehicle21" => Prober::vehicle21(&rig.client, mode)?,
                _ => Prober::new(&rig.client, mode, imu_value(model))?,
            };
            let (mut e2e, mut raw_rtt, mut block_ratios) = (EndToEnd::new(), histogram(), Vec::new());
            let mut pair_rtt = (per_instant > 1).then(histogram);
            for _ in 0..blocks {
                rig.daemon.pause()?;
                pong.resume()?;
                let mut raw_block = histogram();
                pinger.run(per_block + warm, warm, imu_hz, &mut raw_block)?;
                if let Some(pair) = &mut pair_rtt {
                    pinger.run_instants(per_block + warm, warm, imu_hz, per_instant, pair)?;
                }
                pong.pause()?;
                rig.daemon.resume()?;
                let mut block = EndToEnd::new();
                prober.run(per_block + warm, warm, imu_hz, &mut block)?;
                block_ratios
                    .push(block.latency.value_at_quantile(0.5) as f64 / raw_block.value_at_quantile(0.5) as f64);
                raw_rtt.add(&raw_block)?;
                e2e.add(&block)?;
            }
            pong.resume()?;
            pinger.finish()?;
            let name = match model {
                "vehicle-receipt" => "fusiond vehicle, IMU stamped on receipt".to_string(),
                "vehicle-late" => "fusiond vehicle, late GNSS/odometry".to_string(),
                "vehicle21" => "fusiond vehicle, 21 states (+scale, baro, pose frame)".to_string(),
                _ => format!("fusiond {model}"),
            };
            rows.push(Row {
                name: format!("{name}, --wait {}", mode.name()),
                mode,
                one_way: false,
                h: e2e.latency.clone(),
                legs: Some(e2e),
                raw_rtt: Some(raw_rtt),
                raw_pair_rtt: pair_rtt,
                block_ratios,
            });
            if model.starts_with("vehicle") {
                continue; // the fan-out rows are of one IMU
            }
            let warmup = count / 10;
            let plan = PublisherPlan { rate_hz: imu_hz, count: count + warmup, sensor: 2, wake: mode == Mode::Event };
            let _publisher = spawn_publisher(&namespace, model, plan)?;
            let h = fan_out_reader(&rig.client, mode, 2, warmup, count)?;
            rows.push(Row {
                name: format!("fusiond {model}, --wait {}, fan-out", mode.name()),
                mode,
                one_way: false,
                h,
                legs: None,
                raw_rtt: None,
                raw_pair_rtt: None,
                block_ratios: Vec::new(),
            });
        }
    }

    Ok(rows)
}

/// Late-data and throughput rows (sections 3 and 4).
type LateRows = Vec<(&'static str, Mode, LateCost)>;
/// Throughput trials per model and rate (rate −1: the best clean one).
type ThroughputRows = Vec<(&'static str, f64, Trial)>;

/// 3. Late data and 4. throughput, spin mode.
fn late_and_throughput(run: &Run) -> anyhow::Result<(LateRows, ThroughputRows)> {
    let (quick, pid, fusiond) = (run.quick, run.pid, &run.fusiond);
    let only = |section: &str| run.only(section);
    // 3. Late data and 4. throughput, spin mode.
    let late_count = if quick { 1_000 } else { 5_000 };
    let mut late_rows = Vec::new();
    let mut throughput_rows = Vec::new();
    // 4. The floor first: raw iceoryx2's highest clean rate through a relay
    // (doubling from 100 k/s, then halfway to the first rate that lost).
    // fusiond's trials are at fractions of it, so that a row reads the same
    // on a slower machine.
    let raw_best = if only("throughput") {
        let best = raw_best_rate(&format!("fusion-bench-{pid}-relay"), &mut throughput_rows)?;
        anyhow::ensure!(best > 0.0, "raw iceoryx2 lost samples even at 100 k/s: no floor to measure against");
        best
    } else {
        0.0
    };
    let fractions: &[f64] =
        if quick { &[0.1, 0.25, 0.5, 0.75, 1.0] } else { &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0] };
    let rates: Vec<f64> = fractions.iter().map(|f| (f * raw_best / 1000.0).round() * 1000.0).collect();
    for model in ["linear", "ins"] {
        for mode in [Mode::Spin, Mode::Event].into_iter().filter(|_| only("late")) {
            let namespace = format!("fusion-bench-{pid}-{model}-late-{}", mode.name());
            let rig = start_rig(fusiond, &namespace, model, mode)?;
            let cost = late_data(&rig.client, mode, late_count, 1000.0, 100_000_000, imu_value(model))?;
            late_rows.push((model, mode, cost));
        }

        if !only("throughput") {
            continue;
        }
        let namespace = format!("fusion-bench-{pid}-{model}-throughput");
        let config = format!("{}{UNLIMITED_RATE}", config_of(model));
        let rig = start_rig_with(fusiond, &namespace, &config, Mode::Spin)?;
        let mut best = None;
        for (i, &rate) in rates.iter().enumerate() {
            // Half a second per rate: 50 to 500 thousand samples.
            let published = (rate * 0.5) as u64;
            let sensor = i as u32 + 1;
            let trial = throughput(&rig.client, sensor, rate, published, imu_value(model))?;
            throughput_rows.push((model, rate, trial));
            if !trial.clean() {
                break;
            }
            best = Some(rate);
        }
        throughput_rows.push((model, -1.0, Trial { published: best.unwrap_or(0.0) as u64, ..Trial::default() }));
    }

    Ok((late_rows, throughput_rows))
}

/// Raw iceoryx2's highest clean rate through a relay process (its trials go
/// to `rows` as model `raw`, the best as rate −1), samples/s.
fn raw_best_rate(base: &str, rows: &mut ThroughputRows) -> anyhow::Result<f64> {
    let _relay = spawn_pong_as(base, Mode::Spin, "relay")?;
    let mut relay = RawRelay::connect(base)?;
    let (mut best, mut failed) = (0.0f64, None);
    let mut rate = 100e3;
    while rate <= 12.8e6 {
        let trial = raw_throughput(&mut relay, rate, (rate * 0.5) as u64)?;
        rows.push(("raw", rate, trial));
        if !trial.clean() {
            failed = Some(rate);
            break;
        }
        best = rate;
        rate *= 2.0;
    }
    if let Some(failed) = failed.filter(|_| best > 0.0) {
        let rate = (best + failed) / 2.0;
        let trial = raw_throughput(&mut relay, rate, (rate * 0.5) as u64)?;
        rows.push(("raw", rate, trial));
        if trial.clean() {
            best = rate;
        }
    }
    relay.finish()?;
    rows.push(("raw", -1.0, Trial { published: best as u64, ..Trial::default() }));
    Ok(best)
}

/// 6. Allocations of the daemon loop per processed sample, in this process.
fn alloc_rows(run: &Run) -> anyhow::Result<Vec<(&'static str, Mode, Window)>> {
    let (quick, pid) = (run.quick, run.pid);
    // 6. Allocations of the daemon loop per processed sample, in this process.
    let mut alloc_rows = Vec::new();
    let (warm, measured) = if quick { (500, 1000) } else { (1000, 2000) };
    for model in ["linear", "ins", "vehicle", "vehicle21"] {
        for (mode, wait) in [(Mode::Spin, WaitMode::Spin), (Mode::Event, WaitMode::Event)] {
            let namespace = format!("fusion-bench-{pid}-{model}-{}-alloc", mode.name());
            let (vehicle, extras) = (model.starts_with("vehicle"), model == "vehicle21");
            let accel_mps2 = if vehicle { VEHICLE_IMUS_AT_REST[0] } else { imu_value(model).0 };
            let config = config_of(model);
            let scenario = Scenario {
                namespace: &namespace,
                config,
                wait,
                accel_mps2,
                domain: None,
                warm,
                measured,
                vehicle,
                extras,
            };
            alloc_rows.push((model, mode, steady_state(&scenario)?));
        }
    }

    Ok(alloc_rows)
}

/// 7. Recorder rows: per model, p50s without and with a recorder, and the per-block ratios.
type RecordRows = Vec<(&'static str, Histogram<u64>, Histogram<u64>, Vec<f64>)>;

/// 7. A recorder attached (see the section's comment).
fn record_rows(run: &Run) -> anyhow::Result<RecordRows> {
    let Run { imu_hz, pid, blocks, per_block, warm, .. } = *run;
    let (root, target, out_dir, fusiond) = (&run.root, &run.target, &run.out_dir, &run.fusiond);
    // 7. A recorder attached (`fusionctl record`), spin mode: blocks without and
    //    with one, taking turns; the recorder is started and stopped per block.
    let fusionctl = match std::env::var("FUSION_BENCH_FUSIONCTL") {
        Ok(path) => PathBuf::from(path),
        Err(_) => {
            build(root, target, &["-p", "fusion-client", "--features", "cli", "--bin", "fusionctl"], "fusionctl")?
        }
    };
    let mut record_rows = Vec::new();
    for model in ["linear", "ins"] {
        let namespace = format!("fusion-bench-{pid}-{model}-record");
        let rig = start_rig(fusiond, &namespace, model, Mode::Spin)?;
        let mut prober = Prober::new(&rig.client, Mode::Spin, imu_value(model))?;
        let (mut alone, mut recorded, mut block_ratios) = (histogram(), histogram(), Vec::new());
        let mcap = out_dir.join(format!("record-{model}.mcap"));
        for _ in 0..blocks {
            let mut without = EndToEnd::new();
            prober.run(per_block + warm, warm, imu_hz, &mut without)?;
            let recorder = start_recorder(&fusionctl, &namespace, &mcap, &rig.client)?;
            let mut with = EndToEnd::new();
            prober.run(per_block + warm, warm, imu_hz, &mut with)?;
            drop(recorder);
            block_ratios
                .push(with.latency.value_at_quantile(0.5) as f64 / without.latency.value_at_quantile(0.5) as f64);
            alone.add(&without.latency)?;
            recorded.add(&with.latency)?;
        }
        let _ = std::fs::remove_file(&mcap);
        record_rows.push((model, alone, recorded, block_ratios));
    }

    Ok(record_rows)
}

/// The recorder rows' table.
fn print_record_rows(record_rows: &RecordRows, imu_hz: f64) {
    println!("\n## End to end with a recorder attached (spin, {imu_hz} Hz, blocks taking turns)\n");
    println!("| model | without p50 | with p50 | without p99 | with p99 | with/without p50 per block |");
    println!("|---|---|---|---|---|---|");
    for (model, alone, recorded, ratios) in record_rows {
        let us = |h: &Histogram<u64>, q: f64| h.value_at_quantile(q) as f64 / 1000.0;
        let ratios: Vec<String> = ratios.iter().map(|r| format!("{r:.2}")).collect();
        println!(
            "| {model} | {:.2} µs | {:.2} µs | {:.2} µs | {:.2} µs | {} |",
            us(alone, 0.5),
            us(recorded, 0.5),
            us(alone, 0.99),
            us(recorded, 0.99),
            ratios.join(" ")
        );
    }
}
