//! An IMU with a magnetometer and no position, and an IMU alone: a device
//! moved by hand, as a handheld unit or an indoor drone has them. Nothing
//! gives a position or a velocity, so the accelerometer is the tilt's gravity
//! reference (`model::ins::gravity`), and the magnetometer the heading's.
//!
//! Each run: 60 s at 100 Hz of a MEMS IMU (BMI088-like: 0.002 m/s²/√Hz,
//! 2.5·10⁻⁴ rad/s/√Hz, biases drawn with σ 0.03 m/s² and 0.003 rad/s) and a
//! 20 Hz magnetometer (0.5 µT per axis, Munich's field), held still for 5 s
//! (the static alignment takes the first 2), then moved by hand: rotations of
//! up to ±60° in roll and pitch and all round in yaw, accelerations of 2–5
//! m/s² while it moves, and rests of 3 to 12 s at whatever tilt the motion
//! left. The heading is unknown at start (σ π). In every other run the field
//! turns by 30° for 5 s while the device rests (a steel desk).
//!
//! Held over 20 runs, from the end of the alignment on: attitude NEES/dof in
//! [0.75, 1.35] (three axes with the magnetometer, roll and pitch alone
//! without), no attitude error above 10°, and 10 s after a disturbance ends
//! the heading within 3σ. Reported beside: the same runs without the gravity
//! reference (the gyro alone holds the tilt after the alignment).
//!
//! `cargo test --release -p fusion-daemon --test ahrs -- --nocapture`.

#![allow(non_snake_case)]

use std::f64::consts::PI;

use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::{ImuSample, MagnetometerSample, Sample};
use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Uniform};

const RUNS: u64 = 20;
const DURATION_S: f64 = 60.0;
const IMU_HZ: f64 = 100.0;
const MAG_EVERY: usize = 5;
const G: f64 = 9.80665;
const ACCEL_DENSITY: f64 = 0.002;
const GYRO_DENSITY: f64 = 2.5e-4;
const ACCEL_RW: f64 = 1e-4;
const GYRO_RW: f64 = 1e-5;
const ACCEL_BIAS_SD: f64 = 0.03;
const GYRO_BIAS_SD: f64 = 0.003;
const MAG_NOISE_UT: f64 = 0.5;
/// Declination, inclination (degrees), strength (µT): Munich.
const FIELD: (f64, f64, f64) = (3.5, 64.5, 48.5);
/// When the device moves (start, end), s; it rests between.
const MOVING: [(f64, f64); 6] = [(5.0, 12.0), (15.0, 22.0), (25.0, 30.0), (42.0, 50.0), (53.0, 57.0), (58.0, 60.0)];
/// The field turned by 30° while the device rests, s (every other run).
const DISTURBANCE: (f64, f64) = (32.0, 37.0);
/// Where the figures start: after the static alignment, s.
const FROM_S: f64 = 2.5;
/// Ramp of a motion's start and end, s.
const RAMP_S: f64 = 0.5;

/// How much the device moves at `t`, 0 (resting) to 1, and its rate.
fn envelope(t: f64) -> (f64, f64) {
    for &(a, b) in &MOVING {
        if t < a || t >= b {
            continue;
        }
        let ramp = |u: f64| (0.5 * (1.0 - (PI * u / RAMP_S).cos()), 0.5 * PI / RAMP_S * (PI * u / RAMP_S).sin());
        return if t - a < RAMP_S {
            ramp(t - a)
        } else if b - t < RAMP_S {
            let (e, de) = ramp(b - t);
            (e, -de)
        } else {
            (1.0, 0.0)
        };
    }
    (0.0, 0.0)
}

/// One axis of a motion: `amplitude · sin(ω u + φ)`.
#[derive(Clone, Copy)]
struct Wave(f64, f64, f64);

impl Wave {
    fn at(&self, u: f64) -> f64 {
        self.0 * (self.1 * u + self.2).sin()
    }
    fn rate(&self, u: f64) -> f64 {
        self.0 * self.1 * (self.1 * u + self.2).cos()
    }
}

