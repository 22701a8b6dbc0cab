//! Helpers shared by the daemon's integration tests.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::replay::OutputLine;
use fusion_shared::jsonl::format_sample;

/// The `ins` model with automotive MEMS noise (Kalibr densities), its filter
/// started at the true state of the simulated drive of `seed`: `[model]` and
/// `[filter]`, for a test to add its own tables to.
pub fn ins_config_at_truth(seed: u64) -> String {
    let truth = fusion_client::sim::CarTrajectory::new(seed).at(0.0);
    let (p, v, q) = (truth.pos_m, truth.vel_mps, truth.attitude.quaternion().coords);
    format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [filter]\ninitial_state = [{}, {}, {}, {}, {}, {}, {}, {}, {}, {}, 0, 0, 0, 0, 0, 0]\n\
         initial_covariance_diagonal = [0.25, 0.25, 0.25, 0.09, 0.09, 0.09, 4e-4, 4e-4, 4e-4, \
         0.0025, 0.0025, 0.0025, 2.5e-7, 2.5e-7, 2.5e-7]\n",
        p.x, p.y, p.z, v.x, v.y, v.z, q[3], q[0], q[1], q[2]
    )
}

/// The bytes of a snapshot, as they travel.
pub fn snapshot_bytes(s: &fusion_shared::StateSnapshot) -> &[u8] {
    // SAFETY: `StateSnapshot` is `repr(C)` plain data without padding (its size is
    // the sum of its fields, asserted in `fusion_shared`).
    unsafe {
        std::slice::from_raw_parts(
            (s as *const fusion_shared::StateSnapshot).cast::<u8>(),
            size_of::<fusion_shared::StateSnapshot>(),
        )
    }
}

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

/// How long the clients' instant tests let fusiond wait for an instant's
/// last IMU sample, ns: far beyond the time between a client's two publishes,
/// even when a loaded machine deschedules the client between them (the
/// default, 0.25 ms, is not).
pub const INSTANT_WAIT_NS: u64 = 100_000_000;

/// The `linear` config with two IMUs (ids 0 and 1) averaged, waiting
/// [`INSTANT_WAIT_NS`] for an instant's last sample, for the clients' tests of
/// one snapshot per IMU instant.
pub fn two_averaged_imus_config() -> String {
    linear_config(None)
        + "[[sensor]]\nname = \"imu-a\"\nid = 0\nkinds = [\"imu\"]\n\
           [[sensor]]\nname = \"imu-b\"\nid = 1\nkinds = [\"imu\"]\n[imu]\ncombine = \"average\"\n"
        + &format!("instant_wait_ns = {INSTANT_WAIT_NS}\n")
}

