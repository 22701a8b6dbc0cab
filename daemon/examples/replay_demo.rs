//! Replays the example drive shipped in `examples/` and prints the final estimate
//! and its error against the truth: `cargo run --release -p fusion-daemon --example replay_demo`.

use std::io::{BufRead, BufReader, BufWriter};
use std::path::Path;

use anyhow::Context;
use fusion_daemon::config::Config;
use fusion_daemon::replay::{OutputLine, replay};

fn main() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let examples = root.join("examples");
    let out_path = root.join("target").join("replay-demo-estimates.jsonl");
    std::fs::create_dir_all(out_path.parent().context("target dir")?)?;

    let config = Config::load(&examples.join("linear.toml"))?;
    let input = BufReader::new(std::fs::File::open(examples.join("drive.jsonl"))?);
    let summary = replay(&config, input, Some(BufWriter::new(std::fs::File::create(&out_path)?)), false)?;
    print!("{summary}");

    let truth: Vec<serde_json::Value> = BufReader::new(std::fs::File::open(examples.join("drive.truth.jsonl"))?)
        .lines()
        .map(|l| Ok(serde_json::from_str(&l?)?))
        .collect::<anyhow::Result<_>>()?;
    let truth_at = |t: u64| truth.iter().find(|v| v["t_ns"].as_u64() == Some(t));
    let vec3 = |v: &serde_json::Value| -> Vec<f64> { (0..3).map(|i| v[i].as_f64().unwrap_or(f64::NAN)).collect() };

    let estimates: Vec<OutputLine> = BufReader::new(std::fs::File::open(&out_path)?)
        .lines()
        .map(|l| Ok(serde_json::from_str(&l?)?))
        .collect::<anyhow::Result<_>>()?;
    let (mut sum_sq, mut n) = (0.0, 0);
    for e in &estimates {
        let t = truth_at(e.t_ns).context("truth for every sample")?;
        let p = vec3(&t["pos"]);
        sum_sq += (0..3).map(|i| (e.x[i] - p[i]).powi(2)).sum::<f64>();
        n += 1;
    }
    let last = estimates.last().context("no estimate")?;
    let t = truth_at(last.t_ns).context("truth at the end")?;
    let (p, v) = (vec3(&t["pos"]), vec3(&t["vel"]));
    let sd = |i: usize| last.p[i * 6 + i].sqrt();
    println!("\nfinal estimate at t = {:.3} s ({} processed samples):", last.t_ns as f64 * 1e-9, estimates.len());
    println!("  {:<10} {:>10} {:>10} {:>10} {:>9}", "", "estimate", "truth", "error", "1-sigma");
    for (i, name) in ["p_x m", "p_y m", "p_z m", "v_x m/s", "v_y m/s", "v_z m/s"].iter().enumerate() {
        let truth = if i < 3 { p[i] } else { v[i - 3] };
        println!("  {:<10} {:>10.3} {:>10.3} {:>10.3} {:>9.3}", name, last.x[i], truth, last.x[i] - truth, sd(i));
    }
    let err = ((0..3).map(|i| (last.x[i] - p[i]).powi(2)).sum::<f64>()).sqrt();
    println!("  position error {err:.3} m; RMS position error over the drive {:.3} m", (sum_sq / n as f64).sqrt());
    println!("estimates written to {}", out_path.display());
    Ok(())
}
