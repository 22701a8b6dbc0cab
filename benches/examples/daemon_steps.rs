//! Runs what `fusiond run` does per sample, without iceoryx2: engine insert,
//! health, and the snapshot filled in place (in a chunk that holds the previous
//! one, as a loaned chunk would); several IMUs averaged fill one snapshot per
//! IMU instant, after its last sample, as the live loop does. For an instruction-count profile under
//! callgrind of the daemon's own time:
//!
//! ```sh
//! cargo build --release -p fusion-benches --example daemon_steps
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out target/release/examples/daemon_steps linear 10000
//! callgrind_annotate --inclusive=yes /tmp/cg.out
//! ```
//!
//! With `--toggle-collect='*daemon_steps::handle*'` callgrind counts the
//! latency path alone: the samples' handling, without the idle time's work
//! (settling rewinds, stepping ahead to the next instant).
//!
//! With a third argument `time`, each sample's handling is timed and the p50 and
//! p99 per sample kind are printed (the first and the second IMU sample of an
//! instant apart).
//!
//! Models: `linear` and `ins` (one IMU at 1 kHz), and `vehicle`: the latency
//! bench's vehicle set ([`fusion_benches::latency::VEHICLE_CONFIG`]: two IMUs at
//! the same 1 kHz instants, a geodetic fix every 100th instant, an odometry
//! speed every 20th: [`fusion_benches::latency::vehicle_instant`]), `vehicle16`
//! (with the odometry scale factor as a state: 16 error states) and `vehicle21`
//! (the largest state, [`fusion_benches::latency::VEHICLE21_CONFIG`]: scale,
//! barometer and a pose sensor's map frame, with their samples). `linear-late`
//! and `ins-late`: one IMU at 1 kHz and, every 100th instant, a position fix 100 ms old arriving just before the IMU sample
//! (the latency bench's late-data rows). Samples are inserted as the live loop
//! does ([`Engine::insert_deferred`]); after each instant, untimed, as the loop
//! does in its idle time, a pending rewind is settled and the estimate stepped
//! ahead to the next instant ([`Engine::step_ahead`]). The samples are stamped
//! on the IMU's 1 kHz grid.

use std::hint::black_box;

use fusion_benches::latency::{VEHICLE_CONFIG, VEHICLE21_CONFIG, vehicle_instant, vehicle21_extras};
use fusion_daemon::config::{Config, WithModel, with_model};
use fusion_daemon::engine::{Engine, EngineConfig, Insert};
use fusion_daemon::health::HealthMonitor;
use fusion_daemon::measurement::Steps;
use fusion_daemon::model::held_imu::Instants;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_daemon::snapshot::{self, Input};
use fusion_shared::{ImuSample, PositionSample, Sample, StateSnapshot};

fn main() {
    let model = std::env::args().nth(1).unwrap_or_else(|| "linear".into());
    let n: u64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let time = std::env::args().nth(3).is_some_and(|a| a == "time");
    match model.as_str() {
        "ins" => {
            let config = Config::parse(&fusion_benches::ins_config_text()).expect("valid");
            let imus = |t, k| vec![Sample::Imu(ImuSample::new(t, 0, k, [0.0, 0.0, 9.80665], [0.0; 3]))];
            run(InsModel::from_config(&config).expect("ins"), &config, n, time, imus);
        }
        "linear-late" => {
            let config = fusion_benches::linear_config();
            run(LinearModel::from_config(&config).expect("linear"), &config, n, time, |t, k| late_instant(t, k, 0.0));
        }
        "ins-late" => {
            let config = Config::parse(&fusion_benches::ins_config_text()).expect("valid");
            run(InsModel::from_config(&config).expect("ins"), &config, n, time, |t, k| late_instant(t, k, 9.80665));
        }
        "vehicle" => {
            let config = Config::parse(VEHICLE_CONFIG).expect("valid");
            run(InsModel::from_config(&config).expect("ins"), &config, n, time, vehicle_instant);
        }
        "vehicle16" | "vehicle21" => {
            // 16: the vehicle set with the odometry scale state; 21: the largest
            // state (scale, barometer bias, a pose sensor's map frame).
            let text = if model == "vehicle21" {
                VEHICLE21_CONFIG.to_string()
            } else {
                format!("{VEHICLE_CONFIG}[model.odometry_scale]\n")
            };
            let config = Config::parse(&text).expect("valid");
            with_model(&config, Run { config: &config, n, time, extras: model == "vehicle21" });
        }
        _ => {
            let config = fusion_benches::linear_config();
            let imus = |t, k| vec![Sample::Imu(ImuSample::new(t, 0, k, [0.0; 3], [0.0; 3]))];
            run(LinearModel::from_config(&config).expect("linear"), &config, n, time, imus);
        }
    }
}

/// One IMU sample at `t` (specific force `g` up), after a fix 100 ms old every
/// 100th instant (from 200 on, once the history reaches back that far).
fn late_instant(t: u64, k: u64, g: f64) -> Vec<Sample> {
    let mut out = Vec::with_capacity(2);
    if k >= 200 && k.is_multiple_of(100) {
        let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
        out.push(Sample::Position(PositionSample::new(t - 100_000_000, 1, k / 100, [0.0; 3], cov)));
    }
    out.push(Sample::Imu(ImuSample::new(t, 0, k, [0.0, 0.0, g], [0.0; 3])));
    out
}

