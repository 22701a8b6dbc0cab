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
use std::io::BufRead;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

mod bag;
mod scenario_args;

use fusion_shared::time::DEFAULT_MAX_JUMP_NS;
use scenario_args::SimArgs;

use fusion_client::sim::player::{ArrivalMerge, play, sleep_until};
use fusion_client::sim::{Arrival, ImuSim, Scenario, without_outages};
use fusion_client::{Client, Sample, SampleKind, SensorPublishers, now_ns};
use fusion_shared::jsonl::{format_sample, parse_sample};

#[derive(Parser)]
#[command(name = "fusion-sim", version, about = "Simulated IMU and position sensors for fusiond")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Publish simulated sensors (or a file) live to fusiond.
    Run {
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
    },
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
        Command::Run {
            namespace,
            allow_no_daemon,
            imu_only,
            imu_ids,
            position_only,
            input,
            config: topic_map,
            realtime,
            keep_stamps,
            start_at_ns,
            sim,
        } => {
            let config = sim.scenario().unwrap_or_else(|e| usage_error(e));
            if let Some(ids) = &imu_ids
                && !config.imus().any(|i| ids.contains(&i.sensor))
            {
                usage_error(anyhow::anyhow!("--imu-ids names no simulated IMU (ids 0..{})", config.imus().count()));
            }
            let stop = Arc::new(AtomicBool::new(false));
            for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
                signal_hook::flag::register(signal, Arc::clone(&stop))?;
            }
            if let Some(path) = input {
                // A mistake in the arguments is refused before anything starts.
                if fusion_shared::ros::is_bag(&path) {
                    let Some(map) = topic_map else {
                        usage_error(anyhow::anyhow!(
                            "{} is a ROS bag: --config names the fusiond configuration whose [[sensor]] topic keys \
                             map its topics",
                            path.display()
                        ))
                    };
                    let config = bag::routes(&map).unwrap_or_else(|e| usage_error(e));
                    let client = Client::connect(&namespace)?;
                    return publish_bag(&client, &path, &config, allow_no_daemon, &stop);
                }
                let client = Client::connect(&namespace)?;
                return publish_file(&client, &path, realtime, keep_stamps, allow_no_daemon, &stop);
            }
            let client = Client::connect(&namespace)?;
            let mut daemon_seen = daemon_runs(&client);
            let start = start_at_ns.unwrap_or_else(|| now_ns() + 100_000_000);
            let trajectory = config.trajectory().map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
            let end_ns = start + (config.duration_s * 1e9) as u64;
            let mut publishers = SensorPublishers::default();
            let mut imus = Vec::new();
            for imu in
                config.imus().filter(|i| !position_only && imu_ids.as_ref().is_none_or(|ids| ids.contains(&i.sensor)))
            {
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
            if !imu_only {
                for sim in config.aiding_sims() {
                    let arrivals = sim.arrivals(&trajectory, start, config.seed);
                    delayed.push(Box::new(without_outages(arrivals, config.outages.clone(), start)));
                    publishers.open(&client, sim.kind(), sim.sensor())?;
                }
            }
            let played = play(ArrivalMerge::new(imu_sim, delayed), &mut publishers, end_ns, &stop)?;
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
            daemon_seen |= daemon_runs(&client);
            // Other readers (a recorder) take samples too: whether fusiond ran is
            // whether its state service was there.
            if published > 0 && (played.delivered == 0 || !daemon_seen) && !allow_no_daemon {
                anyhow::bail!(
                    "no fusiond received the samples: none runs in namespace {namespace:?} (--allow-no-daemon to \
                     publish anyway)"
                );
            }
            Ok(())
        }
        Command::Record { output, truth, sim } => {
            let scenario = Scenario::generate(&sim.scenario().unwrap_or_else(|e| usage_error(e)));
            let mut out = BufWriter::new(std::fs::File::create(&output).with_context(|| output.display().to_string())?);
            for a in &scenario.arrivals {
                writeln!(out, "{}", format_sample(&a.sample))?;
            }
            out.flush()?;
            if let Some(path) = truth {
                let mut out = BufWriter::new(std::fs::File::create(&path).with_context(|| path.display().to_string())?);
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
    }
}

/// How long `--input` waits for the snapshot of a sample before going on (a
/// rejected, duplicate or too-late sample produces none).
const ACK_TIMEOUT: Duration = Duration::from_millis(50);

/// How long `--input` goes on while fusiond answers none of its samples, before
/// it gives up: fusiond refuses them all.
const SILENCE: Duration = Duration::from_secs(2);

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

