//! Tests of the `ins` model: mechanisation, alignment, constraint, propagation.

use super::*;
use crate::measurement::Steps;
use crate::model::held_imu::Held;
use fusion_shared::{ImuSample, PositionSample, Sample};

const G: f64 = 9.80665;

fn noise() -> ImuNoise {
    ImuNoise {
        accelerometer_noise_density: 0.02,
        gyroscope_noise_density: 0.001,
        accelerometer_random_walk: 0.001,
        gyroscope_random_walk: 1e-5,
    }
}

fn x0() -> [f64; NOMINAL] {
    let mut x = [0.0; NOMINAL];
    x[6] = 1.0;
    x
}

fn p0() -> [f64; N] {
    let mut p = [0.0; N];
    p[0..3].fill(1.0);
    p[3..6].fill(0.1);
    p[6..9].fill(0.01);
    p[9..12].fill(0.01);
    p[12..15].fill(1e-6);
    p
}

fn imu(t_ns: u64, seq: u64, f: Vector3<f64>, w: Vector3<f64>) -> Sample {
    Sample::Imu(ImuSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t_ns, 0, seq),
        accel_mps2: f.into(),
        gyro_radps: w.into(),
    })
}

#[test]
fn structured_fpft_equals_the_dense_product() {
    let m = InsModel::new(noise(), G, x0(), p0(), None, 0).unwrap();
    let mut s = m.initial_state();
    let set = crate::frames::Frames::default();
    s.imu.hold(set.imus(), 0, 0, Vector3::new(0.3, -0.2, 9.7), Vector3::new(0.1, 0.05, -0.3));
    s.ready = true;
    let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 0.7);
    s.set(Vector3::zeros(), Vector3::new(3.0, 1.0, 0.0), q, Vector3::new(0.01, 0.0, 0.0), Vector3::zeros());
    let L = SMatrix::<f64, N, N>::from_fn(|i, j| if i >= j { 0.1 + ((i * 7 + j * 3) % 5) as f64 * 0.05 } else { 0.0 });
    let P = L * L.transpose();
    s.kf.set_state(SVector::zeros(), P).unwrap();
    let mut log = StepLog::begin(&s.kf);
    m.propagate(&mut s, 0.005, Some(&mut log));
    let F = log.finish(&s.kf).F;
    // A moving step: the attitude and bias couplings are really there.
    assert!(F.fixed_view::<3, 3>(3, 6).amax() > 1e-3 && F.fixed_view::<3, 3>(6, 12).amax() > 1e-3);
    let dense = F * P * F.transpose() + m.process_noise(0.005, 1).dense();
    assert!((s.kf.P() - dense).amax() < 1e-12 * dense.amax(), "{}", (s.kf.P() - dense).amax());
    assert_eq!(s.kf.P(), s.kf.P().transpose(), "exactly symmetric");
}

#[test]
fn the_motion_constraint_pulls_sideways_velocity_but_waits_for_a_known_attitude() {
    let nhc = Nonholonomic { std_mps: 0.1, interval_ns: 50_000_000, min_speed_mps: 1.0, lever_arm_m: [0.0; 3] };
    // Driving along body x at 10 m/s, with a 0.5 m/s sideways error in the estimate.
    let mut x = x0();
    x[3] = 10.0;
    x[4] = 0.5;
    let f = Vector3::new(0.0, 0.0, G);
    let run = |p0: [f64; N], constraint: Option<Nonholonomic>| {
        let m = InsModel::new(noise(), G, x, p0, None, 0).unwrap().with_nonholonomic(constraint);
        let mut s = m.initial_state();
        for k in 0..=20u64 {
            m.step(&mut s, &imu(k * 5_000_000, k, f, Vector3::zeros()));
        }
        s
    };
    let mut known = p0();
    known[6..9].fill(1e-4); // attitude known to 0.01 rad
    let free = run(known, None);
    let constrained = run(known, Some(nhc));
    assert!(free.v().y > 0.49, "no constraint: the sideways velocity stays, {}", free.v().y);
    assert!(constrained.v().y.abs() < 0.1, "constrained: pulled towards 0, {}", constrained.v().y);
    // Heading unknown (1 rad): the constraint must not act yet.
    let mut loose = p0();
    loose[8] = 1.0;
    let (waiting, free) = (run(loose, Some(nhc)), run(loose, None));
    assert_eq!((waiting.nominal, waiting.kf.P()), (free.nominal, free.kf.P()));
}

