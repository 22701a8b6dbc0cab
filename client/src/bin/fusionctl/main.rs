//! `fusionctl`: look at a running fusiond.
//!
//! - `fusionctl echo`: every snapshot as a JSON line in the replay output format,
//!   plus the input, health and counters.
//! - `fusionctl state`: the latest snapshot, for a person.
//! - `fusionctl record`: every input sample and snapshot to an MCAP file.
//! - `fusionctl plot`: a report (SVG and PNG) of a recording or a replay.
//! - `fusionctl top`: a live dashboard.
//! - `fusionctl foxglove`: the live run for the Foxglove app (WebSocket).

mod foxglove;
mod plot;
mod record;
mod top;

use std::io::Write;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use fusion_client::{Client, StateSnapshot, now_ns};
use fusion_shared::recording::SnapshotJson;
use fusion_shared::snapshot::{health, model, rejection};

#[derive(Parser)]
#[command(name = "fusionctl", version, about = "Inspect a running fusiond")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print snapshots as JSON lines (replay output format plus input, health and counters).
    Echo {
        /// Namespace of the services.
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
        /// Stop after this many snapshots.
        #[arg(long)]
        count: Option<u64>,
        /// Stop after this many seconds without a snapshot (exit 3, as
        /// `fusionctl state`, when fusiond runs but published none).
        #[arg(long, value_parser = seconds)]
        idle_timeout: Option<f64>,
    },
    /// Record every input sample and every snapshot to an MCAP file (Foxglove,
    /// PlotJuggler, `fusiond replay --input RUN.mcap`), until Ctrl-C.
    Record {
        /// The MCAP file to write.
        #[arg(long)]
        output: std::path::PathBuf,
        /// Namespace of the services.
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
        /// Stop after this many seconds.
        #[arg(long, value_parser = seconds)]
        duration: Option<f64>,
        /// Write uncompressed chunks (default: zstd).
        #[arg(long)]
        no_compression: bool,
        /// Seconds between writes of what was gathered as complete chunks,
        /// synced to the disk: a recorder killed or without power (ignition
        /// off) loses at most this much (readers use every complete chunk).
        #[arg(long, value_parser = seconds, default_value_t = record::DEFAULT_FLUSH_INTERVAL_S)]
        flush_interval: f64,
    },
    /// Write a report of a run (SVG and PNG): trajectory, errors or ±3σ bands,
    /// NIS per sensor with χ² bounds, latency histogram of a live recording.
    Plot {
        /// An MCAP recording, or a replay output (`fusiond replay --output`).
        #[arg(long)]
        input: std::path::PathBuf,
        /// With a replay output: the replay's input, for the fixes (JSON lines,
        /// or a ROS bag: its every sensor_msgs/NavSatFix topic, fused or not).
        #[arg(long)]
        samples: Option<std::path::PathBuf>,
        /// The truth (`fusion-sim record --truth`), for the errors.
        #[arg(long)]
        truth: Option<std::path::PathBuf>,
        /// Directory of the report.
        #[arg(long, default_value = "fusion-report")]
        output_dir: std::path::PathBuf,
    },
    /// A live dashboard: health, per-sensor rates and counters, estimate and σ,
    /// latency percentiles; `q` quits.
    Top {
        /// Namespace of the services.
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
    },
    /// Serve the live estimate, snapshots and samples over the Foxglove
    /// WebSocket protocol (open `ws://HOST:PORT` in the Foxglove app).
    Foxglove {
        /// Namespace of the services.
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
        /// Address to listen on (`0.0.0.0` for the vehicle network).
        #[arg(long, default_value = "127.0.0.1")]
        host: String,
        /// Port (0: any free one, printed at start).
        #[arg(long, default_value_t = 8765)]
        port: u16,
    },
    /// Print the latest snapshot for a person: state, standard deviations, health, counters, age.
    /// Exit status 3 when fusiond runs but has published no snapshot yet.
    State {
        /// Namespace of the services.
        #[arg(long, default_value = fusion_shared::service::DEFAULT_NAMESPACE,
              value_parser = fusion_shared::service::namespace_arg)]
        namespace: String,
        /// Seconds to wait for a first snapshot when fusiond has published none yet.
        #[arg(long, default_value_t = 1.0, value_parser = seconds)]
        wait: f64,
    },
}

