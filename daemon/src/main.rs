//! `fusiond`: the fusion daemon's command line.
//!
//! Thin: parses arguments, sets up tracing, and calls into the library.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use fusion_daemon::config::{Config, DEFAULT_CONFIG};
use fusion_daemon::replay;

#[derive(Parser)]
#[command(name = "fusiond", version, about = "Low-latency Kalman-filter sensor fusion daemon")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
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
        Command::PrintConfig => {
            print!("{DEFAULT_CONFIG}");
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