/// What a client's `instants` program printed (`client/tests/c/instants.c`,
/// `client/python/tests/instants.py`): the first instant has nothing to wait
/// for (both of its samples publish), every later one has one snapshot, and an
/// instant one IMU missed got its snapshot after the configured wait
/// ([`INSTANT_WAIT_NS`]).
pub fn assert_one_snapshot_per_instant(said: &str) {
    assert!(said.contains("100 instants: snapshots of the first 2, of each later one 1 to 1"), "{said}");
    let waited_us: f64 = said
        .split("its snapshot after ")
        .nth(1)
        .and_then(|r| r.split(" us").next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    assert!(waited_us >= INSTANT_WAIT_NS as f64 * 1e-3, "the wait is {INSTANT_WAIT_NS} ns: {said}");
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
    let mut cmd = Command::new(live::fusiond());
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

pub mod car;
pub mod heartbeat;
pub mod live;
pub mod typed;

/// An `ins` fusiond for a robot standing level and facing east (attitude known
/// to 0.01 rad), with magnetometer 2 (Munich's field) and twist sensor 4: what
/// `client/python/tests/publish_robot.py` and `client/tests/c/robot.c` publish to.
pub const ROBOT_INS_CONFIG: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\n\
    gyroscope_noise_density = 0.001\naccelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
    [filter]\ninitial_state = [0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]\n\
    initial_covariance_diagonal = [1, 1, 1, 1, 1, 1, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-8, 1e-8, 1e-8]\n\
    [[sensor]]\nname = \"compass\"\nid = 2\nkinds = [\"magnetometer\"]\n\
    [sensor.magnetic]\ndeclination_deg = 3.5\ninclination_deg = 64.5\nstrength_ut = 48.5\n\
    [[sensor]]\nname = \"camera\"\nid = 4\nkinds = [\"twist\"]\n\
    [[sensor]]\nname = \"baro\"\nid = 5\nkinds = [\"barometer\"]\n\
    [[sensor]]\nname = \"slam\"\nid = 6\nkinds = [\"pose\"]\n";

/// Checks the latest snapshot of a fusiond fed by `publish_robot.py` or
/// `robot.c`: 20 magnetometer samples and 20 twists received and fused, none
/// invalid or lost; 20 barometer samples and 20 poses received, the first of
/// each setting its reference state (the bias, the map frame) and the other
/// 19 fused; the pose with a skewed quaternion refused as invalid; the
/// estimate's auxiliary states the bias and the frame.
pub fn assert_robot_samples_fused(domain: &live::TestDomain) {
    use fusion_shared::SampleKind;
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let s = *reader.wait_next(std::time::Duration::from_secs(10)).unwrap().expect("the latest snapshot");
    let counters = |kind: SampleKind| *s.sensor_counters().iter().find(|c| c.sample_kind() == Some(kind)).unwrap();
    let (mag, twist) = (counters(SampleKind::Magnetometer), counters(SampleKind::Twist));
    assert_eq!((mag.sensor, mag.counts.received, mag.counts.fused, mag.counts.invalid), (2, 20, 20, 0));
    assert_eq!((twist.sensor, twist.counts.received, twist.counts.fused, twist.counts.invalid), (4, 20, 20, 0));
    assert_eq!(twist.counts.lost, 0, "the NaN twist was never sent");
    let (baro, pose) = (counters(SampleKind::Barometer), counters(SampleKind::Pose));
    assert_eq!((baro.sensor, baro.counts.received, baro.counts.processed, baro.counts.fused), (5, 20, 20, 19));
    assert_eq!((pose.sensor, pose.counts.received, pose.counts.processed, pose.counts.fused), (6, 21, 20, 19));
    assert_eq!((baro.counts.invalid, pose.counts.invalid), (0, 1), "the skewed quaternion is refused");
    assert_eq!(s.rejections[fusion_shared::snapshot::rejection::OUT_OF_RANGE as usize], 1);
    let bias = s.baro_bias().expect("the bias state");
    assert!((bias[0] - fusion_shared::pressure_altitude_m(95_000.0)).abs() < 0.5, "{bias:?}");
    let frame = s.pose_frame().expect("the frame states");
    // The robot faces east (yaw 0), the sensor 106° about up in the map: the
    // map's yaw in the world is −106°.
    let yaw = -2.0 * 0.8f64.atan2(0.6);
    assert!((frame[0] - yaw).abs() < 0.01, "{frame:?}");
}

/// The pooled mean over Monte Carlo runs of a `(sum, count)` each run gives.
pub fn pooled_mean<R>(runs: &[R], f: impl Fn(&R) -> (f64, u64)) -> f64 {
    let (s, n) = runs.iter().map(f).fold((0.0, 0), |(s, n), (a, b)| (s + a, n + b));
    s / n as f64
}

/// Numbers as a TOML array's contents (`1e0, -2.5e-1`), exactly.
pub fn toml_list(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ")
}

/// The start of an `ins` Monte-Carlo run: the first sample time `t0`, and the
/// `[filter]` lines of a start state drawn from the prior about the truth at
/// `t0` (standard deviations `sigma0` of δp, δv, δθ, δb_a, δb_g; biases 0) with
/// that prior as its covariance. The draw comes from its own stream of `seed`.
pub fn ins_start_from_prior(scenario: &Scenario, seed: u64, sigma0: [f64; 5]) -> (u64, String) {
    let (t0, x0, p0) = ins_start_values(scenario, seed, sigma0);
    let filter = format!("initial_state = [{}]\ninitial_covariance_diagonal = [{}]\n", toml_list(&x0), toml_list(&p0));
    (t0, filter)
}

/// [`ins_start_from_prior`] as values: `t0`, the nominal start state (16) and the
/// diagonal of its covariance (15).
pub fn ins_start_values(scenario: &Scenario, seed: u64, sigma0: [f64; 5]) -> (u64, Vec<f64>, Vec<f64>) {
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xfeed);
    let mut draw = |s: f64| Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut rng)) * s;
    let t0 = scenario.arrivals.iter().map(|a| a.sample.t_ns()).min().unwrap();
    let truth0 = scenario.truth_at(t0);
    let p = truth0.pos_m + draw(sigma0[0]);
    let v = truth0.vel_mps + draw(sigma0[1]);
    let q = truth0.attitude * UnitQuaternion::from_scaled_axis(draw(sigma0[2]));
    let qc = q.quaternion().coords;
    let x0 = vec![p.x, p.y, p.z, v.x, v.y, v.z, qc[3], qc[0], qc[1], qc[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let p0: Vec<f64> = sigma0.iter().flat_map(|s| [s * s; 3]).collect();
    (t0, x0, p0)
}

/// Turns the attitude `[w, x, y, z]` at entries 6..10 of a nominal `ins` state
/// about world up by `angle`, rad (roll and pitch kept).
pub fn turn_heading(x0: &mut [f64], angle: f64) {
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle)
        * UnitQuaternion::new_normalize(Quaternion::new(x0[6], x0[7], x0[8], x0[9]));
    let c = q.quaternion().coords;
    x0[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
}

/// The heading error of attitude `q` against `truth` (the yaw of the body's x
/// axis, wrapped into [−π, π)) and its σ about world up under the row-major
/// error-state covariance `cov` (δθ at 6..9, local).
pub fn heading_error(
    q: &nalgebra::UnitQuaternion<f64>,
    cov: &[f64],
    truth: &nalgebra::UnitQuaternion<f64>,
) -> (f64, f64) {
    use std::f64::consts::PI;
    let yaw = |q: &nalgebra::UnitQuaternion<f64>| {
        let x = q.transform_vector(&nalgebra::Vector3::x());
        x.y.atan2(x.x)
    };
    let e = (yaw(q) - yaw(truth) + PI).rem_euclid(2.0 * PI) - PI;
    let u = q.inverse_transform_vector(&nalgebra::Vector3::z());
    let n = (cov.len() as f64).sqrt().round() as usize;
    let var: f64 =
        (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| u[i] * cov[(6 + i) * n + 6 + j] * u[j]).sum();
    (e, var.sqrt())
}

/// Position-and-velocity error of an `ins` estimate `x` (nominal state) against
/// the truth, and its NEES under the row-major error-state covariance `cov` (any side).
pub fn pv_error_and_nees(
    x: &[f64],
    cov: &[f64],
    truth: &fusion_client::sim::TruthState,
) -> (nalgebra::Vector6<f64>, f64) {
    let err = nalgebra::Vector6::new(
        x[0] - truth.pos_m.x,
        x[1] - truth.pos_m.y,
        x[2] - truth.pos_m.z,
        x[3] - truth.vel_mps.x,
        x[4] - truth.vel_mps.y,
        x[5] - truth.vel_mps.z,
    );
    let n = (cov.len() as f64).sqrt().round() as usize;
    let p6 = nalgebra::Matrix6::from_fn(|r, c| cov[r * n + c]);
    let nees = err.dot(&nalgebra::Cholesky::new(p6).expect("P is positive definite").solve(&err));
    (err, nees)
}

/// The Python packages of the tests, pinned: `client/python/requirements-test.txt`.
pub const PYTHON_REQUIREMENTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../client/python/requirements-test.txt");

/// A Python interpreter with [`PYTHON_REQUIREMENTS`] installed and the
/// `fusion_client` package of `client/python` importable: a virtual environment
/// in the workspace's `target/python-venv` (`.ci/run` makes it first; a test makes
/// it from PyPI if it is missing, saying so).
pub fn python_venv() -> PathBuf {
    static MADE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = MADE.lock().unwrap_or_else(|e| e.into_inner());
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/python-venv");
    let python = venv.join("bin/python");
    let installed = |python: &Path| {
        Command::new(python)
            .args(["-c", "import mcap.reader, iceoryx2, numpy, zenoh, rosbags, cyclonedds.domain"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !installed(&python) {
        // Straight to the terminal (the harness captures eprintln!), and pip's own
        // progress with it: the download is a wait to be seen.
        let note = format!("making the tests' Python environment in {} (pip, from PyPI)\n", venv.display());
        let _ = std::io::Write::write_all(&mut std::io::stderr(), note.as_bytes());
        let made = Command::new("python3").arg("-m").arg("venv").arg(&venv).status().expect("python3 runs");
        assert!(made.success(), "python3 -m venv {} failed", venv.display());
        let pip = Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--progress-bar",
                "off",
                "--disable-pip-version-check",
                "-r",
                PYTHON_REQUIREMENTS,
            ])
            .status()
            .expect("pip runs");
        assert!(pip.success(), "pip install -r {PYTHON_REQUIREMENTS} failed");
    }
    assert!(installed(&python), "the packages of {PYTHON_REQUIREMENTS} are not importable in {}", venv.display());
    python
}

/// `python` running `script` of `client/python` with `args`, the `fusion_client`
/// package on its path, in iceoryx2 domain `domain`.
pub fn python_command(domain: &str, script: &str, args: &[&str]) -> Command {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/python");
    let mut cmd = Command::new(python_venv());
    cmd.arg(dir.join(script))
        .args(args)
        .env("PYTHONPATH", &dir)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env(fusion_shared::service::DOMAIN_ENV, domain);
    cmd
}