/// A ground robot's constraint at its defaults (every speed) at the rear
/// axle: a sideways velocity error is pulled out while reversing and at rest
/// too (it was applied only above 1 m/s forward, so a reversing robot's
/// lateral velocity drifted and a stop "observed" its yaw). And at a lever arm
/// while turning: the point's lateral speed `v_y + ω_z l_x` is what is zeroed.
#[test]
fn the_motion_constraint_holds_reversing_at_rest_and_at_its_lever_arm() {
    let nhc: Nonholonomic =
        toml::from_str("nonholonomic_std_mps = 0.05\nnonholonomic_lever_arm_m = [-0.3, 0.0, -0.2]\n")
            .expect("the defaults");
    assert_eq!((nhc.min_speed_mps, nhc.interval_ns), (0.0, 50_000_000));
    let f = Vector3::new(0.0, 0.0, G);
    let run = |forward: f64, lateral: f64, w: Vector3<f64>| {
        let mut x = x0();
        (x[3], x[4]) = (forward, lateral);
        let mut known = p0();
        known[6..9].fill(1e-4);
        let m = InsModel::new(noise(), G, x, known, None, 0).unwrap().with_nonholonomic(Some(nhc));
        let mut s = m.initial_state();
        for k in 0..=20u64 {
            m.step(&mut s, &imu(k * 5_000_000, k, f, w));
        }
        s
    };
    for (forward, what) in [(-0.5, "reversing"), (0.0, "at rest"), (0.5, "forward, slowly")] {
        let s = run(forward, 0.3, Vector3::zeros());
        assert!(s.v().y.abs() < 0.05, "{what}: lateral {}", s.v().y);
    }
    // Turning at 0.5 rad/s with the IMU 0.3 m ahead of the axle: the axle does
    // not slide, so the IMU's own lateral velocity is ω l = 0.15 m/s.
    let s = run(0.5, 0.0, Vector3::new(0.0, 0.0, 0.5));
    let lateral_at_axle =
        InsModel::<N>::body_rate(&s).cross(&Vector3::new(-0.3, 0.0, -0.2)).y + (s.q().inverse() * s.v()).y;
    assert!(lateral_at_axle.abs() < 0.03, "{lateral_at_axle}");
    assert!((s.q().inverse() * s.v()).y > 0.1, "the IMU slides as the turn says: {}", s.v());
}

/// The body velocity of a point and its Jacobian (velocity, attitude, gyro
/// bias through the lever arm) against central differences.
#[test]
fn the_point_velocity_jacobian_matches_numerical_differentiation() {
    let s = super::tests_support::moving_state();
    let l = Vector3::new(-0.3, 0.25, -0.2);
    let (v, H) = nonholonomic::point_velocity(&s, &l);
    let numeric = super::tests_support::numeric_jacobian(&s, |x| nonholonomic::point_velocity(x, &l).0);
    assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
    assert!(H.fixed_view::<3, 3>(0, 12).amax() > 0.1, "the gyro bias enters through the lever arm");
    assert!((v - (s.q().inverse() * s.v() + InsModel::<N>::body_rate(&s).cross(&l))).norm() < 1e-12);
}

#[test]
fn a_constant_rotation_rate_integrates_to_the_right_attitude() {
    let m = InsModel::new(noise(), G, x0(), p0(), None, 0).unwrap();
    let mut s = m.initial_state();
    let w = Vector3::new(0.2, -0.1, 0.5);
    // At rest with the attitude turning: the accelerometer keeps reading Rᵀ [0, 0, g].
    let mut t = 0u64;
    for k in 0..=1000u64 {
        t = k * 2_000_000; // 500 Hz, 2 s
        let q_true = UnitQuaternion::from_scaled_axis(w * (t as f64 * 1e-9));
        let f = q_true.inverse_transform_vector(&Vector3::new(0.0, 0.0, G));
        m.step(&mut s, &imu(t, k, f, w));
    }
    let q_true = UnitQuaternion::from_scaled_axis(w * (t as f64 * 1e-9));
    assert!(s.q().angle_to(&q_true) < 1e-9, "attitude error {} rad", s.q().angle_to(&q_true));
    // Holding R over a step leaves an O(|w| dt) error in the gravity
    // compensation; over 2 s it must stay at the millimetre level.
    assert!(s.p().norm() < 5e-3 && s.v().norm() < 5e-3, "p {} v {}", s.p(), s.v());
}