/// How far a file's samples are stamped before this host's clock allows
/// (fusiond's `[validation] max_past_ns` is 5 s by default), with room to spare.
const FOREIGN_CLOCK_PAST_NS: u64 = 4_000_000_000;

/// The shift onto this host's clock (CLOCK_MONOTONIC) of a file whose first
/// sample is stamped `first_t_ns`: `None` when that stamp is of this clock
/// (within [`FOREIGN_CLOCK_PAST_NS`] before now, not ahead of it); else the
/// file was stamped on another clock (a recording stamped from 1 s, as
/// `fusion-sim record` writes it), and its samples are moved to start 0.1 s
/// from now, said on stderr.
fn foreign_clock_shift(path: &std::path::Path, first_t_ns: u64) -> Option<i128> {
    let now = now_ns();
    if first_t_ns + FOREIGN_CLOCK_PAST_NS >= now && first_t_ns <= now + 50_000_000 {
        return None;
    }
    let start = now + 100_000_000;
    eprintln!(
        "fusion-sim: {} is stamped on another clock (its first sample at {:.3} s, this host's clock at {:.3} s): its \
         stamps are moved onto this host's clock, the first 0.1 s from now, and each sample is published at its \
         stamp",
        path.display(),
        first_t_ns as f64 * 1e-9,
        now as f64 * 1e-9
    );
    Some(i128::from(start) - i128::from(first_t_ns))
}