/// A hand's motion: the attitude follows waves of the time spent moving (it
/// stays where it was while resting), the velocity is the envelope times
/// waves of time (zero at rest).
struct Hand {
    roll: Wave,
    pitch: Wave,
    yaw: Wave,
    spin: f64,
    velocity: [Wave; 3],
}

impl Hand {
    fn new(rng: &mut ChaCha8Rng) -> Self {
        let u = |rng: &mut ChaCha8Rng, a: f64, b: f64| Uniform::new(a, b).unwrap().sample(rng);
        let mut wave = |a: f64, w: (f64, f64)| Wave(a, u(rng, w.0, w.1), u(rng, 0.0, 2.0 * PI));
        let roll = wave(60f64.to_radians(), (0.3, 0.8));
        let pitch = wave(60f64.to_radians(), (0.3, 0.8));
        let yaw = wave(1.0, (0.2, 0.6));
        let velocity = [wave(0.8, (3.0, 6.0)), wave(0.8, (3.0, 6.0)), wave(0.5, (3.0, 6.0))];
        let spin = u(rng, 0.3, 0.6) * if u(rng, 0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
        Self { roll, pitch, yaw, spin, velocity }
    }

    /// Attitude (body forward-left-up to ENU) after `moved` s of motion.
    fn attitude(&self, moved: f64, yaw0: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_euler_angles(
            self.roll.at(moved),
            self.pitch.at(moved),
            yaw0 + self.yaw.at(moved) + self.spin * moved,
        )
    }

    /// Velocity at `t`, m/s, and its acceleration.
    fn velocity(&self, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (e, de) = envelope(t);
        let v = Vector3::from_fn(|i, _| self.velocity[i].at(t));
        let a = Vector3::from_fn(|i, _| self.velocity[i].rate(t));
        (v * e, v * de + a * e)
    }
}

/// The truth at each IMU sample time: attitude, and the acceleration at rest
/// or in motion.
struct Truth {
    t_s: Vec<f64>,
    attitude: Vec<UnitQuaternion<f64>>,
}

/// The field in the world frame (ENU), µT, turned by `turn` rad about up.
fn field(turn: f64) -> Vector3<f64> {
    let (d, i, b) = (FIELD.0.to_radians() + turn, FIELD.1.to_radians(), FIELD.2);
    Vector3::new(i.cos() * d.sin(), i.cos() * d.cos(), -i.sin()) * b
}

/// A run's samples (IMU 0, magnetometer 5 if `compass`), in time order, and
/// its truth.
fn samples(seed: u64, compass: bool, disturbed: bool) -> (Vec<Sample>, Truth) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let hand = Hand::new(&mut rng);
    let yaw0 = Uniform::new(-PI, PI).unwrap().sample(&mut rng);
    let n01 = Normal::new(0.0, 1.0).unwrap();
    let mut gauss = |sd: f64| Vector3::from_fn(|_, _| sd * n01.sample(&mut rng));
    let (mut b_a, mut b_g) = (gauss(ACCEL_BIAS_SD), gauss(GYRO_BIAS_SD));
    let dt = 1.0 / IMU_HZ;
    let steps = (DURATION_S * IMU_HZ) as usize;
    // Time spent moving, integrated finely (the attitude's argument).
    let fine = 20;
    let mut moved = vec![0.0; steps + 2];
    for k in 1..steps + 2 {
        let mut m = moved[k - 1];
        for j in 0..fine {
            m += envelope(((k - 1) as f64 + (j as f64 + 0.5) / fine as f64) * dt).0 * dt / fine as f64;
        }
        moved[k] = m;
    }
    let attitude: Vec<_> = moved.iter().map(|&m| hand.attitude(m, yaw0)).collect();
    let t0_ns = 1_000_000_000u64;
    let mut out = Vec::new();
    for k in 0..steps {
        let t = k as f64 * dt;
        let (q, next) = (attitude[k], attitude[k + 1]);
        let w = (q.inverse() * next).scaled_axis() / dt;
        let (v0, v1) = (hand.velocity(t).0, hand.velocity(t + dt).0);
        let mid = q.slerp(&next, 0.5);
        let f = mid.inverse_transform_vector(&((v1 - v0) / dt + Vector3::new(0.0, 0.0, G)));
        let f = f + b_a + gauss(ACCEL_DENSITY * IMU_HZ.sqrt());
        let w = w + b_g + gauss(GYRO_DENSITY * IMU_HZ.sqrt());
        b_a += gauss(ACCEL_RW * dt.sqrt());
        b_g += gauss(GYRO_RW * dt.sqrt());
        let t_ns = t0_ns + (k as u64) * 10_000_000;
        out.push(Sample::Imu(ImuSample::new(t_ns, 0, k as u64, f.into(), w.into())));
        if compass && k % MAG_EVERY == 0 {
            let turn = if disturbed && (DISTURBANCE.0..DISTURBANCE.1).contains(&t) { 30f64.to_radians() } else { 0.0 };
            let m = q.inverse_transform_vector(&field(turn)) + gauss(MAG_NOISE_UT);
            let v = MAG_NOISE_UT * MAG_NOISE_UT;
            let cov = [v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v];
            out.push(Sample::Magnetometer(MagnetometerSample::new(t_ns, 5, (k / MAG_EVERY) as u64, m.into(), cov)));
        }
    }
    let t_s = (0..steps).map(|k| k as f64 * dt).collect();
    (out, Truth { t_s, attitude: attitude[..steps].to_vec() })
}

