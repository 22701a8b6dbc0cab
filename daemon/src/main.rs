//! `fusiond`: the fusion daemon's command line.
//!
//! Thin: parses arguments, sets up tracing, and calls into the library.

use std::fs::File;
use std::io::{BufReader, BufWriter, IsTerminal, Read, Seek};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::Context;
use clap::{Parser, Subcommand};
use fusion_daemon::config::{Config, default_config_text};
use fusion_daemon::ipc::{RunOptions, WaitMode};
use fusion_daemon::replay;
use fusion_daemon::replay::recording::Recording;
use fusion_daemon::systemd::StallFault;

#[derive(Parser)]
#[command(name = "fusiond", version, about = "Low-latency Kalman-filter sensor fusion daemon")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the live daemon: fuse samples from iceoryx2 publishers, publish state snapshots.
    Run {
        /// Configuration file (TOML); see `fusiond print-config`. Without it,
        /// the built-in defaults (what `fusiond print-config` prints).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Namespace of the services (`<ns>/imu`, `<ns>/position`, `<ns>/state`, ...).
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
        /// `spin`: busy-poll for the lowest latency (uses one core); `event`: sleep until woken.
        #[arg(long, value_enum, default_value_t = Wait::Event)]
        wait: Wait,
        /// Seconds between summary log lines (info level).
        #[arg(long, default_value_t = 5.0, value_parser = positive_seconds)]
        summary_interval: f64,
        /// Pin the fusion loop to this CPU (with `--wait spin`, give it a core that
        /// nothing else busy runs on).
        #[arg(long)]
        cpu: Option<usize>,
        /// Fault injection: after N samples the fusion loop stops turning while
        /// the process stays up (to check that a supervisor's watchdog restarts
        /// fusiond; see docs/systemd.md).
        #[arg(long, value_name = "N")]
        fault_stall_after: Option<u64>,
    },
    /// Check a configuration file (as `run` would load it) and exit: 0 when it
    /// is valid, 1 with the reason when not.
    CheckConfig {
        /// Configuration file (TOML).
        config: PathBuf,
    },
    /// Replay recorded samples (JSON lines, or an MCAP recording of `fusionctl
    /// record`) through the engine and write the estimates.
    Replay {
        /// Configuration file (TOML); see `fusiond print-config`. An MCAP
        /// recording carries the configuration it was made with, which is used
        /// without this (given, it wins, with a warning when it differs).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Samples: one JSON object per line in arrival order, or an MCAP recording.
        #[arg(long)]
        input: PathBuf,
        /// Estimates, one JSON object per processed sample, in processing order
        /// (without it, only the summary).
        #[arg(long)]
        output: Option<PathBuf>,
        /// Output RTS-smoothed estimates instead of filtered ones.
        #[arg(long)]
        smooth: bool,
        /// MCAP input: compare every processed sample with the recorded live
        /// snapshot (x, P, NIS, counters) and fail if any differs.
        #[arg(long)]
        compare: bool,
    },
    /// Print the default configuration with comments.
    PrintConfig,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Wait {
    Spin,
    Event,
}

fn main() -> ExitCode {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let logs = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal());
    // Under systemd (stderr connected to the journal), journald stamps every line
    // itself: no second timestamp, no colours.
    if std::env::var_os("JOURNAL_STREAM").is_some() {
        logs.without_time().init();
    } else {
        logs.init();
    }
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusiond: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::status_of(e.as_ref()))
        }
    }
}

/// A positive, finite number of seconds (else a usage error).
fn positive_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s > 0.0 && Duration::try_from_secs_f64(s).is_ok() => Ok(s),
        _ => Err(format!("{text:?} is not a positive number of seconds")),
    }
}

/// Samples between two updates of a replay's progress bar.
const PROGRESS_STEP: u64 = 4096;

/// A progress bar on stderr for a replay of `len` samples (or bytes), hidden
/// when stderr is not a terminal (a log, a pipe) or the length is unknown.
fn progress_bar(len: Option<u64>, bytes: bool) -> indicatif::ProgressBar {
    match len {
        Some(len) if std::io::stderr().is_terminal() => {
            let counts =
                if bytes { "{bytes}/{total_bytes}, {bytes_per_sec}" } else { "{human_pos}/{human_len} samples" };
            let template = format!("replaying {{bar:40}} {{percent:>3}}% {counts}, {{eta}} left");
            let style = indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
            indicatif::ProgressBar::new(len).with_style(style)
        }
        _ => indicatif::ProgressBar::hidden(),
    }
}