fn kind_name(code: u32) -> &'static str {
    fusion_shared::SampleKind::from_code(code).map_or("none", |k| k.name())
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// A number of seconds: finite and not negative (else a usage error).
fn seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s >= 0.0 && Duration::try_from_secs_f64(s).is_ok() => Ok(s),
        _ => Err(format!("{text:?} is not a number of seconds (finite, not negative)")),
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("fusionctl: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::status_of(e.as_ref()))
        }
    }
}

/// Runs a command; its exit status ([`fusion_shared::exit`]).
fn run(cli: Cli) -> anyhow::Result<u8> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM, signal_hook::consts::SIGPIPE] {
        signal_hook::flag::register(signal, Arc::clone(&stop))?;
    }
    match cli.command {
        Command::Echo { namespace, count, idle_timeout } => echo(&namespace, count, idle_timeout, &stop),
        Command::Record { output, namespace, duration, no_compression, flush_interval } => {
            let duration = duration.map(Duration::from_secs_f64);
            let flush_interval = Duration::from_secs_f64(flush_interval);
            record_command(&namespace, &output, duration, !no_compression, flush_interval, &stop)
        }
        Command::Plot { input, samples, truth, output_dir } => {
            let (files, damage) = plot::run(&input, samples.as_deref(), truth.as_deref(), &output_dir)?;
            for f in files {
                println!("{}", f.display());
            }
            match damage {
                Some(damage) => Err(fusion_shared::exit::InputDamaged(damage).into()),
                None => Ok(fusion_shared::exit::SUCCESS),
            }
        }
        Command::Top { namespace } => top::run(&namespace, &stop).map(|()| fusion_shared::exit::SUCCESS),
        Command::Foxglove { namespace, host, port } => {
            foxglove::run(&namespace, &host, port, &stop).map(|()| fusion_shared::exit::SUCCESS)
        }
        Command::State { namespace, wait } => state(&namespace, wait),
    }
}

/// `fusionctl echo`: each snapshot as a JSON line, until `count`, the idle
/// timeout or a signal.
fn echo(namespace: &str, count: Option<u64>, idle_timeout: Option<f64>, stop: &AtomicBool) -> anyhow::Result<u8> {
    let client = Client::connect(namespace)?;
    let mut state = client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER)?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut printed = 0u64;
    let mut last = Instant::now();
    let idle = idle_timeout.map(Duration::from_secs_f64);
    // While fusiond has published nothing, say so once (it waited in silence).
    let started = Instant::now();
    let mut said = false;
    while !stop.load(Ordering::Relaxed) && count.is_none_or(|n| printed < n) {
        match state.wait_next(Duration::from_millis(100))? {
            Some(s) => {
                // A closed pipe (e.g. `| head`) ends the echo quietly.
                if serde_json::to_writer(&mut out, &SnapshotJson::from(s)).is_err() || writeln!(out).is_err() {
                    break;
                }
                printed += 1;
                last = Instant::now();
            }
            None => {
                let _ = out.flush();
                if printed == 0 && !said && started.elapsed() >= ECHO_SILENCE {
                    eprintln!(
                        "fusionctl echo: fusiond runs in namespace {namespace:?} but has published no \
                         snapshot yet (no sample has reached it: are the sensors publishing in this \
                         namespace?); waiting"
                    );
                    said = true;
                }
                if let Some(idle) = idle.filter(|&d| last.elapsed() >= d) {
                    let _ = out.flush();
                    if printed == 0 {
                        // As `fusionctl state` says it: fusiond runs, nothing yet.
                        eprintln!(
                            "fusionctl echo: fusiond runs in namespace {namespace:?} but published no \
                             snapshot in {:.1} s of --idle-timeout (no sample has reached it)",
                            idle.as_secs_f64()
                        );
                        return Ok(fusion_shared::exit::NO_STATE_YET);
                    }
                    break;
                }
            }
        }
    }
    let _ = out.flush();
    Ok(fusion_shared::exit::SUCCESS)
}

