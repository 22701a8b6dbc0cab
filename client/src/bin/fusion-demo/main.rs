//! `fusion-demo` (run it with `./demo`): fusiond and simulated sensors as separate
//! processes over iceoryx2, a live status line, then the position error against
//! the truth and the end-to-end latency.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::{Parser, ValueEnum};
mod status;

use fusion_client::sim::{CarTrajectory, FixPhase, Outage, Stop};
use fusion_client::{Client, now_ns};
use fusion_shared::snapshot::INPUT_NONE;
use hdrhistogram::Histogram;
use status::{Status, describe, rate_hz};

#[derive(Parser)]
#[command(name = "fusion-demo", about = "fusiond with simulated IMU and position sensors, as separate processes")]
struct Args {
    /// Seconds to run, at least 1 (Ctrl-C ends it early).
    #[arg(long, default_value_t = 10.0, value_parser = drive_seconds)]
    duration: f64,
    /// fusiond's wait mode: event (sleeps between samples) or spin (busy-polls one core).
    #[arg(long, value_enum, default_value_t = Wait::Event)]
    wait: Wait,
    /// Seed of the drive.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// Filter model: `linear` (the IMU gives world acceleration) or `ins` (a real
    /// IMU: body specific force and rates with noise and biases, error-state INS).
    #[arg(long, value_enum, default_value_t = ModelArg::Linear)]
    model: ModelArg,
    /// A stop of the car, `AT:SECONDS`: it brakes from AT s into the drive, stands
    /// for SECONDS and drives off (repeat for more stops). With `--model ins`
    /// fusiond detects it and holds the estimate still.
    #[arg(long, value_name = "AT:SECONDS")]
    stop: Vec<Stop>,
    /// A GNSS outage (a tunnel), `AT:SECONDS`: no GNSS sample valid from AT s into
    /// the drive for SECONDS (repeat for more). The report gives the error and its
    /// σ at the end of each.
    #[arg(long, value_name = "AT:SECONDS")]
    outage: Vec<Outage>,
    /// The GNSS receiver's fix type from AT s on, `AT:TYPE` (`rtk_fixed`,
    /// `rtk_float`, `3d`, `none`; repeat, in order): its noise and the accuracy it
    /// reports change with it, and fusiond maps them to noise (`[sensor.quality]`).
    /// With `--model ins`.
    #[arg(long, value_name = "AT:TYPE")]
    fix_phase: Vec<FixPhase>,
    /// How late the GNSS receiver's clock is, ms (its fixes and velocities are
    /// stamped that late); the demo's configuration says so (`time_offset_ns`).
    /// With `--model ins`.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=10_000))]
    gnss_clock_lag_ms: u64,
}

/// `fusiond run --wait`.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum Wait {
    Event,
    Spin,
}

/// `--model`.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ModelArg {
    Linear,
    Ins,
}

/// A drive's length: at least 1 s, at most a day.
fn drive_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if (1.0..=86_400.0).contains(&s) => Ok(s),
        _ => Err(format!("{text:?} is not a number of seconds from 1 to 86400")),
    }
}

/// The IMU rate of the `linear` demo (fusion-sim's default), Hz.
const LINEAR_IMU_HZ: u32 = 400;
/// The IMU rate of the `ins` demo, Hz.
const INS_IMU_HZ: u32 = 200;

/// The `ins` demo: a car with a GNSS receiver (latitude/longitude/height and
/// Doppler velocity of an antenna 1.5 m from the IMUs), two IMUs on one clock
/// mounted differently (one publishing forward-right-down axes), and wheel odometry.
const INS_CONFIG: &str = r#"[model]
kind = "ins"
accelerometer_noise_density = 0.02
gyroscope_noise_density = 0.001
accelerometer_random_walk = 0.001
gyroscope_random_walk = 1.0e-5

[filter]
# at the origin, moving ~10 m/s east-ish, heading unknown (1 rad), biases unknown
initial_state = [0, 0, 0, 10, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]
initial_covariance_diagonal = [1, 1, 1, 100, 100, 4, 0.01, 0.01, 1, 0.0025, 0.0025, 0.0025, 1e-6, 1e-6, 1e-6]
history_ns = 1_000_000_000

[gating]
probability = 0.999

