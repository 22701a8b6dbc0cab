//! `fusion-sim`: simulated IMU and position sensors on one ground-truth trajectory.
//!
//! - `fusion-sim run`: publish live to a running fusiond, paced by the clock:
//!   every sensor (IMUs, one per `--imu-mount`; position; velocity with
//!   `--velocity-rate`, geodetic GNSS with `--geodetic-rate`, wheel odometry with
//!   `--odometry-rate`, heading with `--heading-rate`, a magnetometer with
//!   `--magnetometer-rate`, visual/lidar odometry's twist with `--twist-rate`), or the IMUs (`--imu-only`,
//!   some of them with `--imu-ids`) or the other sensors alone (`--position-only`)
//!   so they can run as separate processes on the same trajectory and start
//!   time; or a file (`--input`), as fast as the daemon takes it or paced by its
//!   timestamps; or a ROS bag (`--input robot.bag --config robot.toml`), live.
//! - `fusion-sim record`: write a drive as replay input (JSON lines, arrival
//!   order) and its truth (JSON lines, one per sample, timestamp order).

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

mod bag;
mod file;
mod scenario_args;

use scenario_args::SimArgs;

use fusion_client::sim::player::{ArrivalMerge, play, sleep_until};
use fusion_client::sim::{Arrival, ImuSim, Scenario, without_outages};
use fusion_client::{Client, SampleKind, SensorPublishers, now_ns};
use fusion_shared::jsonl::format_sample;

#[derive(Parser)]
#[command(name = "fusion-sim", version, about = "Simulated IMU and position sensors for fusiond")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Publish simulated sensors (or a file) live to fusiond.
    Run(RunArgs),
    /// Write a simulated drive to files: samples in arrival order, and the truth.
    Record {
        /// Samples (replay input format).
        #[arg(long)]
        output: PathBuf,
        /// Truth at every sample time: {"t_ns", "pos", "vel", "acc", "q_wxyz", "yaw"} per line.
        #[arg(long)]
        truth: Option<PathBuf>,
        #[command(flatten)]
        sim: SimArgs,
    },
}

/// `fusion-sim run`'s arguments.
#[derive(clap::Args)]
struct RunArgs {
    /// Namespace of the services.
    #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
          value_parser = fusion_shared::service::namespace_arg)]
    namespace: String,
    /// Exit 0 even if no fusiond received the samples (by default a run
    /// that reached no daemon is an error).
    #[arg(long)]
    allow_no_daemon: bool,
    /// Publish only the IMUs.
    #[arg(long, conflicts_with = "position_only")]
    imu_only: bool,
    /// Publish only the IMUs with these sensor ids (default: all).
    #[arg(long, value_delimiter = ',')]
    imu_ids: Option<Vec<u32>>,
    /// Publish only the sensors besides the IMUs: position, velocity, geodetic, odometry, heading,
    /// magnetometer, twist, barometer, pose and attitude, as their rates are set.
    #[arg(long)]
    position_only: bool,
    /// Publish this file instead of simulating: JSON lines (replay input
    /// format), or a ROS bag (ROS 1, or ROS 2 in MCAP) with --config,
    /// restamped onto this host's clock and paced by its stamps.
    #[arg(long, conflicts_with_all = ["imu_only", "position_only"])]
    input: Option<PathBuf>,
    /// With a ROS bag as --input: the fusiond configuration whose
    /// [[sensor]] topic keys say which topics are published as what.
    #[arg(long, requires = "input")]
    config: Option<PathBuf>,
    /// With --input: pace by the samples' timestamps instead of as fast as the daemon takes them.
    #[arg(long, requires = "input")]
    realtime: bool,
    /// With a JSON-lines --input: publish its stamps as they are, even when
    /// they are of another clock than this host's (a fusiond configured with a
    /// large [validation] max_past_ns takes them). By default such a file
    /// (its first stamp more than 4 s before now, or ahead of now) is
    /// restamped onto this host's clock and published at its stamps' pace.
    #[arg(long, requires = "input")]
    keep_stamps: bool,
    /// Trajectory time 0 on CLOCK_MONOTONIC, ns (default: now + 100 ms). Give
    /// the same value to separate --imu-only and --position-only processes.
    #[arg(long)]
    start_at_ns: Option<u64>,
    #[command(flatten)]
    sim: SimArgs,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusion-sim: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::status_of(e.as_ref()))
        }
    }
}