/// fusiond's configuration of the device: the IMU, and the magnetometer with
/// Munich's field; the heading unknown, the tilt from the alignment.
fn config(compass: bool) -> Config {
    let p0 = [1.0, 1.0, 1.0, 1e-4, 1e-4, 1e-4, 0.1, 0.1, PI * PI];
    let biases = [ACCEL_BIAS_SD.powi(2); 3].into_iter().chain([GYRO_BIAS_SD.powi(2); 3]);
    let p0: Vec<String> = p0.into_iter().chain(biases).map(|v| format!("{v:e}")).collect();
    let magnetometer = format!(
        "[[sensor]]\nname = \"compass\"\nid = 5\nkinds = [\"magnetometer\"]\n[sensor.magnetic]\n\
         declination_deg = {}\ninclination_deg = {}\nstrength_ut = {}\n",
        FIELD.0, FIELD.1, FIELD.2
    );
    Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = {ACCEL_DENSITY}\ngyroscope_noise_density = \
         {GYRO_DENSITY}\naccelerometer_random_walk = {ACCEL_RW}\ngyroscope_random_walk = {GYRO_RW}\n\
         [model.alignment]\nstatic_samples = 200\n\
         [filter]\ninitial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\ninitial_covariance_diagonal = [{}]\n\
         [gating]\nprobability = 0.9999\n\
         [[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\n{}",
        p0.join(", "),
        if compass { magnetometer.as_str() } else { "" },
    ))
    .unwrap()
}

/// What a run gives: the attitude's NEES summed (and its steps), its largest
/// error, and the heading's error in σ 10 s after a disturbance.
#[derive(Debug, Default)]
struct Run {
    nees: (f64, u64),
    worst_deg: f64,
    heading_after_sigmas: Option<f64>,
    gravity_updates: u64,
}

