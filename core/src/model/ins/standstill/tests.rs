use super::*;
use crate::model::Model;
use crate::model::ins::N;
use crate::model::ins::tests_support::NOISE;
use nalgebra::UnitQuaternion;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

const RATE_HZ: f64 = 200.0;
const GRAVITY: f64 = 9.80665;

/// A model with standstill on and a prior that knows the tilt to 0.01 rad, the
/// accelerometer bias to 0.01 m/s² and the gyro bias to 10⁻⁴ rad/s.
fn model() -> InsModel {
    let mut x0 = [0.0; 16];
    x0[6..10].copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
    let mut p0 = [1e-2; N];
    p0[6..9].copy_from_slice(&[1e-4, 1e-4, 4e-4]);
    p0[9..12].copy_from_slice(&[1e-4; 3]);
    p0[12..15].copy_from_slice(&[1e-8; 3]);
    InsModel::new(NOISE, GRAVITY, x0, p0, None, 0).unwrap().with_standstill(Some(Standstill::default()))
}

fn yaw(s: &InsState) -> f64 {
    s.q().euler_angles().2
}

/// Runs `seconds` of 200 Hz samples of true specific force `f` and rate `w`
/// (body frame) with the configured white noise, as the engine steps them:
/// propagate to the sample, hold it, observe it. Returns each sample's
/// standing flag.
fn drive(m: &InsModel, s: &mut InsState, t0_ns: u64, seconds: f64, f: Vector3<f64>, w: Vector3<f64>) -> Vec<bool> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(t0_ns);
    let c = *m.standstill().unwrap();
    let mut noise =
        |density: f64| Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut rng)) * density * RATE_HZ.sqrt();
    let n = (seconds * RATE_HZ) as u64;
    (0..n)
        .map(|k| {
            let t = t0_ns + k * 5_000_000;
            m.propagate_to(s, t, None);
            let (f, w) = (f + noise(NOISE.accelerometer_noise_density), w + noise(NOISE.gyroscope_noise_density));
            m.hold_imu(s, 0, t, f, w);
            observe(&c, m, s, t, f, w);
            s.standing()
        })
        .collect()
}

#[test]
fn a_vehicle_at_rest_is_found_standing_and_its_yaw_and_attitude_error_are_held() {
    let m = model();
    let mut s = m.initial_state();
    let standing = drive(&m, &mut s, 1_000_000_000, 1.0, Vector3::new(0.0, 0.0, GRAVITY), Vector3::zeros());
    assert!(standing[100..].iter().all(|&b| b), "standing from the second window on");
    let (yaw0, updates0) = (yaw(&s), s.standstill_updates());
    let u = s.q().to_rotation_matrix().into_inner().transpose() * Vector3::z();
    let yaw_var = |s: &InsState| {
        let P = s.filter().P();
        let block = P.fixed_view::<3, 3>(6, 6);
        (u.transpose() * block * u)[(0, 0)]
    };
    let var0 = yaw_var(&s);
    drive(&m, &mut s, 2_000_000_000, 20.0, Vector3::new(0.0, 0.0, GRAVITY), Vector3::zeros());
    assert!(s.standing());
    assert!(s.standstill_updates() >= updates0 + 95, "{} updates", s.standstill_updates());
    assert!(s.v().norm() < 0.05, "held at rest: {}", s.v());
    // The yaw neither moves (gyro not integrated, updates consider it; what
    // is left is the second-order effect of roll and pitch corrections on
    // the Euler yaw, 10⁻⁶ rad here) nor gains or loses variance.
    assert!((yaw(&s) - yaw0).abs() < 1e-5, "yaw moved by {}", yaw(&s) - yaw0);
    assert!((yaw_var(&s) - var0).abs() <= 1e-5 * var0, "yaw variance {var0} -> {}", yaw_var(&s));
    // Without standstill the same 20 s integrate the gyro's noise into the yaw.
    let m_off = model().with_standstill(None);
    let mut off = m_off.initial_state();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for k in 0..4200u64 {
        let t = 1_000_000_000 + k * 5_000_000;
        m_off.propagate_to(&mut off, t, None);
        let n: f64 = StandardNormal.sample(&mut rng);
        let w = Vector3::new(0.0, 0.0, n * NOISE.gyroscope_noise_density * RATE_HZ.sqrt());
        m_off.hold_imu(&mut off, 0, t, Vector3::new(0.0, 0.0, GRAVITY), w);
    }
    assert!(yaw(&off).abs() > 1e-5, "{}", yaw(&off));
}

