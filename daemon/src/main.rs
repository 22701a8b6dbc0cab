//! `fusiond`: the fusion daemon's command line.
//!
//! Thin: parses arguments, sets up tracing, and calls into the library.

use std::fs::File;
use std::io::{BufReader, BufWriter, IsTerminal};
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
        /// Configuration file (TOML); see `fusiond print-config`.
        #[arg(long)]
        config: PathBuf,
        /// Namespace of the services (`<ns>/imu`, `<ns>/position`, `<ns>/state`, ...).
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE)]
        namespace: String,
        /// `spin`: busy-poll for the lowest latency (uses one core); `event`: sleep until woken.
        #[arg(long, value_enum, default_value_t = Wait::Event)]
        wait: Wait,
        /// Seconds between summary log lines (info level).
        #[arg(long, default_value_t = 5.0)]
        summary_interval: f64,
        /// Pin the fusion loop to this CPU (with `--wait spin`, give it a core that
        /// nothing else busy runs on).
        #[arg(long)]
        cpu: Option<usize>,
    },
    /// Replay recorded samples (JSON lines) through the engine and write the estimates.
    Replay {
        /// Configuration file (TOML); see `fusiond print-config`.
        #[arg(long)]
        config: PathBuf,
        /// Samples, one JSON object per line, in arrival order.
        #[arg(long)]
        input: PathBuf,
        /// Estimates, one JSON object per processed sample, in processing order.
        #[arg(long)]
        output: PathBuf,
        /// Output RTS-smoothed estimates instead of filtered ones.
        #[arg(long)]
        smooth: bool,
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
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusiond: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run { config, namespace, wait, summary_interval, cpu } => {
            let config = Config::load(&config)?;
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
            };
            fusion_daemon::ipc::run(&config, &options, &shutdown)?;
            Ok(())
        }
        Command::PrintConfig => {
            print!("{}", default_config_text());
            Ok(())
        }
        Command::Replay { config, input, output, smooth } => {
            let config = Config::load(&config)?;
            let reader =
                BufReader::new(File::open(&input).with_context(|| format!("cannot open {}", input.display()))?);
            let writer =
                BufWriter::new(File::create(&output).with_context(|| format!("cannot create {}", output.display()))?);
            let summary = replay::replay(&config, reader, writer, smooth)?;
            eprint!("{summary}");
            Ok(())
        }
    }
}