/// A replay that processed nothing: its summary (every refused line with its
/// reason) goes to stderr first.
/// Whether `file` starts as text does: no NUL in its first 4 KiB, and most
/// of them printable UTF-8 (a line of garbage among JSON lines is counted
/// with its line number, not taken for a binary file).
fn is_text(file: &mut File) -> std::io::Result<bool> {
    let mut head = vec![0u8; 4096];
    file.seek(std::io::SeekFrom::Start(0))?;
    let n = file.read(&mut head)?;
    let head = &head[..n];
    if head.contains(&0) {
        return Ok(false);
    }
    let text = String::from_utf8_lossy(head);
    let odd = text.chars().filter(|&c| c == '\u{fffd}' || (c.is_control() && !c.is_whitespace())).count();
    Ok(odd * 10 < text.chars().count().max(1))
}

/// The error of a recording damaged before its first sample (status 4).
fn nothing_before(
    input: &std::path::Path,
    damage: &fusion_shared::mcap_scan::Damage,
) -> fusion_shared::exit::InputDamaged {
    fusion_shared::exit::InputDamaged(format!(
        "{} is {damage}: no sample before it to replay; the {} bytes from the damage to the end of the file are not \
         read",
        input.display(),
        damage.lost_bytes
    ))
}

fn say_why(e: replay::ReplayError) -> replay::ReplayError {
    if let replay::ReplayError::NothingProcessed(summary) = &e {
        eprint!("{summary}");
    }
    e
}

/// The configuration of a replay: `--config` if given (with a warning when
/// the recording was made with another), else the one the recording carries.
fn replay_config(
    path: Option<&std::path::Path>,
    recording: Option<&Recording>,
    input: &std::path::Path,
) -> anyhow::Result<Config> {
    let recorded = recording.and_then(Recording::config);
    if let Some(r) = &recorded
        && r.snapshot_wire != fusion_shared::config_record::snapshot_wire()
    {
        eprintln!(
            "replay: warning: the run was recorded by fusiond {} ({}); this is fusiond {} ({}): the replay may differ",
            r.fusiond_version,
            r.snapshot_wire,
            env!("CARGO_PKG_VERSION"),
            fusion_shared::config_record::snapshot_wire()
        );
    }
    match (path, recorded) {
        (Some(path), recorded) => {
            let config = Config::load(path)?;
            if let Some(r) = recorded {
                match Config::parse(&r.toml) {
                    Ok(at_record) if at_record == config => {}
                    Ok(_) => eprintln!(
                        "replay: warning: {} differs from the configuration {} was recorded with; replaying with {} \
                         (leave --config out to replay with the recorded one)",
                        path.display(),
                        input.display(),
                        path.display()
                    ),
                    Err(e) => eprintln!(
                        "replay: warning: the configuration recorded with {} is not valid for this fusiond ({e}); \
                         replaying with {}",
                        input.display(),
                        path.display()
                    ),
                }
            }
            Ok(config)
        }
        (None, Some(r)) => {
            eprintln!(
                "replay: the configuration {} was recorded with (fusiond {})",
                input.display(),
                r.fusiond_version
            );
            Config::parse(&r.toml).with_context(|| format!("the configuration recorded with {}", input.display()))
        }
        (None, None) => anyhow::bail!(
            "--config is needed: {} carries no configuration (a JSON-lines file, or a recording of a fusiond that did \
             not publish its configuration)",
            input.display()
        ),
    }
}