/// Publishes a file in file order: paced by its timestamps (`realtime`), or in
/// lockstep with the daemon: each sample after the snapshot of the one before, so
/// the daemon sees exactly the file's order and any reader can keep up with the
/// snapshots.
fn publish_file(
    client: &Client,
    path: &std::path::Path,
    realtime: bool,
    keep_stamps: bool,
    allow_no_daemon: bool,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let file = std::io::BufReader::new(std::fs::File::open(path).with_context(|| path.display().to_string())?);
    let mut publishers = SensorPublishers::all(client)?;
    // Lockstep needs the daemon's snapshots; paced by the clock, it may start later.
    let mut state = match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
        Ok(s) => Some(s),
        Err(fusion_client::ClientError::DaemonNotRunning { .. }) if realtime || allow_no_daemon => None,
        Err(e) => return Err(e.into()),
    };
    // No daemon to keep step with (--allow-no-daemon): the file's own pace.
    let realtime = realtime || state.is_none();
    let (mut published, mut delivered, mut skipped, mut unacknowledged) = (0u64, 0u64, 0u64, 0u64);
    let (mut last_answer, mut unanswered) = (std::time::Instant::now(), 0u64);
    // fusiond's refusal counters, as its latest snapshot gave them.
    let mut rejections = [0u64; fusion_shared::snapshot::rejection::MAX];
    let mut pace: Option<(u64, u64)> = None; // (first timestamp, wall time of it)
    // Set at the first sample: the stamps moved onto this host's clock of a
    // file stamped on another (`None`: stamped on this one).
    let mut restamp: Option<Option<bag::Restamp>> = None;
    // The IMU samples of one instant published so far: fusiond publishes one
    // snapshot for the instant, after whichever of them completes it, so the
    // lockstep waits once, after the instant's last one.
    let mut instant: Vec<Sample> = Vec::new();
    // Each line parsed once (`None`: blank), so that the next one can be looked at.
    let mut lines = file
        .lines()
        .enumerate()
        .map(|(i, line)| (i, line.map(|l| (!l.trim().is_empty()).then(|| parse_sample(&l)))))
        .peekable();
    while let Some((i, line)) = lines.next() {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let parsed = match line {
            Ok(parsed) => parsed,
            Err(e) if e.kind() == std::io::ErrorKind::InvalidData => anyhow::bail!(
                "{}: line {} is not text: the file is not JSON lines (`fusion-sim record` writes them; an MCAP \
                 recording is replayed with `fusiond replay --input`)",
                path.display(),
                i + 1
            ),
            Err(e) => return Err(anyhow::Error::new(e).context(format!("cannot read {}", path.display()))),
        };
        let Some(parsed) = parsed else { continue };
        let sample = match parsed {
            Ok(s) => s,
            Err(e) => {
                eprintln!("fusion-sim: line {}: {e}", i + 1);
                skipped += 1;
                continue;
            }
        };
        let mut sample = sample;
        let restamped = restamp.get_or_insert_with(|| {
            let shift = (!keep_stamps).then(|| foreign_clock_shift(path, sample.t_ns())).flatten()?;
            Some(bag::Restamp::new(DEFAULT_MAX_JUMP_NS, 0, Some(shift), "line"))
        });
        if let Some(restamp) = restamped {
            let (t, paced) = restamp.stamp(i as u64 + 1, sample.t_ns());
            sample.header_mut().t_ns = t;
            // fusiond refuses stamps ahead of its clock: none goes out early
            // (a stamp far from the others goes at once, for fusiond to refuse).
            if paced {
                sleep_until(t, stop);
            }
        } else if realtime {
            let (t0, wall0) = *pace.get_or_insert((sample.t_ns(), now_ns()));
            sleep_until(wall0 + sample.t_ns().saturating_sub(t0), stop);
        }
        if stop.load(Ordering::Relaxed) {
            break;
        }
        delivered += u64::from(publishers.publish(sample)?.is_some_and(|readers| readers > 0));
        published += 1;
        if let Some(state) = state.as_mut().filter(|_| !realtime) {
            instant.push(sample);
            let same_instant = |next: &Sample| {
                sample.kind() == SampleKind::Imu && next.kind() == SampleKind::Imu && next.t_ns() == sample.t_ns()
            };
            if lines
                .peek()
                .and_then(|(_, l)| l.as_ref().ok())
                .and_then(|p| p.as_ref()?.as_ref().ok())
                .is_some_and(same_instant)
            {
                continue;
            }
            let deadline = std::time::Instant::now() + ACK_TIMEOUT;
            let acknowledged = loop {
                let left = deadline.saturating_duration_since(std::time::Instant::now());
                match state.wait_next(left)? {
                    Some(s)
                        if instant.iter().any(|sample| {
                            s.input_kind == sample.kind() as u32
                                && s.input_sensor == sample.sensor()
                                && s.input_seq == sample.seq()
                                && s.input_t_ns == sample.t_ns()
                        }) =>
                    {
                        break true;
                    }
                    Some(s) => rejections = s.rejections,
                    None => break false,
                }
            };
            instant.clear();
            unacknowledged += u64::from(!acknowledged);
            if acknowledged {
                (last_answer, unanswered) = (std::time::Instant::now(), 0);
                continue;
            }
            unanswered += 1;
            if last_answer.elapsed() > SILENCE {
                use fusion_shared::snapshot::rejection;
                let reasons: Vec<String> = rejection::ALL
                    .iter()
                    .filter(|(code, _)| rejections[*code as usize] > 0)
                    .map(|(code, name)| format!("{} {name}: {}", rejections[*code as usize], rejection::advice(*code)))
                    .collect();
                if !reasons.is_empty() {
                    anyhow::bail!(
                        "fusiond answered none of the last {unanswered} samples in {:.0} s: its refusal counters \
                         (`fusionctl state`) say {}",
                        SILENCE.as_secs_f64(),
                        reasons.join("; ")
                    );
                }
                anyhow::bail!(
                    "fusiond answered none of the last {unanswered} samples in {:.0} s: it refuses them \
                     (`fusionctl state` and its log say why; samples stamped on another clock than fusiond's, \
                     as a recording's, are too far in the past: raise [validation] max_past_ns, or run \
                     `fusiond replay` on the file)",
                    SILENCE.as_secs_f64()
                );
            }
        }
    }
    let done = format!(
        "published {published} samples from {} ({skipped} unreadable lines, {unacknowledged} without a snapshot, {} \
         reached no reader)",
        path.display(),
        published - delivered
    );
    if stop.load(Ordering::Relaxed) {
        return Err(fusion_shared::exit::Interrupted(format!("interrupted: {done} before the signal")).into());
    }
    if let Some(Some(restamp)) = &restamp {
        eprint!("{}", restamp.jumps);
    }
    eprintln!("fusion-sim: {done}");
    if published == 0 && skipped > 0 {
        anyhow::bail!("{}: none of its {skipped} lines is a sample (see the lines above)", path.display());
    }
    if published == 0 && !stop.load(Ordering::Relaxed) {
        anyhow::bail!("{}: no sample in it (an empty file)", path.display());
    }
    let daemon_seen = state.is_some() || daemon_runs(client);
    if published > 0 && (delivered == 0 || !daemon_seen) && !allow_no_daemon {
        anyhow::bail!(
            "no fusiond received the samples: none runs in namespace {:?} (--allow-no-daemon to publish anyway)",
            client.names().namespace
        );
    }
    Ok(())
}