/// Refuses invalid arguments before anything starts: clap's usage error (status 2).
fn usage_error(e: anyhow::Error) -> ! {
    Cli::command().error(clap::error::ErrorKind::ValueValidation, fusion_shared::exit::error_line(e.as_ref())).exit()
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run(args) => {
            let stop = Arc::new(AtomicBool::new(false));
            for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
                signal_hook::flag::register(signal, Arc::clone(&stop))?;
            }
            match args.input.clone() {
                Some(path) => publish_input(&args, &path, &stop),
                None => simulate(&args, &stop),
            }
        }
        Command::Record { output, truth, sim } => record(&output, truth.as_deref(), &sim),
    }
}

/// `fusion-sim run --input`: a ROS bag (with its `--config`) or a JSON-lines
/// file, published live; a mistake in the arguments is refused before anything
/// starts.
fn publish_input(args: &RunArgs, path: &std::path::Path, stop: &AtomicBool) -> anyhow::Result<()> {
    let namespace = &args.namespace;
    if fusion_shared::ros::is_bag(path) {
        let Some(map) = &args.config else {
            usage_error(anyhow::anyhow!(
                "{} is a ROS bag: --config names the fusiond configuration whose [[sensor]] topic keys map its topics",
                path.display()
            ))
        };
        let config = bag::routes(map).unwrap_or_else(|e| usage_error(e));
        let client = Client::connect(namespace)?;
        return publish_bag(&client, path, &config, args.allow_no_daemon, stop);
    }
    let client = Client::connect(namespace)?;
    let how =
        file::How { realtime: args.realtime, keep_stamps: args.keep_stamps, allow_no_daemon: args.allow_no_daemon };
    file::publish_file(&client, path, how, stop)
}

/// `fusion-sim run` without `--input`: the simulated sensors, live, paced by
/// the clock from `--start-at-ns`.
fn simulate(args: &RunArgs, stop: &AtomicBool) -> anyhow::Result<()> {
    let config = args.sim.scenario().unwrap_or_else(|e| usage_error(e));
    if let Some(ids) = &args.imu_ids
        && !config.imus().any(|i| ids.contains(&i.sensor))
    {
        usage_error(anyhow::anyhow!("--imu-ids names no simulated IMU (ids 0..{})", config.imus().count()));
    }
    let client = Client::connect(&args.namespace)?;
    let mut daemon_seen = daemon_runs(&client);
    let start = args.start_at_ns.unwrap_or_else(|| now_ns() + 100_000_000);
    let trajectory = config.trajectory().map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
    let end_ns = start + (config.duration_s * 1e9) as u64;
    let mut publishers = SensorPublishers::default();
    let mut imus = Vec::new();
    let wanted = |id: &u32| !args.position_only && args.imu_ids.as_ref().is_none_or(|ids| ids.contains(id));
    for imu in config.imus().filter(|i| wanted(&i.sensor)) {
        publishers.open(&client, SampleKind::Imu, imu.sensor)?;
        imus.push(ImuSim::new(trajectory.clone(), imu.clone(), config.imu_output, start, config.seed));
    }
    // The first IMU paces the run; the others (same instants) merge in by arrival.
    let mut imus = imus.into_iter();
    let imu_sim = imus.next();
    let mut delayed: Vec<Box<dyn Iterator<Item = Arrival> + Send>> = Vec::new();
    for imu in imus {
        delayed.push(Box::new(imu));
    }
    if !args.imu_only {
        for sim in config.aiding_sims() {
            let arrivals = sim.arrivals(&trajectory, start, config.seed);
            delayed.push(Box::new(without_outages(arrivals, config.outages.clone(), start)));
            publishers.open(&client, sim.kind(), sim.sensor())?;
        }
    }
    let played = play(ArrivalMerge::new(imu_sim, delayed), &mut publishers, end_ns, stop)?;
    daemon_seen |= daemon_runs(&client);
    report_played(&args.namespace, &played, daemon_seen, args.allow_no_daemon)
}

