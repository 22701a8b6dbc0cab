//! `fusion-demo` (run it with `./demo`): fusiond and simulated sensors as separate
//! processes over iceoryx2, a live status line, then the position error against
//! the truth and the end-to-end latency.

use std::path::PathBuf;
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::{Parser, ValueEnum};
mod drive;
mod status;
use status::say;

use fusion_client::sim::{CarTrajectory, FixPhase, Outage, Stop};
use fusion_client::{Client, now_ns};

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
/// fusion-sim's IMU noise of the `ins` demo: automotive MEMS (Kalibr densities as
/// configured), 5 mg / ~100 deg/h turn-on biases; 0.283 m/s² and 0.0141 rad/s per
/// sample are 0.02 m/s²/√Hz and 0.001 rad/s/√Hz at 200 Hz.
const INS_IMU_NOISE: [&str; 14] = [
    "--imu-output",
    "body",
    "--accel-noise",
    "0.283",
    "--gyro-noise",
    "0.0141",
    "--accel-bias",
    "0.05",
    "--gyro-bias",
    "0.0005",
    "--accel-random-walk",
    "0.001",
    "--gyro-random-walk",
    "1e-5",
];

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
    let truth = CarTrajectory::new(args.seed).with_stops(&args.stop).map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
    let setup = Setup::new(&args)?;
    say(&format!(
        "fusiond demo: namespace {}, model {}, --wait {}, {} s",
        setup.namespace, setup.model, setup.wait, args.duration
    ));
    let (mut children, mut recorder, mut reader) = setup.start_fusiond()?;
    // Every sensor process drives the same trajectory from the same start time.
    let start_ns = now_ns() + 300_000_000;
    setup.start_sensors(&args, start_ns, &mut children)?;
    // With the recorder and this reader.
    let processes = children.0.len() + 2;
    let truth_path = setup.work.join("demo.truth.jsonl");
    let seen = drive::watch(&args, &truth, &mut reader.state, start_ns, &stop, &truth_path)?;
    children.stop();
    // The recorder last: it has every snapshot once fusiond stopped.
    recorder.stop();
    let Some(last) = seen.last else { bail!("no snapshot received (log: {})", setup.log.display()) };
    drive::print_result(&args, &seen, &last, start_ns);
    drive::print_latency(&seen.latency, processes, setup.wait);
    drive::print_health(&seen, &last.0);
    setup.report(&truth_path)
}

/// This process's reader of fusiond's snapshots: the subscriber, then its
/// node (fields drop in this order, so the node goes last and cleans up).
struct Reader {
    state: fusion_client::StateSubscriber,
    _client: Client,
}

/// Where the demo's processes, files and services are, and how they are set up.
struct Setup {
    /// The workspace's binaries.
    bin_dir: PathBuf,
    /// `<bin_dir>/demo`: the config, the logs, the recording, the report.
    work: PathBuf,
    namespace: String,
    model: &'static str,
    wait: &'static str,
    ins: bool,
    imu_hz: u32,
    /// fusion-sim's options of the IMU processes.
    imu_args: Vec<String>,
    /// fusion-sim's options of every process: stops, outages, fix phases, clock lag.
    scenario_args: Vec<String>,
    config: PathBuf,
    log: PathBuf,
    recording: PathBuf,
}

impl Setup {
    /// Checks the options, writes the config.
    fn new(args: &Args) -> anyhow::Result<Self> {
        let bin_dir = std::env::current_exe()?.parent().context("binary directory")?.to_path_buf();
        let ins = args.model == ModelArg::Ins;
        if !ins && (!args.fix_phase.is_empty() || args.gnss_clock_lag_ms > 0) {
            bail!("--fix-phase and --gnss-clock-lag-ms need --model ins (a GNSS receiver with quality and a clock)");
        }
        let mut scenario_args: Vec<String> =
            args.stop.iter().flat_map(|s| ["--stop".to_string(), format!("{}:{}", s.at_s, s.duration_s)]).collect();
        scenario_args
            .extend(args.outage.iter().flat_map(|o| ["--outage".to_string(), format!("{}:{}", o.at_s, o.duration_s)]));
        scenario_args.extend(
            args.fix_phase.iter().flat_map(|p| {
                ["--fix-phase".to_string(), format!("{}:{}", p.at_s, fusion_shared::fix::name(p.fix_type))]
            }),
        );
        if args.gnss_clock_lag_ms > 0 {
            scenario_args.extend(["--fix-clock-lag-ms".to_string(), args.gnss_clock_lag_ms.to_string()]);
        }
        let work = bin_dir.join("demo");
        std::fs::create_dir_all(&work)?;
        let (model, wait) =
            (if ins { "ins" } else { "linear" }, if args.wait == Wait::Spin { "spin" } else { "event" });
        let imu_hz = if ins { INS_IMU_HZ } else { LINEAR_IMU_HZ };
        let mut imu_args = vec!["--imu-rate".to_string(), imu_hz.to_string()];
        let config_text = match args.model {
            ModelArg::Linear => CONFIG,
            ModelArg::Ins => {
                imu_args.extend(INS_IMU_NOISE.iter().map(|a| a.to_string()));
                INS_CONFIG
            }
        };
        let config = work.join(format!("{model}.toml"));
        let offset = format!("time_offset_ns = {}", args.gnss_clock_lag_ms * 1_000_000);
        std::fs::write(&config, config_text.replacen("time_offset_ns = 0", &offset, 1))?;
        Ok(Self {
            namespace: format!("demo-{}", std::process::id()),
            log: work.join("fusiond.log"),
            recording: work.join("demo.mcap"),
            bin_dir,
            work,
            model,
            wait,
            ins,
            imu_hz,
            imu_args,
            scenario_args,
            config,
        })
    }