[model.alignment]
# the heading, unknown at start, from the GNSS course once the car drives 3 m/s
heading_from_velocity_mps = 3.0

[model.constraints]
# a car: no sideways or vertical body velocity, up to 0.1 m/s
nonholonomic_std_mps = 0.1

[model.standstill]
# standing still (a traffic light): zero velocity and rate, the attitude held

[model.odometry_scale]
# worn tyres: the odometry's scale factor is estimated (a state), 2 % at start
initial_std = 0.02

[datum]
# where the drive starts: Theresienwiese, Munich
latitude_deg = 48.1316
longitude_deg = 11.5494
height_m = 519.0

[[sensor]]
name = "gnss"
id = 3
kinds = ["geodetic", "velocity"]
lever_arm_m = [1.0, 0.5, 1.0]
time_offset_ns = 0

[sensor.quality]
# what each fix type is worth (the receiver's own accuracy is optimistic)
refuse = ["none", "2d"]
horizontal_floor_m = { rtk_fixed = 0.02, rtk_float = 0.3, "3d" = 1.5 }
vertical_floor_m = { rtk_fixed = 0.03, rtk_float = 0.5, "3d" = 2.5 }

[[sensor]]
name = "imu-a"
id = 0
kinds = ["imu"]
axes = "frd"
rotation_rpy_deg = [3.0, -2.0, 90.0]

[[sensor]]
name = "imu-b"
id = 1
kinds = ["imu"]
rotation_rpy_deg = [-1.5, 2.5, -90.0]

[[sensor]]
name = "wheels"
id = 0
kinds = ["odometry"]
lever_arm_m = [-1.3, 0.0, -0.3]

[imu]
combine = "average"
"#;

/// The mounts of the demo's IMUs, as `fusion-sim --imu-mount` takes them (the
/// same as `INS_CONFIG`'s).
const INS_IMU_MOUNTS: [&str; 4] = ["--imu-mount", "frd:3,-2,90", "--imu-mount", "flu:-1.5,2.5,-90"];

/// The demo's GNSS receiver and odometry, as `fusion-sim` takes them.
const INS_AIDING: [&str; 15] = [
    "--position-rate",
    "0",
    "--geodetic-rate",
    "10",
    "--velocity-rate",
    "10",
    "--lever-arm",
    "1.0,0.5,1.0",
    "--odometry-rate",
    "50",
    "--odometry-lever-arm",
    "-1.3,0,-0.3",
    "--odometry-scale-error",
    "0.01",
    "--odometry-noise-only-variance",
];

const CONFIG: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n\n[filter]\n\
    initial_state = [0, 0, 0, 0, 0, 0]\n# the car is already moving: sigma_v 15 m/s\n\
    initial_covariance_diagonal = [100, 100, 100, 225, 225, 225]\nhistory_ns = 1_000_000_000\n\n\
    [gating]\nprobability = 0.999\n";

struct Children(Vec<(&'static str, Child)>);

impl Children {
    fn stop(&mut self) {
        for (_, c) in &mut self.0 {
            let _ = Command::new("kill").args(["-TERM", &c.id().to_string()]).status();
        }
        for (name, c) in &mut self.0 {
            let deadline = Instant::now() + Duration::from_secs(5);
            loop {
                match c.try_wait() {
                    Ok(Some(_)) => break,
                    _ if Instant::now() > deadline => {
                        eprintln!("fusion-demo: {name} did not stop; killing it");
                        let _ = c.kill();
                        let _ = c.wait();
                        break;
                    }
                    _ => std::thread::sleep(Duration::from_millis(10)),
                }
            }
        }
        self.0.clear();
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        self.stop();
    }
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusion-demo: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::FAILURE)
        }
    }
}

/// The last line of a log that says something (fusiond's reason for stopping).
fn last_line(path: &std::path::Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no log").trim().to_string()
}