/// [`run`] with whichever state size a config builds ([`with_model`]).
struct Run<'a> {
    config: &'a Config,
    n: u64,
    time: bool,
    /// The 21-state set's barometer and poses too ([`vehicle21_extras`]).
    extras: bool,
}

impl WithModel for Run<'_> {
    type Output = ();
    fn run<M: Steps>(self, model: M) {
        eprintln!("{} error states", M::COV_DIM);
        let extras = self.extras;
        run(model, self.config, self.n, self.time, move |t, k| {
            let mut out = vehicle_instant(t, k);
            if let Some(s) = vehicle21_extras(t, k).filter(|_| extras) {
                out.insert(0, s);
            }
            out
        });
    }
}

#[inline(never)]
fn run<M: Steps>(model: M, config: &Config, n: u64, time: bool, instant: impl Fn(u64, u64) -> Vec<Sample>) {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut health = HealthMonitor::new(config.health);
    if !M::NEEDS_POSITION {
        health = health.without_position();
    }
    let mut chunk = Box::new(StateSnapshot::default());
    let t0 = 1_000_000_000u64;
    // The samples are made first, so the loop below is the daemon's work only.
    let samples: Vec<Sample> = (0..n)
        .flat_map(|k| {
            let t = t0 + k * 1_000_000;
            let mut s = instant(t, k);
            for sample in &mut s {
                sample.header_mut().sent_ns = t;
            }
            s
        })
        .collect();
    // Per sample: its name (kind, and for an IMU whether it is the first of its
    // instant) and ns.
    let mut times: Vec<(&str, u64)> = Vec::with_capacity(if time { samples.len() } else { 0 });
    let (mut last_imu_t, mut prev_was_imu) = (None, false);
    for sample in &samples {
        let t = sample.t_ns();
        let imu = matches!(sample, Sample::Imu(_));
        // An instant ends with its IMU samples: before the next one, the loop's
        // idle time settles what is pending.
        if prev_was_imu && !(imu && last_imu_t == Some(t)) {
            while engine.settle_step() {}
            engine.take_first_outcomes(|slot, outcome, exact| health.record(slot, outcome, exact));
            engine.step_ahead();
        }
        let start = std::time::Instant::now();
        handle(&mut engine, &mut health, black_box(&mut chunk), sample, t + 500);
        if time {
            let ns = start.elapsed().as_nanos() as u64;
            let name = match sample {
                Sample::Imu(_) if last_imu_t == Some(t) => "imu, not first of its instant",
                Sample::Imu(_) => "imu, first of its instant",
                other => other.kind().name(),
            };
            times.push((name, ns));
        }
        if imu {
            last_imu_t = Some(t);
        }
        prev_was_imu = imu;
    }
    if time {
        report(times);
    }
    let stats = engine.stats();
    eprintln!("stepped ahead {}, of which used {}", stats.stepped_ahead, stats.stepped_from_ahead);
}

/// Prints the p50 and p99 of each sample name, and of every IMU sample.
fn report(times: Vec<(&str, u64)>) {
    let mut names: Vec<&str> = times.iter().map(|(n, _)| *n).collect();
    names.sort();
    names.dedup();
    names.push("imu, all");
    for name in names {
        let mut ns: Vec<u64> = times
            .iter()
            .filter(|(n, _)| *n == name || (name == "imu, all" && n.starts_with("imu")))
            .map(|t| t.1)
            .collect();
        ns.sort_unstable();
        let q = |p: f64| ns[((ns.len() - 1) as f64 * p) as usize];
        println!("{name:<32} {:>7} samples  p50 {:>6} ns  p99 {:>6} ns", ns.len(), q(0.5), q(0.99));
    }
}

#[inline(never)]
fn handle<M: Steps>(
    engine: &mut Engine<M>,
    health: &mut HealthMonitor,
    snap: &mut StateSnapshot,
    sample: &Sample,
    received_ns: u64,
) {
    let replayed = match engine.insert_deferred(sample, Some(received_ns), &mut |_| {}) {
        Insert::Processed { replayed, outcome } => {
            if let Some(slot) = engine.slot_of(sample.kind(), sample.sensor()) {
                health.record(slot, &outcome, fusion_daemon::measurement::exact(sample));
            }
            replayed
        }
        Insert::Placed { replayed } => replayed,
        _ => return,
    };
    engine.take_first_outcomes(|slot, outcome, exact| health.record(slot, outcome, exact));
    // As the live loop: an IMU sample that leaves its instant open (several
    // IMUs averaged) publishes nothing; the instant's last one does.
    if replayed == 0 && matches!(sample, Sample::Imu(_)) && engine.latest().is_some_and(|e| M::instant_open(&e.state)) {
        return;
    }
    let initialised = engine.latest().is_some_and(|e| M::initialised(&e.state));
    let reinitialisations = engine.latest().map_or(0, |e| M::diagnostics(&e.state).reinitialisations);
    let now = health.evaluate(engine.sensors(), received_ns, initialised, reinitialisations);
    snapshot::fill(snap, engine, Some(Input { sample, received_ns, replayed }), now);
}