#[test]
fn noiseless_constant_acceleration_is_tracked_to_numerical_precision() {
    // Fixed tilted attitude, constant acceleration: the mechanisation is exact.
    let q = UnitQuaternion::from_euler_angles(0.05, -0.1, 1.2);
    let mut x = x0();
    let c = q.quaternion().coords;
    x[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
    x[3] = 2.0;
    let m = InsModel::new(noise(), G, x, p0(), None, 0).unwrap();
    let mut s = m.initial_state();
    let a = Vector3::new(0.4, -0.3, 0.05);
    let f = q.inverse_transform_vector(&(a + Vector3::new(0.0, 0.0, G)));
    let truth = |t: f64| (Vector3::new(2.0 * t, 0.0, 0.0) + a * (0.5 * t * t), Vector3::new(2.0, 0.0, 0.0) + a * t);
    for k in 0..=2000u64 {
        let t = k * 5_000_000;
        m.step(&mut s, &imu(t, k, f, Vector3::zeros()));
        if k % 20 == 0 {
            let (p, _) = truth(t as f64 * 1e-9);
            let fix = PositionSample {
                header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t, 1, k / 20),
                pos_m: p.into(),
                cov_m2: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
            };
            m.step(&mut s, &Sample::Position(fix));
        }
    }
    let (p, v) = truth(10.0);
    assert!(
        (s.p() - p).norm() < 1e-9 && (s.v() - v).norm() < 1e-9,
        "p err {} v err {}",
        (s.p() - p).norm(),
        (s.v() - v).norm()
    );
    assert!(s.q().angle_to(&q) < 1e-12);
}

#[test]
fn a_stationary_vehicle_stays_put_and_its_accelerometer_bias_converges() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    // Tilted at rest (so pitch and roll make the horizontal bias observable
    // against gravity only through the level constraint of position fixes).
    let q = UnitQuaternion::from_euler_angles(0.02, -0.03, 0.4);
    let mut x = x0();
    let c = q.quaternion().coords;
    x[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
    let mut p0 = p0();
    p0[6..9].fill(1e-8); // attitude known well: the bias is what must converge
    let m = InsModel::new(noise(), G, x, p0, None, 0).unwrap();
    let mut s = m.initial_state();
    let b_a = Vector3::new(0.05, -0.08, 0.1);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut n = |std: f64| Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut rng)) * std;
    let rate = 200.0;
    let f_true = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, G));
    for k in 0..(120 * 200u64) {
        let t = k * 5_000_000;
        let f = f_true + b_a + n(0.02 * f64::sqrt(rate));
        let w = n(0.001 * f64::sqrt(rate));
        m.step(&mut s, &imu(t, k, f, w));
        if k % 20 == 0 {
            let z = n(0.3);
            let fix = PositionSample {
                header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t, 1, k / 20),
                pos_m: z.into(),
                cov_m2: [0.09, 0.0, 0.0, 0.0, 0.09, 0.0, 0.0, 0.0, 0.09],
            };
            m.step(&mut s, &Sample::Position(fix));
        }
    }
    let sd = |i: usize| s.kf.P()[(i, i)].sqrt();
    for i in 0..3 {
        // Stays put: within its own 4-sigma and physically small.
        assert!(s.p()[i].abs() < (4.0 * sd(i)).max(0.02) && s.p()[i].abs() < 0.3, "p[{i}] {}", s.p()[i]);
        assert!(s.v()[i].abs() < (4.0 * sd(3 + i)).max(0.02) && s.v()[i].abs() < 0.2, "v[{i}] {}", s.v()[i]);
    }
    // At rest the bias along gravity is observable: it converges (the prior sd was 0.1).
    let bz = s.b_a() - b_a;
    let bz = q.transform_vector(&bz).z; // world-vertical component
    let sd_v = (q.to_rotation_matrix() * s.kf.P().fixed_view::<3, 3>(9, 9) * q.to_rotation_matrix().transpose())
        [(2, 2)]
        .sqrt();
    assert!(bz.abs() < 4.0 * sd_v && bz.abs() < 0.005 && sd_v < 0.01, "vertical bias error {bz} (sd {sd_v})");
    // Horizontally, bias and tilt are one observable together (gyro noise lets
    // the tilt wander): their sum is what must converge, so that the specific
    // force, corrected and rotated, cancels gravity.
    let a_world = s.q() * (f_true + b_a - s.b_a()) + Vector3::new(0.0, 0.0, -G);
    // 0.03 m/s² is the pull of gravity on a 0.17° tilt error.
    assert!(a_world.norm() < 0.03, "estimated acceleration at rest {a_world}");
}