    /// The workspace's binary `name`, or why not.
    fn bin(&self, name: &str) -> anyhow::Result<PathBuf> {
        let p = self.bin_dir.join(name);
        if !p.exists() {
            bail!("{} not found: build the workspace first (./demo does)", p.display());
        }
        Ok(p)
    }

    /// Starts the recorder, then fusiond, and waits for fusiond's snapshots.
    fn start_fusiond(&self) -> anyhow::Result<(Children, Children, Reader)> {
        let mut children = Children(Vec::new());
        // The recorder first: it reads the sample services at once and the
        // snapshots as soon as fusiond is up, so it misses nothing.
        let recorder = Children(vec![(
            "fusionctl record",
            Command::new(self.bin("fusionctl")?)
                .args(["record", "--namespace", &self.namespace, "--output"])
                .arg(&self.recording)
                .stderr(std::fs::File::create(self.work.join("record.log"))?)
                .spawn()?,
        )]);
        let daemon = Command::new(self.bin("fusiond")?)
            .args(["run", "--namespace", &self.namespace, "--wait", self.wait, "--config"])
            .arg(&self.config)
            .stderr(std::fs::File::create(&self.log)?)
            .spawn()?;
        children.0.push(("fusiond", daemon));
        let client = Client::connect(&self.namespace)?;
        let deadline = Instant::now() + Duration::from_secs(10);
        let state = loop {
            if let Ok(Some(status)) = children.0[0].1.try_wait() {
                bail!("fusiond stopped at start ({status}): {} (log: {})", last_line(&self.log), self.log.display());
            }
            match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
                Ok(s) => break s,
                Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => bail!("fusiond did not start: {e} (log: {})", self.log.display()),
            }
        };
        say(&format!("  fusiond started (log: {})", self.log.display()));
        Ok((children, recorder, Reader { state, _client: client }))
    }

    /// Starts the sensor processes, each driving from `start_ns`, and says what they are.
    fn start_sensors(&self, args: &Args, start_ns: u64, children: &mut Children) -> anyhow::Result<()> {
        let sim = |role: &[&str]| -> anyhow::Result<Child> {
            let imu = role[0] == "--imu-only";
            Ok(Command::new(self.bin("fusion-sim")?)
                .args(["run", "--namespace", &self.namespace, "--outliers", "0.03"])
                .args(role)
                .args(["--seed", &args.seed.to_string(), "--duration", &args.duration.to_string()])
                .args(["--start-at-ns", &start_ns.to_string()])
                .args(&self.scenario_args)
                .args(if imu { &self.imu_args[..] } else { &[] })
                .args(if self.ins { &INS_IMU_MOUNTS[..] } else { &[] })
                .args(match (imu, self.ins) {
                    (true, _) => &[][..],
                    (false, true) => &INS_AIDING[..],
                    (false, false) => &["--velocity-rate", "10"][..],
                })
                .stderr(Stdio::null())
                .spawn()?)
        };
        let imu_hz = self.imu_hz;
        if !self.ins {
            children.0.push(("fusion-sim --imu-only", sim(&["--imu-only"])?));
            children.0.push(("fusion-sim --position-only", sim(&["--position-only"])?));
            say(&format!(
                "  fusion-sim --imu-only ({imu_hz} Hz) and fusion-sim --position-only (a GNSS receiver: 10 Hz positions \
                 with 3 % outliers and 10 Hz Doppler velocities, 20-120 ms late) started\n"
            ));
            return Ok(());
        }
        children.0.push(("fusion-sim --imu-only --imu-ids 0", sim(&["--imu-only", "--imu-ids", "0"])?));
        children.0.push(("fusion-sim --imu-only --imu-ids 1", sim(&["--imu-only", "--imu-ids", "1"])?));
        children.0.push(("fusion-sim --position-only", sim(&["--position-only"])?));
        say(&format!(
            "  fusion-sim: two IMU processes ({imu_hz} Hz each, one clock, differently mounted, one in FRD axes) and \
             a GNSS receiver\n  (10 Hz latitude/longitude/height with 3 % outliers and 10 Hz Doppler velocity of an \
             antenna 1.5 m from the IMUs,\n  20-120 ms late) with wheel odometry (50 Hz, 1 % scale error) started\n"
        ));
        if !args.fix_phase.is_empty() {
            let phases: Vec<String> = args
                .fix_phase
                .iter()
                .map(|p| format!("{} from {} s", fusion_shared::fix::name(p.fix_type), p.at_s))
                .collect();
            say(&format!(
                "  the receiver's fix type: {} (noise and reported accuracy change with it)",
                phases.join(", ")
            ));
        }
        if args.gnss_clock_lag_ms > 0 {
            say(&format!(
                "  the receiver's clock is {} ms late; the configuration says so (time_offset_ns)",
                args.gnss_clock_lag_ms
            ));
        }
        Ok(())
    }

    /// `fusionctl plot` of the recording against the truth, and where both are.
    fn report(&self, truth_path: &std::path::Path) -> anyhow::Result<()> {
        let report = self.work.join("report");
        let plot = Command::new(self.bin("fusionctl")?)
            .args(["plot", "--input"])
            .arg(&self.recording)
            .arg("--truth")
            .arg(truth_path)
            .arg("--output-dir")
            .arg(&report)
            .output()?;
        if !plot.status.success() {
            bail!("the report failed: {}", String::from_utf8_lossy(&plot.stderr).trim());
        }
        say(&format!(
            "\nrecording: {}\nreport (trajectory, errors with ±3σ, NIS, latency): {}",
            self.recording.display(),
            report.display()
        ));
        Ok(())
    }
}
