//! The latency bench's report: its tables on stdout and `latency.json`.

use std::io::Write;

use fusion_benches::alloc::Window;
use fusion_benches::latency::{EndToEnd, LateCost, Mode, Trial};
use hdrhistogram::Histogram;
use serde_json::Value;

/// A latency row.
pub struct Row {
    /// As the table names it.
    pub name: String,
    pub mode: Mode,
    /// A raw row: its histogram holds round trips, reported halved.
    pub one_way: bool,
    /// Latency, ns.
    pub h: Histogram<u64>,
    /// The legs of an end-to-end row (trip in, daemon, trip out), where measured.
    pub legs: Option<EndToEnd>,
    /// Raw ping-pong round trips measured in blocks taking turns with this row's.
    pub raw_rtt: Option<Histogram<u64>>,
    /// A per-instant row (two IMU samples an instant): raw round trips with the
    /// same two-sample traffic, timed from the last ping, in the same blocks.
    pub raw_pair_rtt: Option<Histogram<u64>>,
    /// Per pair of blocks: end-to-end p50 / raw round-trip p50.
    pub block_ratios: Vec<f64>,
}

/// ns as `"1.23 us"`.
fn us(ns: u64) -> String {
    format!("{:.2} us", ns as f64 / 1e3)
}

/// Prints every table and writes `latency.json` into `out_dir`.
pub fn print_report(
    rows: &[Row],
    late_rows: &[(&str, Mode, LateCost)],
    throughput_rows: &[(&str, f64, Trial)],
    alloc_rows: &[(&str, Mode, Window)],
    quick: bool,
    out_dir: &std::path::Path,
) -> anyhow::Result<()> {
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
        "{:<42} {:>9} {:>9} {:>9} {:>9} {:>10} {:>7} {:>10} {:>14} {:>12}",
        "", "p50", "p90", "p99", "p99.9", "max", "count", "p50/RTT", "raw 1-way p50", "daemon p50"
    );
    let mut json = Vec::new();
    latency_table(rows, &mut json);
    legs_table(rows);
    instant_table(rows);
    late_table(late_rows, &mut json);
    late_legs_table(late_rows);
    throughput_table(throughput_rows, &mut json);
    alloc_table(alloc_rows, &mut json);
    let path = out_dir.join("latency.json");
    let mut f = std::fs::File::create(&path)?;
    writeln!(f, "{}", serde_json::to_string_pretty(&json)?)?;
    println!("written to {}", path.display());
    Ok(())
}

/// The latency rows, each against its raw round trip.
fn latency_table(rows: &[Row], json: &mut Vec<Value>) {
    let raw_rtt_p50 =
        |mode: Mode| rows.iter().find(|r| r.one_way && r.mode == mode).map(|r| r.h.value_at_quantile(0.5));
    for r in rows {
        // Raw rows report one way (RTT / 2); end-to-end rows are already one way.
        let div = if r.one_way { 2 } else { 1 };
        let q = |p: f64| r.h.value_at_quantile(p) / div;
        // Against the raw round trip measured in turns with this row's blocks (an
        // end-to-end time, or the round trip with the 4.2 KB answer), or else the
        // raw row of the same mode.
        let ratio = match &r.raw_rtt {
            Some(raw) => Some(r.h.value_at_quantile(0.5) as f64 / raw.value_at_quantile(0.5) as f64),
            None if !r.one_way => raw_rtt_p50(r.mode).map(|rtt| q(0.5) as f64 / rtt as f64),
            None => None,
        };
        let interleaved_one_way = r.raw_rtt.as_ref().map(|h| h.value_at_quantile(0.5) / 2);
        let leg = |f: fn(&EndToEnd) -> &Histogram<u64>, p: f64| r.legs.as_ref().map(|e| f(e).value_at_quantile(p));
        let daemon_p50 = leg(|e| &e.daemon, 0.5);
        let mut blocks = r.block_ratios.clone();
        blocks.sort_by(f64::total_cmp);
        println!(
            "{:<42} {:>9} {:>9} {:>9} {:>9} {:>10} {:>7} {:>10} {:>14} {:>12}",
            r.name,
            us(q(0.5)),
            us(q(0.9)),
            us(q(0.99)),
            us(q(0.999)),
            us(r.h.max() / div),
            r.h.len(),
            ratio.map_or_else(|| "-".into(), |x| format!("{x:.2}x")),
            interleaved_one_way.map_or_else(|| "-".into(), us),
            daemon_p50.map_or_else(|| "-".into(), us),
        );
        json.push(serde_json::json!({
            "name": r.name, "mode": r.mode.name(), "one_way_of_round_trip": r.one_way,
            "p50": q(0.5), "p90": q(0.9), "p99": q(0.99), "p999": q(0.999), "max": r.h.max() / div,
            "count": r.h.len(), "ratio_p50_to_raw_round_trip": ratio,
            "daemon_p50": daemon_p50, "daemon_p99": leg(|e| &e.daemon, 0.99),
            "to_daemon_p50": leg(|e| &e.to_daemon, 0.5), "from_daemon_p50": leg(|e| &e.from_daemon, 0.5),
            "raw_one_way_p50_interleaved": interleaved_one_way,
            "raw_two_sample_round_trip_p50": r.raw_pair_rtt.as_ref().map(|h| h.value_at_quantile(0.5)),
            "ratio_p50_to_raw_two_sample_round_trip": r.raw_pair_rtt.as_ref()
                .map(|h| r.h.value_at_quantile(0.5) as f64 / h.value_at_quantile(0.5) as f64),
            "block_ratios_min_median_max": (!blocks.is_empty())
                .then(|| [blocks[0], blocks[blocks.len() / 2], blocks[blocks.len() - 1]]),
        }));
    }
}

