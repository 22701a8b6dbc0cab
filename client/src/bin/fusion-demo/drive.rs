//! What the demo watches while the car drives (the snapshots against the truth,
//! a status line) and what it says after.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use fusion_client::sim::CarTrajectory;
use fusion_client::{StateSubscriber, now_ns};
use fusion_shared::snapshot::{INPUT_NONE, StateSnapshot};
use hdrhistogram::Histogram;

use super::Args;
use super::status::{Status, describe, rate_hz, say};

/// What the snapshots showed over the drive.
pub struct Seen {
    /// Sample published → snapshot received, ns.
    pub latency: Histogram<u64>,
    /// Squared position errors after the first second, and their count.
    sum_sq: f64,
    n_err: u64,
    /// The last snapshot and its position error, m.
    pub last: Option<(StateSnapshot, f64)>,
    /// Health as of the last snapshot a sample triggered (later ones only say
    /// the sensors stopped).
    drive_health: Option<(u32, u32)>,
    /// While the car stands: snapshots of samples then, how many of them say
    /// standing, the estimate's position when it stopped and its largest move.
    stood: u64,
    found_standing: u64,
    stop_at: Option<[f64; 3]>,
    stop_drift: f64,
    /// Each outage's horizontal error and its 1σ at its end (the first
    /// snapshot after it).
    outage_ends: Vec<Option<(f64, f64)>>,
}

impl Seen {
    fn new(outages: usize) -> anyhow::Result<Self> {
        Ok(Self {
            latency: Histogram::<u64>::new_with_bounds(1, 10_000_000_000, 3)?,
            sum_sq: 0.0,
            n_err: 0,
            last: None,
            drive_health: None,
            stood: 0,
            found_standing: 0,
            stop_at: None,
            stop_drift: 0.0,
            outage_ends: vec![None; outages],
        })
    }

    /// Takes snapshot `s` at drive time `t` (s) with position error `err` (m).
    fn observe(&mut self, args: &Args, truth: &CarTrajectory, s: &StateSnapshot, t: f64, err: f64) {
        let x = s.state();
        // Error statistics after the first second of fixes (the filter starts from x0 = 0).
        if t > 1.0 && err.is_finite() {
            self.sum_sq += err * err;
            self.n_err += 1;
        }
        self.last = Some((*s, err));
        for (o, seen) in args.outage.iter().zip(&mut self.outage_ends) {
            if seen.is_none() && t >= o.at_s + o.duration_s && x.len() >= 3 && s.cov_dim >= 2 {
                let p = truth.at(t).pos_m;
                let n = s.cov_dim as usize;
                let sd = (s.cov[0].max(0.0) + s.cov[n + 1].max(0.0)).sqrt();
                *seen = Some((((x[0] - p.x).powi(2) + (x[1] - p.y).powi(2)).sqrt(), sd));
            }
        }
        if s.input_kind == INPUT_NONE {
            return;
        }
        self.drive_health = Some((s.health, s.health_reasons));
        if x.len() >= 3 && truth.standing(t) {
            self.stood += 1;
            self.found_standing += u64::from(s.standing());
            let at = *self.stop_at.get_or_insert([x[0], x[1], x[2]]);
            self.stop_drift = self.stop_drift.max(((x[0] - at[0]).powi(2) + (x[1] - at[1]).powi(2)).sqrt());
        } else {
            self.stop_at = None;
        }
    }
}

/// Reads the snapshots until the drive ends (or a signal sets `stop`): each
/// against the truth (written to `truth_path` for the report), a status line.
pub fn watch(
    args: &Args,
    truth: &CarTrajectory,
    state: &mut StateSubscriber,
    start_ns: u64,
    stop: &AtomicBool,
    truth_path: &Path,
) -> anyhow::Result<Seen> {
    let mut truth_file = std::io::BufWriter::new(std::fs::File::create(truth_path)?);
    let mut seen = Seen::new(args.outage.len())?;
    let mut next_status = Instant::now();
    // On a terminal one status line redrawn 4 times a second; into a file or a
    // pipe a plain line every 5 s (redrawn lines would collapse into one).
    let terminal = std::io::stdout().is_terminal();
    // `\x1b[K` clears what a longer line before left.
    let (every, start_of_line, end_of_line) =
        if terminal { (Duration::from_millis(250), "\r", "\x1b[K") } else { (Duration::from_secs(5), "", "\n") };
    let end = Instant::now() + Duration::from_secs_f64(args.duration + 0.5);
    while !stop.load(Ordering::Relaxed) && Instant::now() < end {
        let Some(s) = state.wait_next(Duration::from_millis(50))? else { continue };
        let received = now_ns();
        if s.input_sent_ns > 0 && s.input_replayed == 0 {
            let _ = seen.latency.record(received.saturating_sub(s.input_sent_ns));
        }
        let x = s.state();
        let t = (s.t_ns as f64 - start_ns as f64) * 1e-9;
        let err = if t >= 0.0 && x.len() >= 3 {
            let at = truth.at(t);
            let p = at.pos_m;
            let line = serde_json::json!({"t_ns": s.t_ns, "pos": [p.x, p.y, p.z], "vel": [at.vel_mps.x, at.vel_mps.y, at.vel_mps.z]});
            writeln!(truth_file, "{line}")?;
            ((x[0] - p.x).powi(2) + (x[1] - p.y).powi(2) + (x[2] - p.z).powi(2)).sqrt()
        } else {
            f64::NAN
        };
        seen.observe(args, truth, s, t, err);
        if Instant::now() >= next_status {
            next_status = Instant::now() + every;
            let c = s.sensor_counters();
            let fixes = [fusion_shared::SampleKind::Position as u32, fusion_shared::SampleKind::Geodetic as u32];
            let pos = c.iter().find(|c| fixes.contains(&c.kind));
            let status = Status {
                t,
                pos: [x[0], x[1], x[2]],
                err,
                health: if s.standing() { format!("{}, standing", describe(s)) } else { describe(s) },
                fused: pos.map_or(0, |c| c.counts.fused),
                gated: pos.map_or(0, |c| c.counts.gated),
                p50_us: seen.latency.value_at_quantile(0.5) as f64 / 1e3,
            };
            // On a terminal the line fits its width (a wrapped line would fill the screen).
            let width =
                terminal.then(|| ratatui::crossterm::terminal::size().ok()).flatten().map(|(w, _)| usize::from(w));
            print!("{start_of_line}{}{end_of_line}", status.line(width));
            let _ = std::io::stdout().flush();
        }
    }
    if terminal {
        println!();
    }
    truth_file.flush()?;
    Ok(seen)
}