/// What a simulated run published, on stderr; an error if no fusiond received it.
fn report_played(
    namespace: &str,
    played: &fusion_client::sim::player::Played,
    daemon_seen: bool,
    allow_no_daemon: bool,
) -> anyhow::Result<()> {
    let counts: Vec<String> = SampleKind::ALL
        .iter()
        .zip(played.published)
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| format!("{n} {} samples", k.name()))
        .collect();
    let published: u64 = played.published.iter().sum();
    let missed = published - played.delivered;
    let reached = if missed == 0 { String::new() } else { format!(" ({missed} reached no reader)") };
    eprintln!("fusion-sim: published {} to namespace {namespace:?}{reached}", counts.join(", "));
    // Other readers (a recorder) take samples too: whether fusiond ran is
    // whether its state service was there.
    if published > 0 && (played.delivered == 0 || !daemon_seen) && !allow_no_daemon {
        anyhow::bail!(
            "no fusiond received the samples: none runs in namespace {namespace:?} (--allow-no-daemon to publish \
             anyway)"
        );
    }
    Ok(())
}

/// `fusion-sim record`: the drive's samples in arrival order, and its truth
/// at every sample time.
fn record(output: &std::path::Path, truth: Option<&std::path::Path>, sim: &SimArgs) -> anyhow::Result<()> {
    let scenario = Scenario::generate(&sim.scenario().unwrap_or_else(|e| usage_error(e)));
    let mut out = BufWriter::new(std::fs::File::create(output).with_context(|| output.display().to_string())?);
    for a in &scenario.arrivals {
        writeln!(out, "{}", format_sample(&a.sample))?;
    }
    out.flush()?;
    if let Some(path) = truth {
        let mut out = BufWriter::new(std::fs::File::create(path).with_context(|| path.display().to_string())?);
        let mut times: Vec<u64> = scenario.arrivals.iter().map(|a| a.sample.t_ns()).collect();
        times.sort_unstable();
        times.dedup();
        for t in times {
            let s = scenario.truth_at(t);
            let v = |x: nalgebra::Vector3<f64>| [x.x, x.y, x.z];
            let q = s.attitude.quaternion().coords;
            let line = serde_json::json!({
                "t_ns": t, "pos": v(s.pos_m), "vel": v(s.vel_mps), "acc": v(s.acc_mps2),
                "q_wxyz": [q[3], q[0], q[1], q[2]], "yaw": s.yaw_rad(),
            });
            writeln!(out, "{line}")?;
        }
        out.flush()?;
    }
    eprintln!("fusion-sim: wrote {} samples to {}", scenario.arrivals.len(), output.display());
    Ok(())
}

/// Whether a fusiond runs in the client's namespace (its state service is there).
fn daemon_runs(client: &Client) -> bool {
    !matches!(client.state_subscriber_with_buffer(1), Err(fusion_client::ClientError::DaemonNotRunning { .. }))
}

/// Publishes a ROS bag live, restamped onto this host's clock and paced by its
/// stamps ([`bag`]).
fn publish_bag(
    client: &Client,
    path: &std::path::Path,
    config: &bag::BagConfig,
    allow_no_daemon: bool,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let mut publishers = SensorPublishers::all(client)?;
    let (mut published, mut delivered, mut refused) = (0u64, 0u64, 0u64);
    let mut failed = None;
    let start = now_ns() + 100_000_000;
    let (summary, jumps) = bag::samples(path, config, start, |_, sample| {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let Ok((sample, paced)) = sample else {
            refused += 1;
            return true;
        };
        if paced {
            sleep_until(sample.t_ns(), stop);
        }
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        match publishers.publish(sample) {
            Ok(readers) => delivered += u64::from(readers.is_some_and(|r| r > 0)),
            Err(e) => {
                failed = Some(e);
                return false;
            }
        }
        published += 1;
        true
    })?;
    if let Some(e) = failed {
        return Err(e.into());
    }
    eprint!("{summary}");
    eprint!("{jumps}");
    let done = format!(
        "published {published} samples from {} ({refused} messages gave none, {} reached no reader)",
        path.display(),
        published - delivered
    );
    if stop.load(Ordering::Relaxed) {
        return Err(fusion_shared::exit::Interrupted(format!("interrupted: {done} before the signal")).into());
    }
    eprintln!("fusion-sim: {done}");
    if published > 0 && (delivered == 0 || !daemon_runs(client)) && !allow_no_daemon {
        anyhow::bail!(
            "no fusiond received the samples: none runs in namespace {:?} (--allow-no-daemon to publish anyway)",
            client.names().namespace
        );
    }
    if let Some(damage) = &summary.damage {
        return Err(fusion_shared::exit::InputDamaged(format!(
            "{} is damaged ({damage}): published what comes before it",
            path.display()
        ))
        .into());
    }
    Ok(())
}