/// Where the end-to-end time goes, leg by leg.
fn legs_table(rows: &[Row]) {
    println!("\nwhere the end-to-end time goes (p50 of each leg; raw one way from the blocks in turn)");
    println!("{:<42} {:>12} {:>12} {:>12} {:>14}", "", "trip in", "daemon", "trip out", "raw one way");
    for r in rows {
        if let (Some(e), Some(raw)) = (&r.legs, &r.raw_rtt) {
            let p50 = |h: &Histogram<u64>| us(h.value_at_quantile(0.5));
            println!(
                "{:<42} {:>12} {:>12} {:>12} {:>14}",
                r.name,
                p50(&e.to_daemon),
                p50(&e.daemon),
                p50(&e.from_daemon),
                us(raw.value_at_quantile(0.5) / 2)
            );
        }
    }
}

/// The per-instant rows (two IMU samples an instant, timed from the last)
/// against both raw baselines measured in their blocks: one sample a round
/// trip, and the same two-sample traffic.
fn instant_table(rows: &[Row]) {
    println!("\nper-instant rows (from the instant's last IMU sample) against raw, p50");
    println!("{:<42} {:>10} {:>12} {:>8} {:>16} {:>8}", "", "fusiond", "raw RTT", "ratio", "raw 2-sample RTT", "ratio");
    for r in rows {
        if let (Some(raw), Some(pair)) = (&r.raw_rtt, &r.raw_pair_rtt) {
            let p50 = r.h.value_at_quantile(0.5);
            let (raw, pair) = (raw.value_at_quantile(0.5), pair.value_at_quantile(0.5));
            println!(
                "{:<42} {:>10} {:>12} {:>7.2}x {:>16} {:>7.2}x",
                r.name,
                us(p50),
                us(raw),
                p50 as f64 / raw as f64,
                us(pair),
                p50 as f64 / pair as f64
            );
        }
    }
}

/// The cost of a late fix and of the IMU samples behind it.
fn late_table(late_rows: &[(&str, Mode, LateCost)], json: &mut Vec<Value>) {
    println!(
        "\nlate position fix, 100 ms late at 1 kHz IMU (daemon time = snapshot published - sample received; \
         landed = late fix received -> settled snapshot published)"
    );
    println!(
        "{:<8} {:<6} {:>9} {:>13} {:>13} {:>17} {:>18} {:>10} {:>13} {:>12}",
        "model",
        "wait",
        "replayed",
        "late fix p50",
        "IMU step p50",
        "next IMU e2e p50",
        "other IMU e2e p50",
        "next/other",
        "next IMU p99",
        "landed p50"
    );
    for (model, mode, c) in late_rows {
        let replayed = c.replayed.value_at_quantile(0.5);
        let late = c.late_processing.value_at_quantile(0.5);
        let imu = c.imu_processing.value_at_quantile(0.5);
        let (next, other) = (c.next_after_late.value_at_quantile(0.5), c.normal.value_at_quantile(0.5));
        let landed = (!c.landed.is_empty()).then(|| c.landed.value_at_quantile(0.5));
        println!(
            "{:<8} {:<6} {:>9} {:>13} {:>13} {:>17} {:>18} {:>10} {:>13} {:>12}",
            model,
            mode.name(),
            replayed,
            us(late),
            us(imu),
            us(next),
            us(other),
            format!("{:.2}x", next as f64 / other.max(1) as f64),
            us(c.next_after_late.value_at_quantile(0.99)),
            landed.map_or_else(|| "-".into(), us),
        );
        json.push(serde_json::json!({
            "name": format!("late fix 100 ms at 1 kHz, {model}, {}", mode.name()), "replayed_p50": replayed,
            "late_fix_daemon_p50": late, "late_fix_daemon_p99": c.late_processing.value_at_quantile(0.99),
            "imu_daemon_p50": imu,
            "next_imu_e2e_p50": next, "next_imu_e2e_p99": c.next_after_late.value_at_quantile(0.99),
            "other_imu_e2e_p50": other, "next_over_other_p50": next as f64 / other.max(1) as f64,
            "landed_p50": landed, "landed_p99": landed.map(|_| c.landed.value_at_quantile(0.99)),
            "next_imu_provisional": c.next_provisional, "count": c.late_processing.len(),
            "overtaken": c.overtaken,
        }));
    }
}