/// Each sensor's counts, the position error, the scale, the outages and the
/// stops, after the drive ending with `last`.
pub fn print_result(args: &Args, seen: &Seen, last: &(StateSnapshot, f64), start_ns: u64) {
    let (s, err) = last;
    let sd: Vec<f64> = s.std_devs().collect();
    let driven_s = (s.t_ns as f64 - start_ns as f64) * 1e-9;
    say(&format!("\nresult after {driven_s:.1} s of driving:"));
    for c in s.sensor_counters() {
        let kind = fusion_shared::SampleKind::from_code(c.kind);
        let n = &c.counts;
        // Samples of a sensor span (n − 1) periods from the start to its newest timestamp.
        let span_s = (c.last_t_ns as f64 - start_ns as f64) * 1e-9;
        let hz = kind.map_or(0.0, |k| rate_hz(n.received, span_s, k, &args.outage));
        let name = format!("{} {} ({hz:.0} Hz)", kind.map_or("?", |k| k.name()), c.sensor);
        // IMU samples propagate the state; only measurements are fused or gated.
        let what = if kind == Some(fusion_shared::SampleKind::Imu) {
            format!("propagated {}", n.processed)
        } else {
            // Refused by the model, not the gate: odometry before the attitude is known.
            let unused = n.processed.saturating_sub(n.fused + n.gated);
            let unused =
                if unused > 0 { format!(", {unused} before the filter could use them") } else { String::new() };
            format!("fused {}, gated {}{unused}", n.fused, n.gated)
        };
        say(&format!(
            "  {name:<21} received {}, {what}; out of order {} (processed exactly by rewind), too late {}, \
             invalid {}, lost {}",
            n.received, n.late, n.too_late, n.invalid, n.lost
        ));
    }
    say(&format!(
        "  position error vs truth: final {err:.3} m (1-sigma {:.3} / {:.3} / {:.3} m), RMS over the drive {:.3} m",
        sd[0],
        sd[1],
        sd[2],
        (seen.sum_sq / seen.n_err.max(1) as f64).sqrt()
    ));
    if let (Some(k), Some(sd)) = (s.odometry_scale(), s.odometry_scale_std()) {
        say(&format!("  odometry scale factor: estimated {k:.4} (1-sigma {sd:.4}), simulated 1.0100"));
    }
    for (o, end) in args.outage.iter().zip(&seen.outage_ends) {
        if let Some((e, sd)) = end {
            say(&format!(
                "  GNSS outage {:.0}-{:.0} s: horizontal error at its end {e:.2} m (1-sigma {sd:.2} m)",
                o.at_s,
                o.at_s + o.duration_s
            ));
        }
    }
    if seen.stood > 0 {
        say(&format!(
            "  while the car stood: fusiond found it standing in {:.1} % of the samples ({} standstill updates); \
             the estimate moved at most {:.3} m horizontally",
            100.0 * seen.found_standing as f64 / seen.stood as f64,
            s.standstill_updates,
            seen.stop_drift
        ));
    }
}

/// The end-to-end latency this reader saw, with `processes` sharing the cores.
pub fn print_latency(latency: &Histogram<u64>, processes: usize, wait: &str) {
    say(&format!(
        "  end-to-end latency, sample published -> snapshot received ({} samples, --wait {wait}):\n    p50 {:.1} us, \
         p90 {:.1} us, p99 {:.1} us, max {:.1} us",
        latency.len(),
        latency.value_at_quantile(0.5) as f64 / 1e3,
        latency.value_at_quantile(0.9) as f64 / 1e3,
        latency.value_at_quantile(0.99) as f64 / 1e3,
        latency.max() as f64 / 1e3,
    ));
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    say(&format!(
        "    (this reader sleeps on an event and {processes} processes share {cores} cores; the README's ~1 us is the \
         benchmark's busy-polling reader: cargo bench -p fusion-benches --bench latency)"
    ));
}

/// The health at the end of the drive, and after the sensors stopped if it
/// changed then (`last`: the last snapshot).
pub fn print_health(seen: &Seen, last: &StateSnapshot) {
    let during = seen.drive_health.map(|(health, reasons)| {
        let mut d = *last;
        (d.health, d.health_reasons) = (health, reasons);
        d
    });
    match during {
        Some(d) if (d.health, d.health_reasons) != (last.health, last.health_reasons) => say(&format!(
            "  health at the end of the drive: {}; after the sensors stopped: {}",
            describe(&d),
            describe(last)
        )),
        _ => say(&format!("  health at the end of the drive: {}", describe(last))),
    }
}