/// `fusiond replay` of a ROS bag: `--config` maps its topics.
fn replay_bag(
    config: Option<&std::path::Path>,
    input: &std::path::Path,
    output: Option<std::path::PathBuf>,
    smooth: bool,
    compare: bool,
) -> anyhow::Result<()> {
    anyhow::ensure!(!compare, "--compare needs an MCAP recording (fusionctl record), not a ROS bag");
    let Some(path) = config else {
        // A usage error (status 2), as fusion-sim's for the same mistake.
        use clap::CommandFactory;
        Cli::command()
            .error(
                clap::error::ErrorKind::MissingRequiredArgument,
                format!(
                    "--config is needed: {} is a ROS bag, and the configuration's [[sensor]] topic keys say which of \
                     its topics are read",
                    input.display()
                ),
            )
            .exit()
    };
    let config = Config::load(path)?;
    eprintln!("replay: model {}, form {}", config.model.kind(), config.filter.form.name());
    let writer = output
        .map(|o| File::create(&o).map(BufWriter::new).with_context(|| format!("cannot create {}", o.display())))
        .transpose()?;
    let (summary, bag) = replay::bag::replay_bag(&config, input, writer, smooth)
        .map_err(|e| match e {
            replay::bag::BagReplayError::Replay(e) => anyhow::anyhow!(say_why(e)),
            e => anyhow::anyhow!(e),
        })
        .with_context(|| format!("replaying {}", input.display()))?;
    eprint!("{bag}");
    eprint!("{summary}");
    match &bag.damage {
        Some(damage) => Err(fusion_shared::exit::InputDamaged(format!(
            "{} is damaged ({damage}): replayed what comes before it",
            input.display()
        ))
        .into()),
        None => Ok(()),
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run { config, namespace, wait, summary_interval, cpu, fault_stall_after } => {
            let options = RunFlags { namespace, wait, summary_interval, cpu, fault_stall_after };
            run_daemon(config.as_deref(), options)
        }
        Command::CheckConfig { config: path } => {
            let config = Config::load(&path)?;
            println!("{}: valid (model {}, form {})", path.display(), config.model.kind(), config.filter.form.name());
            Ok(())
        }
        Command::PrintConfig => {
            print!("{}", default_config_text());
            Ok(())
        }
        Command::Replay { config, input, output, smooth, compare } => {
            replay_command(config.as_deref(), &input, output, smooth, compare)
        }
    }
}

/// `fusiond run`'s flags besides its configuration.
struct RunFlags {
    namespace: String,
    wait: Wait,
    summary_interval: f64,
    cpu: Option<usize>,
    fault_stall_after: Option<u64>,
}

/// `fusiond run`: the daemon on `config` (the built-in defaults without one),
/// until SIGINT or SIGTERM.
fn run_daemon(config: Option<&std::path::Path>, flags: RunFlags) -> anyhow::Result<()> {
    let RunFlags { namespace, wait, summary_interval, cpu, fault_stall_after } = flags;
    let (text, config) = match config {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            (text, Config::load(path)?)
        }
        None => {
            tracing::info!("no --config: running on the built-in defaults (`fusiond print-config` shows them)");
            let text = default_config_text();
            let config = Config::parse(&text).context("the built-in defaults")?;
            (text, config)
        }
    };
    let shutdown = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&shutdown)).context("cannot install signal handler")?;
    }
    let options = RunOptions {
        namespace,
        wait: match wait {
            Wait::Spin => WaitMode::Spin,
            Wait::Event => WaitMode::Event,
        },
        summary_interval: Duration::try_from_secs_f64(summary_interval)
            .context("--summary-interval must be a positive number of seconds")?,
        cpu,
        stall: fault_stall_after.map(|after_samples| StallFault { after_samples }),
        config_text: Some(text),
    };
    fusion_daemon::ipc::run(&config, &options, &shutdown)?;
    Ok(())
}