/// `fusionctl record`, and what it recorded on stderr.
fn record_command(
    namespace: &str,
    output: &std::path::Path,
    duration: Option<Duration>,
    compress: bool,
    flush_interval: Duration,
    stop: &AtomicBool,
) -> anyhow::Result<u8> {
    let c = record::run(namespace, output, duration, compress, flush_interval, stop)?;
    eprintln!(
        "fusionctl: recorded {} samples ({} not processed by fusiond) and {} snapshots to {}",
        c.samples,
        c.unreported,
        c.snapshots,
        output.display()
    );
    if !c.complete() {
        eprintln!(
            "fusionctl: the recording is incomplete: {} samples lost, {} snapshots lost, {} processed samples \
             missed; a replay will not equal the live run everywhere",
            c.samples_lost, c.snapshots_lost, c.missed
        );
    }
    Ok(fusion_shared::exit::SUCCESS)
}

/// `fusionctl state`: the latest snapshot, described (waiting up to `wait` s
/// for a first one).
fn state(namespace: &str, wait: f64) -> anyhow::Result<u8> {
    let client = Client::connect(namespace)?;
    let mut state = client.state_subscriber()?;
    anyhow::ensure!(
        state.fusiond_publishes(),
        "fusiond is not running in namespace {namespace:?}: it stopped (its state service stays while \
         readers such as a fusionctl top hold it open)"
    );
    let s = match state.latest()? {
        Some(s) => *s,
        None => match state.wait_next(Duration::from_secs_f64(wait))? {
            Some(s) => *s,
            None => {
                eprintln!(
                    "fusionctl: fusiond runs in namespace {namespace:?} but has published no snapshot yet \
                     (no sample has reached it)"
                );
                return Ok(fusion_shared::exit::NO_STATE_YET);
            }
        },
    };
    print!("{}", describe(&s));
    Ok(fusion_shared::exit::SUCCESS)
}

/// How long `fusionctl echo` waits for a first snapshot before it says so.
const ECHO_SILENCE: Duration = Duration::from_secs(2);

/// Each state's name and the index of its standard deviation in the covariance
/// (see [`fusion_client::Model::state_layout`]).
fn state_layout(s: &StateSnapshot) -> Vec<(String, Option<usize>)> {
    let layout: Vec<_> = s.state_layout().map(|(n, i)| (n.to_string(), i)).collect();
    if layout.is_empty() { (0..s.state().len()).map(|i| (format!("x[{i}]"), Some(i))).collect() } else { layout }
}

/// The health reasons of a snapshot, and which sensors are stale (`stale: imu 0`).
fn health_reasons(s: &StateSnapshot) -> Vec<String> {
    // `nis out of bounds: odometry 0`: which sensor disagrees with the filter.
    let mut reasons = s.health_reason_texts();
    let stale: Vec<String> = s.stale_sensor_counters().map(|c| format!("{} {}", kind_name(c.kind), c.sensor)).collect();
    if !stale.is_empty() {
        reasons.push(format!("stale: {}", stale.join(", ")));
    }
    reasons
}

/// Whether the estimate includes every sample received, or which late sample's
/// correction it still lacks.
fn settledness(s: &StateSnapshot) -> String {
    if s.settled() {
        format!("settled: includes every sample received ({} rewinds so far)\n", s.rewinds)
    } else {
        format!(
            "provisional: lacks the late sample at t = {:.6} s ({} later samples still to re-process)\n",
            s.pending_since_t_ns as f64 * 1e-9,
            s.pending_steps
        )
    }
}

/// The samples refused in validation, by reason, with what to do about each
/// (empty when none was).
fn refusals(s: &StateSnapshot) -> String {
    let total = s.rejected();
    if total == 0 {
        return String::new();
    }
    let mut o = format!("refused in validation since start: {total} samples\n");
    for (code, n) in s.rejection_counts() {
        let sensors: Vec<String> = s
            .sensor_counters()
            .iter()
            .filter(|c| c.rejection_codes().any(|c| c == code))
            .map(|c| format!("{} {}", kind_name(c.kind), c.sensor))
            .collect();
        let from = if sensors.is_empty() { String::new() } else { format!(" (from {})", sensors.join(", ")) };
        o += &format!("  {n} {}{from}: {}\n", rejection::name(code), rejection::advice(code));
    }
    if s.unknown_sensor > 0 {
        o += &format!(
            "  {} of them from sensors without a row (a refused sample takes none)\n",
            s.unknown_sensor.min(total)
        );
    }
    o
}

