//! The f32/f64, Joseph/UDU study of `fusion_benches::precision`, printed as
//! Markdown tables (the figures of `docs/performance.md`):
//!
//! ```sh
//! cargo run --release -p fusion-benches --example precision -- [ins seconds, default 3600]
//! ```

use fusion_benches::precision::{compare, drives, ins_runs, linear_runs, table, time_ordered};

fn main() {
    let ins_seconds: f64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(3600.0);
    for (label, seconds, sd) in [
        ("linear, fixes σ 0.5 m", 600.0, 0.5),
        ("linear, fixes σ 1 mm", 600.0, 1e-3),
        ("linear, fixes σ 0.1 mm", 600.0, 1e-4),
    ] {
        let (scenario, model) = drives::linear(seconds, sd, 1);
        let samples = time_ordered(&scenario);
        let t = std::time::Instant::now();
        let rows = compare(&mut linear_runs(&model), &samples, |t| scenario.truth_at(t).pos_m);
        println!(
            "### {label}, {seconds} s, {} samples ({:.1} s)\n\n{}",
            samples.len(),
            t.elapsed().as_secs_f64(),
            table(&rows)
        );
    }
    for (label, sd) in [("ins, fixes σ 0.5 m", 0.5), ("ins, fixes σ 1 mm", 1e-3)] {
        let (scenario, model) = drives::ins(ins_seconds, sd, 2);
        let samples = time_ordered(&scenario);
        let t = std::time::Instant::now();
        let rows = compare(&mut ins_runs(&model), &samples, |t| scenario.truth_at(t).pos_m);
        println!(
            "### {label}, {ins_seconds} s, {} samples ({:.1} s)\n\n{}",
            samples.len(),
            t.elapsed().as_secs_f64(),
            table(&rows)
        );
    }
}