/// Where the next IMU sample's time goes behind a late fix.
fn late_legs_table(late_rows: &[(&str, Mode, LateCost)]) {
    println!("where the next IMU sample's time goes (p50 of each leg; IMU first: its snapshot came before the fix's)");
    println!(
        "{:<8} {:<6} {:>12} {:>12} {:>12} {:>14} {:>10}",
        "model", "wait", "trip in", "daemon", "trip out", "provisional", "IMU first"
    );
    for (model, mode, c) in late_rows {
        let [to, daemon, from] = &c.next_legs;
        let p50 = |h: &Histogram<u64>| us(h.value_at_quantile(0.5));
        println!(
            "{:<8} {:<6} {:>12} {:>12} {:>12} {:>14} {:>10}",
            model,
            mode.name(),
            p50(to),
            p50(daemon),
            p50(from),
            format!("{} of {}", c.next_provisional, c.next_after_late.len()),
            c.overtaken
        );
    }
    let overtaken: u64 = late_rows.iter().map(|(_, _, c)| c.overtaken).sum();
    if overtaken > 0 {
        println!("({overtaken} IMU samples sent behind a late fix were published before the fix's snapshot)");
    }
}

/// The throughput trials, each rate also as a fraction of raw iceoryx2's
/// highest clean rate through a relay, measured in the same run.
fn throughput_table(throughput_rows: &[(&str, f64, Trial)], json: &mut Vec<Value>) {
    println!(
        "\nthroughput (spin daemon; one bench thread publishes in 100 us slices and busy-polls every snapshot in between; \
         raw: the same through a relay process that answers each sample with a 4.2 KB message, fusiond's buffers)"
    );
    println!(
        "{:<8} {:>12} {:>7} {:>10} {:>10} {:>8} {:>13}",
        "model", "rate", "× raw", "published", "received", "lost", "reader missed"
    );
    let raw = throughput_rows.iter().find(|(m, r, _)| *m == "raw" && *r < 0.0).map(|(_, _, t)| t.published as f64);
    let of_raw = |rate: f64| raw.filter(|r| *r > 0.0).map(|r| rate / r);
    for (model, rate, t) in throughput_rows {
        if *rate < 0.0 {
            let best = t.published as f64;
            match (model, of_raw(best)) {
                (&"raw", _) | (_, None) => println!("{model}: highest clean rate {best} samples/s"),
                (_, Some(f)) => println!(
                    "{model}: highest clean rate {best} samples/s = {f:.2} × raw iceoryx2's {} samples/s",
                    raw.unwrap_or(0.0)
                ),
            }
            json.push(serde_json::json!({
                "name": format!("max sustained IMU rate, {model}"), "rate_hz": best, "of_raw": of_raw(best),
            }));
            continue;
        }
        let f = of_raw(*rate).map_or("-".to_string(), |f| format!("{f:.2}"));
        println!(
            "{:<8} {:>10.0}/s {:>7} {:>10} {:>10} {:>8} {:>13}",
            model, rate, f, t.published, t.received, t.lost, t.reader_missed
        );
        json.push(serde_json::json!({
            "name": format!("throughput trial, {model}"), "rate_hz": rate, "of_raw": of_raw(*rate),
            "published": t.published, "received": t.received, "lost": t.lost, "reader_missed": t.reader_missed,
            "clean": t.clean(),
        }));
    }
}

/// The daemon loop's allocations per sample.
fn alloc_table(alloc_rows: &[(&str, Mode, Window)], json: &mut Vec<Value>) {
    println!("\nallocations of the daemon loop (fusiond run's, on a counted thread of this process), steady state");
    println!(
        "{:<8} {:<6} {:>9} {:>10} {:>12} {:>11}",
        "model", "wait", "samples", "snapshots", "allocations", "per sample"
    );
    for (model, mode, w) in alloc_rows {
        let per_sample = w.allocations() as f64 / w.samples.max(1) as f64;
        println!(
            "{:<8} {:<6} {:>9} {:>10} {:>12} {:>11}",
            model,
            mode.name(),
            w.samples,
            w.snapshots,
            w.allocations(),
            format!("{per_sample:.3}")
        );
        json.push(serde_json::json!({
            "name": format!("allocations, {model}, {}", mode.name()), "samples": w.samples,
            "snapshots": w.snapshots, "allocations": w.allocations(), "per_sample": per_sample,
            "sizes": w.sizes,
        }));
    }
}