/// What `fusionctl state` prints of a snapshot: the health and its reasons,
/// the estimate and the sensors' counters.
fn describe(s: &StateSnapshot) -> String {
    let mut o = String::new();
    let age_ms = now_ns().saturating_sub(s.publish_ns) as f64 * 1e-6;
    let reasons = health_reasons(s);
    o += &if s.state().is_empty() {
        format!("snapshot {} published {age_ms:.1} ms ago: no estimate yet\n", s.seq)
    } else {
        format!(
            "model {}, snapshot {} published {age_ms:.1} ms ago, estimate at t = {:.6} s\n",
            model::name(s.model),
            s.seq,
            s.t_ns as f64 * 1e-9
        )
    };
    o += &format!(
        "health: {}{}\n",
        health::name(s.health),
        if reasons.is_empty() { String::new() } else { format!(" ({})", reasons.join(", ")) }
    );
    o += &refusals(s);
    o += &settledness(s);
    if s.standing() {
        o += &format!("standing still: attitude held, {} standstill updates so far\n", s.standstill_updates);
    } else if s.standstill_updates > 0 {
        o += &format!("moving ({} standstill updates so far)\n", s.standstill_updates);
    }
    if let Some((ns, sd, n)) = s.velocity_time_offset() {
        let (ms, sd_ms) = (ns * 1e-6, sd * 1e-6);
        o += &if s.velocity_time_offset_to_add_ms().is_some() {
            format!(
                "velocity stamps {ms:+.0} ± {sd_ms:.0} ms off beyond their time_offset_ns ({n} samples): \
                 add about {ms:.0} ms to it\n"
            )
        } else {
            format!("velocity stamps vs their time_offset_ns: {ms:+.1} ± {sd_ms:.1} ms ({n} samples)\n")
        };
    }
    o += &estimate_table(s);
    o += &sensor_table(s);
    o += &format!(
        "\n  samples of no sensor row: {}; filter re-initialisations: {}; readers refused: {}\n",
        s.unknown_sensor, s.reinitialisations, s.readers_refused
    );
    o
}

/// The estimate, a state a line with its 1-sigma, and the attitude in degrees.
fn estimate_table(s: &StateSnapshot) -> String {
    let mut o = String::new();
    o += "\n";
    let layout = state_layout(s);
    let sd: Vec<f64> = s.std_devs().collect();
    // The names' column as wide as the longest (the pose frame's auxiliary states).
    let w = layout.iter().map(|(n, _)| n.chars().count()).max().unwrap_or(0).max(12);
    o += &format!("  {:<w$} {:>14} {:>12}\n", "state", "value", "1-sigma");
    for (v, (name, k)) in s.state().iter().zip(&layout) {
        let sigma = k.and_then(|k| sd.get(k)).map_or_else(String::new, |v| format!("{v:.4}"));
        o += &format!("  {name:<w$} {v:>14.6} {sigma:>12}\n");
    }
    if let (Some(rpy), Some(sigma)) = (s.roll_pitch_yaw(), s.roll_pitch_yaw_std()) {
        let [r, p, y] = rpy.map(f64::to_degrees);
        let [sr, sp, sy] = sigma.map(f64::to_degrees);
        o += &format!(
            "  roll/pitch/yaw deg: {r:.3} / {p:.3} / {y:.3}, 1-sigma {sr:.3} / {sp:.3} / {sy:.3} (yaw from east, \
             counter-clockwise)\n"
        );
    }
    o
}

