//! Latency of fusiond beside the floor set by raw iceoryx2, measured in one run:
//! a table on stdout and `target/fusion-bench/latency.json` (numbers in ns).
//! `FUSION_BENCH_QUICK=1` takes a short sample; `FUSION_BENCH_IMU_HZ` sets the IMU
//! rate of the end-to-end rows (default 1000). See the README's performance section.

#![allow(missing_docs)]

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::Context;
use fusion_benches::latency::{ChildGuard, Mode, end_to_end, ping, pong, start_daemon};
use fusion_client::Client;
use hdrhistogram::Histogram;

const LINEAR: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
    initial_covariance_diagonal = [100,100,100,10,10,10]\n[gating]\nprobability = 0.999\n";
const INS: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
    initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
    initial_covariance_diagonal = [1,1,1, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
    [gating]\nprobability = 0.999\n";

struct Row {
    name: String,
    mode: Mode,
    one_way: bool,
    h: Histogram<u64>,
}

fn main() -> anyhow::Result<()> {
    // The pong role: this same binary, re-executed.
    if let Ok(base) = std::env::var("FUSION_BENCH_PONG") {
        let mode = Mode::parse(&std::env::var("FUSION_BENCH_MODE")?).context("mode")?;
        return pong(&base, mode);
    }
    // `cargo bench` passes --bench; with a filter argument that excludes "latency", do nothing.
    let filters: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    if !filters.is_empty() && !filters.iter().any(|f| "latency".contains(f.as_str()) || f.contains("latency")) {
        return Ok(());
    }
    let quick = std::env::var("FUSION_BENCH_QUICK").is_ok_and(|v| v != "0");
    let (raw_count, e2e_count) = if quick { (2_000, 8_000) } else { (10_000, 10_000) };
    let imu_hz: f64 = std::env::var("FUSION_BENCH_IMU_HZ").ok().and_then(|v| v.parse().ok()).unwrap_or(1000.0);

    // The daemon binary, built as cargo bench builds (release).
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--quiet", "--release", "-p", "fusion-daemon", "--bin", "fusiond"])
        .current_dir(&root)
        .status()?;
    anyhow::ensure!(status.success(), "building fusiond failed");
    let target = std::env::var("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|_| root.join("target"));
    let fusiond = target.join("release").join("fusiond");
    let out_dir = target.join("fusion-bench");
    std::fs::create_dir_all(&out_dir)?;
    let pid = std::process::id();

    let mut rows = Vec::new();
    for mode in [Mode::Spin, Mode::Event] {
        let base = format!("fusion-bench-{pid}-raw-{}", mode.name());
        let child = Command::new(std::env::current_exe()?)
            .env("FUSION_BENCH_PONG", &base)
            .env("FUSION_BENCH_MODE", mode.name())
            .stdout(Stdio::null())
            .spawn()?;
        let mut guard = ChildGuard(child);
        let h = ping(&base, mode, raw_count, imu_hz, &mut guard)?;
        rows.push(Row { name: format!("raw iceoryx2 ping-pong, {}", mode.name()), mode, one_way: true, h });
    }
    for (model, config, imu) in
        [("linear", LINEAR, ([0.1, 0.0, 0.0], [0.0; 3])), ("ins", INS, ([0.0, 0.0, 9.80665], [0.0; 3]))]
    {
        for mode in [Mode::Spin, Mode::Event] {
            let namespace = format!("fusion-bench-{pid}-{model}-{}", mode.name());
            let dir = std::env::temp_dir();
            let _daemon = start_daemon(&fusiond, &dir, config, &namespace, mode)?;
            let client = Client::connect(&namespace)?;
            let started = Instant::now();
            while client.state_subscriber().is_err() {
                anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "fusiond did not start");
                std::thread::sleep(Duration::from_millis(20));
            }
            let h = end_to_end(&client, mode, e2e_count, imu_hz, imu)?;
            rows.push(Row { name: format!("fusiond {model}, --wait {}", mode.name()), mode, one_way: false, h });
            let _ = std::fs::remove_file(dir.join(format!("{namespace}.toml")));
        }
    }

    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_default();
    println!(
        "\nfusiond latency ({} cores, {cpu}){}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        if quick { ", quick" } else { "" }
    );
    println!(
        "{:<34} {:>9} {:>9} {:>9} {:>9} {:>10} {:>8} {:>16}",
        "", "p50", "p90", "p99", "p99.9", "max", "count", "p50 / raw RTT"
    );
    let mut json = Vec::new();
    let raw_rtt_p50 = |mode: Mode, rows: &[Row]| {
        rows.iter().find(|r| r.one_way && r.mode == mode).map(|r| r.h.value_at_quantile(0.5))
    };
    for r in &rows {
        // Raw rows report one way (RTT / 2); end-to-end rows are already one way.
        let div = if r.one_way { 2 } else { 1 };
        let q = |p: f64| r.h.value_at_quantile(p) / div;
        let ratio = if r.one_way { None } else { raw_rtt_p50(r.mode, &rows).map(|rtt| q(0.5) as f64 / rtt as f64) };
        let us = |ns: u64| format!("{:.2} us", ns as f64 / 1e3);
        println!(
            "{:<34} {:>9} {:>9} {:>9} {:>9} {:>10} {:>8} {:>16}",
            format!("{}{}", r.name, if r.one_way { " (one way)" } else { "" }),
            us(q(0.5)),
            us(q(0.9)),
            us(q(0.99)),
            us(q(0.999)),
            us(r.h.max() / div),
            r.h.len(),
            ratio.map_or_else(|| "-".into(), |x| format!("{x:.2}x")),
        );
        json.push(serde_json::json!({
            "name": r.name, "mode": r.mode.name(), "one_way_of_round_trip": r.one_way,
            "p50": q(0.5), "p90": q(0.9), "p99": q(0.99), "p999": q(0.999), "max": r.h.max() / div,
            "count": r.h.len(), "ratio_p50_to_raw_round_trip": ratio,
        }));
    }
    let path = out_dir.join("latency.json");
    let mut f = std::fs::File::create(&path)?;
    writeln!(f, "{}", serde_json::to_string_pretty(&json)?)?;
    println!("written to {}", path.display());
    Ok(())
}
