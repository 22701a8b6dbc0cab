//! Helpers shared by the daemon's integration tests.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::replay::OutputLine;
use fusion_shared::jsonl::format_sample;

/// The config used by the reference tests, with or without gating.
pub fn linear_config(gating: Option<f64>) -> String {
    let mut c = String::from(
        "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n\n[filter]\ninitial_state = [0, 0, 0, 0, 0, 0]\n\
         initial_covariance_diagonal = [100, 100, 100, 10, 10, 10]\nhistory_ns = 1_000_000_000\n",
    );
    if let Some(p) = gating {
        c.push_str(&format!("\n[gating]\nprobability = {p}\n"));
    }
    c
}

/// Writes a scenario's samples as replay input, in arrival order.
pub fn write_input(path: &Path, scenario: &Scenario) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for a in &scenario.arrivals {
        writeln!(f, "{}", format_sample(&a.sample)).unwrap();
    }
}

/// Runs the real `fusiond replay` and returns its output lines and stderr.
pub fn run_replay(dir: &Path, config: &str, input: &Path, smooth: bool) -> (Vec<OutputLine>, String) {
    let config_path = dir.join("config.toml");
    std::fs::write(&config_path, config).unwrap();
    let output: PathBuf = dir.join(if smooth { "smoothed.jsonl" } else { "filtered.jsonl" });
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fusiond"));
    cmd.arg("replay").arg("--config").arg(&config_path).arg("--input").arg(input).arg("--output").arg(&output);
    if smooth {
        cmd.arg("--smooth");
    }
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "fusiond replay failed: {stderr}");
    let lines = std::fs::read_to_string(&output).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    (lines, stderr)
}

/// The scenario of the acceptance check: 20 s, 200 Hz IMU with timestamp jitter,
/// 10 Hz positions arriving 20–120 ms late.
pub fn acceptance_scenario(seed: u64, outlier_probability: f64) -> Scenario {
    let mut c = ScenarioConfig { seed, duration_s: 20.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.imu.jitter_ns = 1_000_000;
    c.imu.accel_noise_std = 0.1;
    c.position.delay_min_ns = 20_000_000;
    c.position.delay_max_ns = 120_000_000;
    c.position.outlier_probability = outlier_probability;
    Scenario::generate(&c)
}

pub mod live;