#[test]
fn static_alignment_levels_the_attitude_and_finds_the_gyro_bias() {
    let (roll, pitch, yaw) = (0.04, -0.03, 0.9);
    let mut x = x0();
    let q_yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
    let c = q_yaw.quaternion().coords;
    x[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
    let m = InsModel::new(noise(), G, x, p0(), None, 100).unwrap();
    let mut s = m.initial_state();
    let q_true = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
    let f = q_true.inverse_transform_vector(&Vector3::new(0.0, 0.0, G));
    let b_g = Vector3::new(0.002, -0.001, 0.0005);
    for k in 0..100 {
        assert!(!InsModel::initialised(&s), "initialising until aligned");
        m.step(&mut s, &imu(k * 5_000_000, k, f, b_g));
    }
    assert!(InsModel::initialised(&s));
    assert!(s.q().angle_to(&q_true) < 1e-9, "{}", s.q().angle_to(&q_true));
    assert!((s.b_g() - b_g).norm() < 1e-15);
    assert_eq!(s.p(), Vector3::zeros(), "held still while aligning");
}

/// The mean of n IMUs has 1/n of one IMU's white-noise power; the bias random
/// walks stay as configured.
#[test]
fn averaged_imus_scale_the_white_noise_not_the_bias_walks() {
    let m = InsModel::new(noise(), G, x0(), p0(), None, 0).unwrap();
    let (one, two) = (m.process_noise(0.01, 1), m.process_noise(0.01, 2));
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
    assert!(close(two.vv, one.vv / 2.0) && close(two.pv, one.pv / 2.0) && close(two.pp, one.pp / 2.0));
    assert!(close(two.theta, one.theta / 2.0));
    assert_eq!((two.ba, two.bg), (one.ba, one.bg));
    assert_eq!(m.process_noise(0.01, 0).vv, one.vv, "nothing held: one IMU's noise");
}

/// When the IMUs in use change (failover, or the set in the mean), the bias
/// variances grow back to their initial values; nothing else in P moves.
#[test]
fn when_the_imus_in_use_change_the_bias_variances_grow_back() {
    use crate::frames::{Axes, Combine, ImuConfig, SensorConfig};
    let imu = |id| SensorConfig {
        name: format!("imu-{id}"),
        id,
        kinds: vec!["imu".into()],
        axes: Axes::Flu,
        rotation_rpy_deg: [0.0; 3],
        lever_arm_m: [0.0; 3],
        time_offset_ns: 0,
        topic: None,
        tables: toml::Table::new(),
    };
    let f = Vector3::new(0.0, 0.0, G);
    for combine in [Combine::Failover, Combine::Average] {
        let config = ImuConfig { combine, failover_after_ns: 20, ..Default::default() };
        let frames =
            crate::frames::Frames::from_config(None, &[imu(0), imu(1)], config, &crate::measurement::Kinds).unwrap();
        let m = InsModel::new(noise(), G, x0(), p0(), None, 0).unwrap().with_frames(frames);
        let mut s = m.initial_state();
        assert_eq!(m.hold_imu(&mut s, 0, 0, f, Vector3::zeros()), Held::Held);
        if combine == Combine::Average {
            assert_eq!(m.hold_imu(&mut s, 1, 0, f, Vector3::zeros()), Held::Held);
            assert_eq!(m.hold_imu(&mut s, 0, 10, f, Vector3::zeros()), Held::Held);
        }
        let mut shrunk = s.kf.P();
        for i in 9..15 {
            shrunk[(i, i)] = 1e-9;
        }
        shrunk[(0, 9)] = 1e-6;
        shrunk[(9, 0)] = 1e-6;
        s.kf.set_state(SVector::zeros(), shrunk).unwrap();
        let switch = match combine {
            Combine::Failover => m.hold_imu(&mut s, 1, 100, f, Vector3::zeros()),
            Combine::Average => m.hold_imu(&mut s, 0, 20, f, Vector3::zeros()),
        };
        assert_eq!(switch, Held::Switched, "{combine:?}");
        let P = s.kf.P();
        for i in 9..15 {
            assert_eq!(P[(i, i)], p0()[i], "{combine:?} {i}");
        }
        assert_eq!((P[(0, 0)], P[(0, 9)]), (shrunk[(0, 0)], 1e-6), "{combine:?}");
    }
}