#[test]
fn a_smooth_acceleration_and_a_steady_turn_are_not_standing() {
    let m = model();
    let g = Vector3::new(0.0, 0.0, GRAVITY);
    let mut s = m.initial_state();
    let standing = drive(&m, &mut s, 1_000_000_000, 2.0, g + Vector3::new(1.0, 0.0, 0.0), Vector3::zeros());
    assert!(standing.iter().all(|&b| !b), "1 m/s² forward is not rest");
    let mut s = m.initial_state();
    let standing = drive(&m, &mut s, 1_000_000_000, 2.0, g, Vector3::new(0.0, 0.0, 0.05));
    assert!(standing.iter().all(|&b| !b), "a 3°/s turn is not rest");
    // Vibration: the variance test.
    let mut s = m.initial_state();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let c = *m.standstill().unwrap();
    for k in 0..400u64 {
        let t = 1_000_000_000 + k * 5_000_000;
        m.propagate_to(&mut s, t, None);
        let shake = Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut rng)) * 1.5;
        m.hold_imu(&mut s, 0, t, g + shake, Vector3::zeros());
        observe(&c, &m, &mut s, t, g + shake, Vector3::zeros());
        assert!(!s.standing(), "an engine shaking the body at 1.5 m/s² is not rest");
    }
}

/// A gyro bias of 0.02 rad/s that the filter believes it knows (σ 10⁻⁴):
/// the mean-rate test fails at rest, and the vehicle is never found
/// standing; with the wheels reading exactly 0 it is, and the standstill
/// updates are fused (velocity held at zero). A turn on the spot
/// (0.3 rad/s, wheels' forward speed 0) is not rest.
#[test]
fn wheels_reading_zero_find_a_standstill_the_unlearnt_bias_hides() {
    let m = model();
    let c = *m.standstill().unwrap();
    let g = Vector3::new(0.0, 0.0, GRAVITY);
    let bias = Vector3::new(0.0, 0.0, 0.02);
    let run = |wheels: bool, w: Vector3<f64>| {
        let mut s = m.initial_state();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut standing = Vec::new();
        for k in 0..1200u64 {
            let t = 1_000_000_000 + k * 5_000_000;
            m.propagate_to(&mut s, t, None);
            if wheels && k % 4 == 0 {
                s.still.odometry(&c, t, 0.0);
            }
            let n = Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let w = w + bias + n * NOISE.gyroscope_noise_density * RATE_HZ.sqrt();
            m.hold_imu(&mut s, 0, t, g, w);
            observe(&c, &m, &mut s, t, g, w);
            standing.push(s.standing());
        }
        (standing, s.standstill_updates())
    };
    let (standing, _) = run(false, Vector3::zeros());
    assert!(standing.iter().all(|&b| !b), "the unlearnt bias fails the mean-rate test");
    let (standing, updates) = run(true, Vector3::zeros());
    assert!(standing[100..].iter().all(|&b| b), "standing from the second window on");
    assert!(updates >= 25, "{updates} standstill updates");
    let (standing, _) = run(true, Vector3::new(0.0, 0.0, 0.3));
    assert!(standing.iter().all(|&b| !b), "a turn on the spot is not rest");
}

#[test]
fn motion_ends_a_standstill_at_once() {
    let m = model();
    let c = *m.standstill().unwrap();
    let g = Vector3::new(0.0, 0.0, GRAVITY);
    let mut s = m.initial_state();
    drive(&m, &mut s, 1_000_000_000, 1.0, g, Vector3::zeros());
    assert!(s.standing());
    // The wheels turn.
    let mut moving = s;
    moving.still.odometry(&c, 2_000_000_000, 0.2);
    assert!(!moving.standing());
    // A turn starts: one sample of 0.5 rad/s, far beyond the gyro's noise.
    let t = 2_000_000_000;
    m.propagate_to(&mut s, t, None);
    let w = Vector3::new(0.0, 0.0, 0.5);
    m.hold_imu(&mut s, 0, t, g, w);
    observe(&c, &m, &mut s, t, g, w);
    assert!(!s.standing());
    // A vehicle whose estimated speed is above the bound is not standing,
    // however quiet its IMU.
    let mut fast = m.initial_state();
    let q = UnitQuaternion::identity();
    fast.set(Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0), q, Vector3::zeros(), Vector3::zeros());
    let standing = drive(&m, &mut fast, 1_000_000_000, 1.0, g, Vector3::zeros());
    assert!(standing.iter().all(|&b| !b));
}

#[test]
fn while_standing_the_propagation_holds_the_attitude() {
    let m = model();
    let g = Vector3::new(0.0, 0.0, GRAVITY);
    let mut s = m.initial_state();
    drive(&m, &mut s, 1_000_000_000, 1.0, g, Vector3::zeros());
    assert!(s.standing());
    let (q0, P0) = (s.q(), s.filter().P());
    // A gyro sample far off (held for the next step) does not turn the body.
    m.hold_imu(&mut s, 0, 2_000_000_000, g, Vector3::new(0.0, 0.0, 0.01));
    m.propagate_to(&mut s, 2_100_000_000, None);
    assert_eq!(s.q(), q0);
    let P = s.filter().P();
    for i in 6..9 {
        assert_eq!(P[(i, i)], P0[(i, i)], "no attitude noise while standing");
        for j in 12..15 {
            assert_eq!(P[(i, j)], P0[(i, j)], "no attitude–gyro bias coupling while standing");
        }
    }
}