/// The sensors' counters, a sensor a line.
fn sensor_table(s: &StateSnapshot) -> String {
    let mut o = String::new();
    o += &format!(
        "\n  {:<14} {:>9} {:>9} {:>7} {:>7} {:>6} {:>8} {:>9} {:>7} {:>6} {:>12} {:>8} {:>9}\n",
        "sensor",
        "received",
        "fused",
        "gated",
        "refused",
        "late",
        "too late",
        "duplicate",
        "invalid",
        "lost",
        "rate limited",
        "restarts",
        "last NIS"
    );
    for c in s.sensor_counters() {
        o += &format!(
            "  {:<14} {:>9} {:>9} {:>7} {:>7} {:>6} {:>8} {:>9} {:>7} {:>6} {:>12} {:>8} {:>9}\n",
            format!("{} {}", kind_name(c.kind), c.sensor),
            c.counts.received,
            c.counts.fused,
            c.counts.gated,
            c.counts.refused,
            c.counts.late,
            c.counts.too_late,
            c.counts.duplicate,
            c.counts.invalid,
            c.counts.lost,
            c.counts.rate_limited,
            c.counts.restarts,
            finite(c.last_nis).map_or("-".into(), |v| format!("{v:.2}")),
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use fusion_client::StateSnapshot;
    use fusion_shared::snapshot::{aux, model, rejection};

    use super::describe;

    /// Every sample refused: no estimate, and why, with the setting to change
    /// and the sensors it came from.
    #[test]
    fn refusals_are_described_with_their_setting() {
        let mut s = StateSnapshot { unknown_sensor: 1072, ..Default::default() };
        s.rejections[rejection::PAST_TIMESTAMP as usize] = 1072;
        let text = describe(&s);
        assert!(text.contains("no estimate yet"), "{text}");
        assert!(text.contains("refused in validation since start: 1072 samples"), "{text}");
        assert!(
            text.contains("1072 timestamp too far in the past: ") && text.contains("[validation] max_past_ns"),
            "{text}"
        );
        assert!(text.contains("1072 of them from sensors without a row"), "{text}");
        // A sensor with a row names itself.
        s.sensor_count = 1;
        s.sensors[0].kind = 1;
        s.sensors[0].rejection_reasons = 1 << rejection::PAST_TIMESTAMP;
        assert!(describe(&s).contains("in the past (from imu 0)"), "{}", describe(&s));
        assert!(!describe(&StateSnapshot::default()).contains("refused in validation"));
    }

    /// `nis out of bounds` names the sensor (a fleet monitor could not tell
    /// the wheels at a traffic light from a failing receiver).
    #[test]
    fn an_inconsistent_nis_names_its_sensor() {
        use fusion_shared::snapshot::health;
        let mut s = StateSnapshot {
            health: health::DEGRADED,
            health_reasons: health::NIS_OUT_OF_BOUNDS,
            sensor_count: 2,
            nis_sensors: 0b10,
            ..Default::default()
        };
        s.sensors[0].kind = fusion_shared::SampleKind::Imu as u32;
        s.sensors[1].kind = fusion_shared::SampleKind::Odometry as u32;
        assert_eq!(super::health_reasons(&s), vec!["nis out of bounds: odometry 0".to_string()]);
        let json = fusion_shared::recording::SnapshotJson::from(&s);
        assert_eq!((json.nis_sensors[0].kind.as_str(), json.nis_sensors.len()), ("odometry", 1));
    }

    /// An ins snapshot with the odometry scale state and a velocity time offset
    /// estimate: the state table names the scale with its σ, and the offset
    /// line says what to add.
    #[test]
    fn the_state_names_auxiliary_states_and_the_offset_advice() {
        let mut s = StateSnapshot {
            model: model::INS,
            state_len: 17,
            cov_dim: 16,
            aux_states: aux::ODOMETRY_SCALE,
            velocity_offset_ns: 52.4e6,
            velocity_offset_std_ns: 3.1e6,
            velocity_offset_samples: 600,
            ..Default::default()
        };
        s.x[6] = 1.0;
        s.x[16] = 1.0123;
        (0..16).for_each(|i| s.cov[i * 16 + i] = 1e-6);
        let text = describe(&s);
        assert!(text.contains("odometry_scale") && text.contains("1.012300") && text.contains("0.0010"), "{text}");
        assert!(text.contains("+52 ± 3 ms off") && text.contains("add about 52 ms"), "{text}");
        s.velocity_offset_ns = 4.0e6;
        assert!(describe(&s).contains("velocity stamps vs their time_offset_ns: +4.0 ± 3.1 ms"), "{}", describe(&s));
        // A row's refusals by the model have their column, after the gated.
        s.sensor_count = 1;
        s.sensors[0].kind = fusion_shared::SampleKind::Magnetometer as u32;
        (s.sensors[0].counts.received, s.sensors[0].counts.gated, s.sensors[0].counts.refused) = (60, 1, 40);
        let text = describe(&s);
        let header = text.lines().find(|l| l.trim_start().starts_with("sensor ")).unwrap();
        let row = text.lines().find(|l| l.contains("magnetometer 0")).unwrap();
        let columns: Vec<&str> = header.split_whitespace().collect();
        let refused = columns.iter().position(|c| *c == "refused").expect("a refused column");
        // The row has one more word than the header ("magnetometer 0" and "sensor").
        assert_eq!(row.split_whitespace().nth(refused + 1), Some("40"), "{header}\n{row}");
    }
}