fn run(args: Args) -> anyhow::Result<()> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))?;
    }
    let bin_dir = std::env::current_exe()?.parent().context("binary directory")?.to_path_buf();
    let bin = |name: &str| -> anyhow::Result<PathBuf> {
        let p = bin_dir.join(name);
        if !p.exists() {
            bail!("{} not found: build the workspace first (./demo does)", p.display());
        }
        Ok(p)
    };
    let truth = CarTrajectory::new(args.seed).with_stops(&args.stop).map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
    let mut stops: Vec<String> =
        args.stop.iter().flat_map(|s| ["--stop".to_string(), format!("{}:{}", s.at_s, s.duration_s)]).collect();
    stops.extend(args.outage.iter().flat_map(|o| ["--outage".to_string(), format!("{}:{}", o.at_s, o.duration_s)]));
    if args.model != ModelArg::Ins && (!args.fix_phase.is_empty() || args.gnss_clock_lag_ms > 0) {
        bail!("--fix-phase and --gnss-clock-lag-ms need --model ins (a GNSS receiver with quality and a clock)");
    }
    stops.extend(
        args.fix_phase
            .iter()
            .flat_map(|p| ["--fix-phase".to_string(), format!("{}:{}", p.at_s, fusion_shared::fix::name(p.fix_type))]),
    );
    if args.gnss_clock_lag_ms > 0 {
        stops.extend(["--fix-clock-lag-ms".to_string(), args.gnss_clock_lag_ms.to_string()]);
    }
    let work = bin_dir.join("demo");
    std::fs::create_dir_all(&work)?;
    let ins = args.model == ModelArg::Ins;
    let (model, wait) = (if ins { "ins" } else { "linear" }, if args.wait == Wait::Spin { "spin" } else { "event" });
    let imu_hz = if ins { INS_IMU_HZ } else { LINEAR_IMU_HZ };
    let imu_rate = imu_hz.to_string();
    let (config_text, imu_args): (&str, &[&str]) = match args.model {
        ModelArg::Linear => (CONFIG, &["--imu-rate", &imu_rate]),
        // Automotive MEMS (Kalibr densities as configured), 200 Hz, 5 mg / ~100 deg/h turn-on biases.
        ModelArg::Ins => (
            INS_CONFIG,
            &[
                "--imu-output",
                "body",
                "--imu-rate",
                &imu_rate,
                "--accel-noise",
                "0.283",
                "--gyro-noise",
                "0.0141", // 0.02 m/s²/√Hz, 0.001 rad/s/√Hz at 200 Hz
                "--accel-bias",
                "0.05",
                "--gyro-bias",
                "0.0005",
                "--accel-random-walk",
                "0.001",
                "--gyro-random-walk",
                "1e-5",
            ],
        ),
    };
    let config = work.join(format!("{model}.toml"));
    let offset = format!("time_offset_ns = {}", args.gnss_clock_lag_ms * 1_000_000);
    std::fs::write(&config, config_text.replacen("time_offset_ns = 0", &offset, 1))?;
    let log = work.join("fusiond.log");
    let namespace = format!("demo-{}", std::process::id());

    println!("fusiond demo: namespace {namespace}, model {model}, --wait {wait}, {} s", args.duration);
    let mut children = Children(Vec::new());
    // The recorder first: it reads the sample services at once and the
    // snapshots as soon as fusiond is up, so it misses nothing.
    let recording = work.join("demo.mcap");
    let mut recorder = Children(vec![(
        "fusionctl record",
        Command::new(bin("fusionctl")?)
            .args(["record", "--namespace", &namespace, "--output"])
            .arg(&recording)
            .stderr(std::fs::File::create(work.join("record.log"))?)
            .spawn()?,
    )]);
    let daemon = Command::new(bin("fusiond")?)
        .args(["run", "--namespace", &namespace, "--wait", wait, "--config"])
        .arg(&config)
        .stderr(std::fs::File::create(&log)?)
        .spawn()?;
    children.0.push(("fusiond", daemon));
    let client = Client::connect(&namespace)?;
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut state = loop {
        if let Ok(Some(status)) = children.0[0].1.try_wait() {
            bail!("fusiond stopped at start ({status}): {} (log: {})", last_line(&log), log.display());
        }
        match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
            Ok(s) => break s,
            Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => bail!("fusiond did not start: {e} (log: {})", log.display()),
        }
    };
    println!("  fusiond started (log: {})", log.display());

    // Every sensor process drives the same trajectory from the same start time.
    let start_ns = now_ns() + 300_000_000;
    let sim = |role: &[&str]| -> anyhow::Result<Child> {
        let imu = role[0] == "--imu-only";
        Ok(Command::new(bin("fusion-sim")?)
            .args(["run", "--namespace", &namespace, "--outliers", "0.03"])
            .args(role)
            .args(["--seed", &args.seed.to_string(), "--duration", &args.duration.to_string()])
            .args(["--start-at-ns", &start_ns.to_string()])
            .args(&stops)
            .args(if imu { imu_args } else { &[] })
            .args(if ins { &INS_IMU_MOUNTS[..] } else { &[] })
            .args(match (imu, ins) {
                (true, _) => &[][..],
                (false, true) => &INS_AIDING[..],
                (false, false) => &["--velocity-rate", "10"][..],
            })
            .stderr(Stdio::null())
            .spawn()?)
    };
    if ins {
        children.0.push(("fusion-sim --imu-only --imu-ids 0", sim(&["--imu-only", "--imu-ids", "0"])?));
        children.0.push(("fusion-sim --imu-only --imu-ids 1", sim(&["--imu-only", "--imu-ids", "1"])?));
        children.0.push(("fusion-sim --position-only", sim(&["--position-only"])?));
        println!(
            "  fusion-sim: two IMU processes ({imu_hz} Hz each, one clock, differently mounted, one in FRD axes) and \
             a GNSS receiver\n  (10 Hz latitude/longitude/height with 3 % outliers and 10 Hz Doppler velocity of an \
             antenna 1.5 m from the IMUs,\n  20-120 ms late) with wheel odometry (50 Hz, 1 % scale error) started\n"
        );
        if !args.fix_phase.is_empty() {
            let phases: Vec<String> = args
                .fix_phase
                .iter()
                .map(|p| format!("{} from {} s", fusion_shared::fix::name(p.fix_type), p.at_s))
                .collect();
            println!("  the receiver's fix type: {} (noise and reported accuracy change with it)", phases.join(", "));
        }
        if args.gnss_clock_lag_ms > 0 {
            println!(
                "  the receiver's clock is {} ms late; the configuration says so (time_offset_ns)",
                args.gnss_clock_lag_ms
            );
        }
    } else {
        children.0.push(("fusion-sim --imu-only", sim(&["--imu-only"])?));
        children.0.push(("fusion-sim --position-only", sim(&["--position-only"])?));
        println!(
            "  fusion-sim --imu-only ({imu_hz} Hz) and fusion-sim --position-only (a GNSS receiver: 10 Hz positions \
             with 3 % outliers and 10 Hz Doppler velocities, 20-120 ms late) started\n"
        );
    }
    // With the recorder and this reader.
    let processes = children.0.len() + 2;

    let truth_path = work.join("demo.truth.jsonl");
    let mut truth_file = std::io::BufWriter::new(std::fs::File::create(&truth_path)?);
    let mut latency = Histogram::<u64>::new_with_bounds(1, 10_000_000_000, 3)?;
    let (mut sum_sq, mut n_err) = (0.0, 0u64);
    let mut last = None;
    // Health as of the last snapshot a sample triggered (later ones only say the
    // sensors stopped).
    let mut drive_health = None;
    // While the car stands: snapshots of samples then, how many of them say
    // standing, the estimate's position when it stopped and its largest move.
    let (mut stood, mut found_standing) = (0u64, 0u64);
    let (mut stop_at, mut stop_drift) = (None::<[f64; 3]>, 0.0f64);
    // Each outage's horizontal error and its 1σ at its end (the first snapshot after it).
    let mut outage_ends: Vec<Option<(f64, f64)>> = vec![None; args.outage.len()];
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
            let _ = latency.record(received.saturating_sub(s.input_sent_ns));
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
        // Error statistics after the first second of fixes (the filter starts from x0 = 0).
        if t > 1.0 && err.is_finite() {
            sum_sq += err * err;
            n_err += 1;
        }
        last = Some((*s, err));
        for (o, seen) in args.outage.iter().zip(&mut outage_ends) {
            if seen.is_none() && t >= o.at_s + o.duration_s && x.len() >= 3 && s.cov_dim >= 2 {
                let p = truth.at(t).pos_m;
                let n = s.cov_dim as usize;
                let sd = (s.cov[0].max(0.0) + s.cov[n + 1].max(0.0)).sqrt();
                *seen = Some((((x[0] - p.x).powi(2) + (x[1] - p.y).powi(2)).sqrt(), sd));
            }
        }
        if s.input_kind != INPUT_NONE {
            drive_health = Some((s.health, s.health_reasons));
            if x.len() >= 3 && truth.standing(t) {
                stood += 1;
                found_standing += u64::from(s.standing());
                let at = *stop_at.get_or_insert([x[0], x[1], x[2]]);
                stop_drift = stop_drift.max(((x[0] - at[0]).powi(2) + (x[1] - at[1]).powi(2)).sqrt());
            } else {
                stop_at = None;
            }
        }
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
                p50_us: latency.value_at_quantile(0.5) as f64 / 1e3,
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
    children.stop();
    // The recorder last: it has every snapshot once fusiond stopped.
    recorder.stop();
    truth_file.flush()?;

    let Some((s, err)) = last else { bail!("no snapshot received (log: {})", log.display()) };
    let sd: Vec<f64> = s.std_devs().collect();
    let driven_s = (s.t_ns as f64 - start_ns as f64) * 1e-9;
    println!("\nresult after {driven_s:.1} s of driving:");
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
        println!(
            "  {name:<21} received {}, {what}; out of order {} (processed exactly by rewind), too late {}, \
             invalid {}, lost {}",
            n.received, n.late, n.too_late, n.invalid, n.lost
        );
    }
    println!(
        "  position error vs truth: final {err:.3} m (1-sigma {:.3} / {:.3} / {:.3} m), RMS over the drive {:.3} m",
        sd[0],
        sd[1],
        sd[2],
        (sum_sq / n_err.max(1) as f64).sqrt()
    );
    if let (Some(k), Some(sd)) = (s.odometry_scale(), s.odometry_scale_std()) {
        println!("  odometry scale factor: estimated {k:.4} (1-sigma {sd:.4}), simulated 1.0100");
    }
    for (o, seen) in args.outage.iter().zip(&outage_ends) {
        if let Some((e, sd)) = seen {
            println!(
                "  GNSS outage {:.0}-{:.0} s: horizontal error at its end {e:.2} m (1-sigma {sd:.2} m)",
                o.at_s,
                o.at_s + o.duration_s
            );
        }
    }
    if stood > 0 {
        println!(
            "  while the car stood: fusiond found it standing in {:.1} % of the samples ({} standstill updates); \
             the estimate moved at most {:.3} m horizontally",
            100.0 * found_standing as f64 / stood as f64,
            s.standstill_updates,
            stop_drift
        );
    }
    println!(
        "  end-to-end latency, sample published -> snapshot received ({} samples, --wait {wait}):\n    p50 {:.1} us, \
         p90 {:.1} us, p99 {:.1} us, max {:.1} us",
        latency.len(),
        latency.value_at_quantile(0.5) as f64 / 1e3,
        latency.value_at_quantile(0.9) as f64 / 1e3,
        latency.value_at_quantile(0.99) as f64 / 1e3,
        latency.max() as f64 / 1e3,
    );
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    println!(
        "    (this reader sleeps on an event and {processes} processes share {cores} cores; the README's ~1 us is the \
         benchmark's busy-polling reader: cargo bench -p fusion-benches --bench latency)"
    );
    let during = drive_health.map(|(health, reasons)| {
        let mut d = s;
        (d.health, d.health_reasons) = (health, reasons);
        d
    });
    match during {
        Some(d) if (d.health, d.health_reasons) != (s.health, s.health_reasons) => {
            println!("  health at the end of the drive: {}; after the sensors stopped: {}", describe(&d), describe(&s))
        }
        _ => println!("  health at the end of the drive: {}", describe(&s)),
    }
    let report = work.join("report");
    let plot = Command::new(bin("fusionctl")?)
        .args(["plot", "--input"])
        .arg(&recording)
        .arg("--truth")
        .arg(&truth_path)
        .arg("--output-dir")
        .arg(&report)
        .output()?;
    if plot.status.success() {
        println!(
            "\nrecording: {}\nreport (trajectory, errors with ±3σ, NIS, latency): {}",
            recording.display(),
            report.display()
        );
    } else {
        bail!("the report failed: {}", String::from_utf8_lossy(&plot.stderr).trim());
    }
    Ok(())
}
