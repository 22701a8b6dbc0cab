//! `fusion-sim`: simulated IMU and position sensors on one ground-truth trajectory.
//!
//! `fusion-sim record` writes a drive as replay input (JSON lines, arrival order)
//! and its truth (JSON lines, one per sample, timestamp order).

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::jsonl::format_sample;

#[derive(Parser)]
#[command(name = "fusion-sim", version, about = "Simulated IMU and position sensors for fusiond")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write a simulated drive to files: samples in arrival order, and the truth.
    Record {
        /// Samples (replay input format).
        #[arg(long)]
        output: PathBuf,
        /// Truth at every sample time: {"t_ns", "pos", "vel", "acc"} per line.
        #[arg(long)]
        truth: Option<PathBuf>,
        #[command(flatten)]
        sim: SimArgs,
    },
}

/// Sensor and trajectory settings.
#[derive(Args, Clone)]
struct SimArgs {
    /// Seed of the trajectory and all noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of the drive, s.
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// IMU rate, Hz.
    #[arg(long, default_value_t = 400.0)]
    imu_rate: f64,
    /// IMU timestamp jitter, ± µs.
    #[arg(long, default_value_t = 0)]
    imu_jitter_us: u64,
    /// IMU acceleration noise, m/s² per sample.
    #[arg(long, default_value_t = 0.05)]
    accel_noise: f64,
    /// Position rate, Hz.
    #[arg(long, default_value_t = 10.0)]
    position_rate: f64,
    /// Horizontal position noise, m (vertical: 1.6×).
    #[arg(long, default_value_t = 0.5)]
    position_noise: f64,
    /// Smallest position delay, ms.
    #[arg(long, default_value_t = 20)]
    position_delay_min_ms: u64,
    /// Largest position delay, ms.
    #[arg(long, default_value_t = 120)]
    position_delay_max_ms: u64,
    /// Probability of a lost fix.
    #[arg(long, default_value_t = 0.0)]
    dropouts: f64,
    /// Probability of a gross outlier.
    #[arg(long, default_value_t = 0.0)]
    outliers: f64,
    /// Trajectory time 0 as a sample timestamp, ns.
    #[arg(long, default_value_t = 1_000_000_000)]
    start_ns: u64,
}

impl SimArgs {
    fn scenario(&self) -> ScenarioConfig {
        let mut c = ScenarioConfig {
            seed: self.seed,
            duration_s: self.duration,
            start_ns: self.start_ns,
            ..Default::default()
        };
        c.imu.rate_hz = self.imu_rate;
        c.imu.jitter_ns = self.imu_jitter_us * 1000;
        c.imu.accel_noise_std = self.accel_noise;
        c.position.rate_hz = self.position_rate;
        c.position.noise_std_m = self.position_noise;
        c.position.vertical_noise_std_m = 1.6 * self.position_noise;
        c.position.delay_min_ns = self.position_delay_min_ms * 1_000_000;
        c.position.delay_max_ns = self.position_delay_max_ms * 1_000_000;
        c.position.dropout_probability = self.dropouts;
        c.position.outlier_probability = self.outliers;
        c
    }
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Record { output, truth, sim } => {
            let scenario = Scenario::generate(&sim.scenario());
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
                    let line =
                        serde_json::json!({"t_ns": t, "pos": v(s.pos_m), "vel": v(s.vel_mps), "acc": v(s.acc_mps2)});
                    writeln!(out, "{line}")?;
                }
                out.flush()?;
            }
            eprintln!("fusion-sim: wrote {} samples to {}", scenario.arrivals.len(), output.display());
            Ok(())
        }
    }
}