fn run(seed: u64, compass: bool, gravity: bool) -> Run {
    let disturbed = compass && seed % 2 == 1;
    let (samples, truth) = samples(seed, compass, disturbed);
    let config = config(compass);
    let InsBuilt::Core(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("no auxiliary state") };
    assert!(model.gravity_reference().is_some(), "nothing gives a position: the gravity reference is on");
    let model = if gravity { model } else { model.with_gravity_reference(None) };
    let mut engine = Engine::new(model, EngineConfig::from_config(&config));
    let mut out = Run::default();
    let t0_ns = samples[0].header().t_ns;
    let mut sink = |e: &Entry<_>| {
        let Sample::Imu(_) = e.sample else { return };
        out.gravity_updates = <InsModel as Model>::diagnostics(&e.state).gravity_updates;
        let k = ((e.key.t_ns - t0_ns) / 10_000_000) as usize;
        let t = truth.t_s[k];
        if t < FROM_S {
            return;
        }
        let cov = <InsModel as Model>::covariance(&e.state);
        let n = (cov.len() as f64).sqrt().round() as usize;
        let P = Matrix3::from_fn(|r, c| cov[(6 + r) * n + 6 + c]);
        let q = e.state.q();
        // R_true = R Exp(δθ): the error about the body's axes.
        let dtheta = (q.inverse() * truth.attitude[k]).scaled_axis();
        let nees = if compass {
            dtheta.dot(&P.cholesky().expect("P positive definite").solve(&dtheta)) / 3.0
        } else {
            // Roll and pitch: the error's horizontal part in the world frame.
            let R = q.to_rotation_matrix().into_inner();
            let (e, Pw) = (R * dtheta, R * P * R.transpose());
            let (e2, P2) = (Vector2::new(e.x, e.y), Matrix2::new(Pw[(0, 0)], Pw[(0, 1)], Pw[(1, 0)], Pw[(1, 1)]));
            e2.dot(&P2.cholesky().expect("P positive definite").solve(&e2)) / 2.0
        };
        out.nees = (out.nees.0 + nees, out.nees.1 + 1);
        let tilt = {
            let up = |q: &UnitQuaternion<f64>| q.inverse_transform_vector(&Vector3::z());
            up(&q).angle(&up(&truth.attitude[k]))
        };
        let angle = if compass { dtheta.norm() } else { tilt };
        out.worst_deg = out.worst_deg.max(angle.to_degrees());
        if disturbed && out.heading_after_sigmas.is_none() && t >= DISTURBANCE.1 + 10.0 {
            let yaw = |q: &UnitQuaternion<f64>| {
                let x = q.transform_vector(&Vector3::x());
                x.y.atan2(x.x)
            };
            let err = (yaw(&q) - yaw(&truth.attitude[k]) + PI).rem_euclid(2.0 * PI) - PI;
            let u = q.inverse_transform_vector(&Vector3::z());
            out.heading_after_sigmas = Some(err.abs() / (u.dot(&(P * u))).sqrt());
        }
    };
    for s in &samples {
        engine.insert(s, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

fn check(compass: bool) {
    let runs: Vec<Run> = (0..RUNS).map(|seed| run(7100 + seed, compass, true)).collect();
    let (sum, n) = runs.iter().fold((0.0, 0), |(s, k), r| (s + r.nees.0, k + r.nees.1));
    let nees = sum / n as f64;
    let worst = runs.iter().map(|r| r.worst_deg).fold(0.0, f64::max);
    let after: Vec<f64> = runs.iter().filter_map(|r| r.heading_after_sigmas).collect();
    let updates = runs.iter().map(|r| r.gravity_updates).sum::<u64>() as f64 / RUNS as f64;
    let what = if compass { "IMU and magnetometer: attitude" } else { "IMU alone: roll and pitch" };
    eprintln!(
        "{RUNS} runs, {what} NEES/dof {nees:.2}, worst error {worst:.1} deg, gravity updates {updates:.0} a run; \
         heading 10 s after a disturbance, in sigma: {after:.2?}"
    );
    let without: Vec<Run> = (0..RUNS).map(|seed| run(7100 + seed, compass, false)).collect();
    let (sum, n) = without.iter().fold((0.0, 0), |(s, k), r| (s + r.nees.0, k + r.nees.1));
    eprintln!(
        "  without the gravity reference (the gyro alone after the alignment): NEES/dof {:.2}, worst error {:.1} deg",
        sum / n as f64,
        without.iter().map(|r| r.worst_deg).fold(0.0, f64::max)
    );
    assert!((0.75..=1.35).contains(&nees), "NEES/dof {nees}");
    assert!(worst < 10.0, "an attitude error of {worst} degrees");
    assert!(runs.iter().all(|r| r.gravity_updates > 50), "the gravity reference holds the tilt");
    if compass {
        assert_eq!(after.len() as u64, RUNS / 2, "every disturbed run");
        assert!(after.iter().all(|s| *s <= 3.0), "the heading back within 3 sigma: {after:?}");
    }
}

/// An IMU and a magnetometer, moved by hand: the attitude consistent and held.
#[test]
fn an_imu_and_a_magnetometer_hold_the_attitude_by_hand() {
    check(true);
}

/// An IMU alone, moved by hand: roll and pitch consistent and held.
#[test]
fn an_imu_alone_holds_roll_and_pitch_by_hand() {
    check(false);
}