/// `fusiond replay`: a ROS bag, an MCAP recording or JSON lines, by what the
/// file is.
fn replay_command(
    config: Option<&std::path::Path>,
    input: &std::path::Path,
    output: Option<PathBuf>,
    smooth: bool,
    compare: bool,
) -> anyhow::Result<()> {
    let mut file = File::open(input).with_context(|| format!("cannot open {}", input.display()))?;
    let mut magic = [0u8; 16];
    let n = file.read(&mut magic).with_context(|| format!("cannot read {}", input.display()))?;
    if fusion_shared::ros::is_bag(input) {
        return replay_bag(config, input, output, smooth, compare);
    }
    // rosbag2's file compression (`--compression-mode file`) makes
    // `bag.db3.zstd` or `bag.mcap.zstd`: whole files, not read here.
    anyhow::ensure!(
        !magic[..n].starts_with(fusion_shared::ros::ZSTD_MAGIC),
        "{}: a zstd-compressed file (as rosbag2's --compression-mode file writes a bag): decompress it \
         first (`zstd -d {}`) and replay what it holds",
        input.display(),
        input.display()
    );
    let named_mcap = input.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    anyhow::ensure!(
        !named_mcap || Recording::is_mcap(&magic[..n]),
        "{}: named .mcap but not an MCAP file (it does not start with the MCAP magic bytes)",
        input.display()
    );
    let recording = Recording::is_mcap(&magic[..n])
        .then(|| Recording::open(input).with_context(|| format!("cannot map {}", input.display())))
        .transpose()?;
    if let Some(damage) = recording.as_ref().and_then(Recording::damage) {
        // Nothing before the damage: nothing to replay.
        if damage.offset <= mcap::MAGIC.len() as u64 {
            return Err(nothing_before(input, damage).into());
        }
        eprintln!("replay: {} is {damage}: what comes after it is not read", input.display());
    }
    let config = replay_config(config, recording.as_ref(), input)?;
    eprintln!("replay: model {}, form {}", config.model.kind(), config.filter.form.name());
    let writer = output
        .map(|o| File::create(&o).map(BufWriter::new).with_context(|| format!("cannot create {}", o.display())))
        .transpose()?;
    if let Some(recording) = recording {
        return replay_recording_file(&config, &recording, input, writer, smooth, compare);
    }
    anyhow::ensure!(!compare, "--compare needs an MCAP recording (fusionctl record)");
    anyhow::ensure!(
        is_text(&mut file)?,
        "{}: not a text file: fusiond replay reads JSON lines, an MCAP recording (fusionctl record) or a ROS \
         bag (ROS 1, or ROS 2 in MCAP or .db3)",
        input.display()
    );
    file.seek(std::io::SeekFrom::Start(0))?;
    let bar = progress_bar(file.metadata().ok().map(|m| m.len()), true);
    let summary = replay::replay(&config, BufReader::new(bar.wrap_read(file)), writer, smooth);
    bar.finish_and_clear();
    let summary = summary.map_err(say_why)?;
    eprint!("{summary}");
    Ok(())
}

/// `fusiond replay` of an MCAP recording (`fusionctl record`), with a
/// progress bar; `compare`: against the live run it recorded.
fn replay_recording_file(
    config: &Config,
    recording: &Recording,
    input: &std::path::Path,
    writer: Option<BufWriter<File>>,
    smooth: bool,
    compare: bool,
) -> anyhow::Result<()> {
    let bar = progress_bar(recording.sample_count(), false);
    let mut since = 0u64;
    let tick = || {
        since += 1;
        if since == PROGRESS_STEP {
            bar.inc(since);
            since = 0;
        }
    };
    let replayed = replay::recording::replay_recording(config, recording, writer, smooth, compare, tick);
    let (summary, comparison) = match (replayed, recording.damage()) {
        (Ok(replayed), _) => replayed,
        // The damage is why nothing could be replayed: say so, as damage.
        (Err(replay::ReplayError::NothingProcessed(_)), Some(damage)) => {
            return Err(nothing_before(input, damage).into());
        }
        (Err(replay::ReplayError::NothingProcessed(s)), None) if s.read == 0 => {
            let why = if recording.was_cut_off() {
                "it was cut off before its first sample (the recorder was killed or lost its power at \
                 its start)"
            } else {
                "it holds no sample message (a recording of a run that had no input)"
            };
            anyhow::bail!("{}: nothing to replay: {why}", input.display());
        }
        (Err(e), _) => return Err(say_why(e).into()),
    };
    bar.finish_and_clear();
    eprint!("{summary}");
    if recording.was_cut_off() && recording.damage().is_none() {
        eprintln!(
            "replay: {} was cut off (no summary: the recorder was killed or lost its power): replayed \
             what its complete chunks hold ({} samples); what the recorder had not yet written is lost",
            input.display(),
            summary.read
        );
    }
    if let Some(c) = comparison {
        eprint!("{c}");
        anyhow::ensure!(c.equal(), "the replay differs from the live run");
    }
    if let (Some(damage), Some(loss)) = (recording.damage(), recording.loss(summary.read)) {
        return Err(fusion_shared::exit::InputDamaged(format!(
            "{} is {damage}: replayed what comes before it ({} samples); {loss}",
            input.display(),
            summary.read
        ))
        .into());
    }
    Ok(())
}
