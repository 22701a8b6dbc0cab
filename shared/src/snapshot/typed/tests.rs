use super::super::{MAX_COV, StateSnapshot, health, model};
use super::{Health, HealthReason, Model};
use crate::SampleKind;

/// Hamilton product of `[w, x, y, z]` quaternions.
fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// `Exp(θ)`: the rotation by `|θ|` about `θ`.
fn exp(t: [f64; 3]) -> [f64; 4] {
    let angle = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    if angle == 0.0 {
        return [1.0, 0.0, 0.0, 0.0];
    }
    let s = (angle / 2.0).sin() / angle;
    [(angle / 2.0).cos(), t[0] * s, t[1] * s, t[2] * s]
}

/// `Rz(yaw) Ry(pitch) Rx(roll)` as a quaternion.
fn from_rpy([roll, pitch, yaw]: [f64; 3]) -> [f64; 4] {
    mul(mul(exp([0.0, 0.0, yaw]), exp([0.0, pitch, 0.0])), exp([roll, 0.0, 0.0]))
}

/// Rotates `v` by `q`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let r = mul(mul(q, [0.0, v[0], v[1], v[2]]), [q[0], -q[1], -q[2], -q[3]]);
    [r[1], r[2], r[3]]
}

fn ins(q: [f64; 4], attitude_cov: [[f64; 3]; 3]) -> StateSnapshot {
    let mut s = StateSnapshot { model: model::INS, state_len: 16, cov_dim: 15, ..Default::default() };
    for (i, v) in (0..16).map(|i| i as f64 + 1.0).enumerate() {
        s.x[i] = v;
    }
    s.x[6..10].copy_from_slice(&q);
    for i in 0..15 {
        s.cov[i * 15 + i] = (i + 1) as f64;
    }
    for (i, row) in attitude_cov.iter().enumerate() {
        s.cov[(6 + i) * 15 + 6..(6 + i) * 15 + 9].copy_from_slice(row);
    }
    s
}

#[test]
fn each_accessor_takes_its_entries_of_the_ins_layout() {
    let s = ins([1.0, 0.0, 0.0, 0.0], [[7.0, 0.0, 0.0], [0.0, 8.0, 0.0], [0.0, 0.0, 9.0]]);
    assert_eq!(s.position(), Some([1.0, 2.0, 3.0]));
    assert_eq!(s.velocity(), Some([4.0, 5.0, 6.0]));
    assert_eq!(s.attitude(), Some([1.0, 0.0, 0.0, 0.0]));
    assert_eq!(s.accel_bias(), Some([11.0, 12.0, 13.0]));
    assert_eq!(s.gyro_bias(), Some([14.0, 15.0, 16.0]));
    let sd = |a: usize| [a, a + 1, a + 2].map(|v| (v as f64).sqrt());
    assert_eq!(s.position_std(), Some(sd(1)));
    assert_eq!(s.velocity_std(), Some(sd(4)));
    assert_eq!(s.attitude_std(), Some(sd(7)));
    assert_eq!(s.accel_bias_std(), Some(sd(10)));
    assert_eq!(s.gyro_bias_std(), Some(sd(13)));
    for (i, (name, cov)) in Model::Ins.state_layout().iter().enumerate() {
        assert_eq!(cov.is_none(), (6..10).contains(&i), "{name}");
        if let Some(k) = cov {
            // Each state's covariance index is the one its accessor reads.
            assert_eq!(*k, if i < 6 { i } else { i - 1 }, "{name}");
        }
    }
}

#[test]
fn the_linear_model_has_position_and_velocity_only() {
    let mut s = StateSnapshot { model: model::LINEAR, state_len: 6, cov_dim: 6, ..Default::default() };
    s.x[..6].copy_from_slice(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    (0..6).for_each(|i| s.cov[i * 6 + i] = 4.0);
    assert_eq!(s.model(), Some(Model::Linear));
    assert_eq!(s.position(), Some([1.0, 2.0, 3.0]));
    assert_eq!(s.velocity(), Some([4.0, 5.0, 6.0]));
    assert_eq!(s.velocity_std(), Some([2.0; 3]));
    assert_eq!(s.attitude(), None);
    assert_eq!(s.roll_pitch_yaw(), None);
    assert_eq!(s.attitude_std(), None);
    assert_eq!(s.accel_bias(), None);
    assert_eq!(s.gyro_bias_std(), None);
    assert_eq!(Model::Linear.state_len(), 6);
    assert_eq!(Model::Ins.state_len(), 16);
}

#[test]
fn an_unknown_model_or_a_short_state_reads_as_nothing() {
    let default = StateSnapshot::default();
    assert_eq!(default.model(), None);
    assert_eq!(default.position(), None);
    assert_eq!(default.position_std(), None);
    let mut s = StateSnapshot { model: 9, state_len: 16, cov_dim: 15, ..Default::default() };
    assert_eq!(s.position(), None);
    s.model = model::INS;
    s.state_len = 8; // fewer than the model has
    s.cov_dim = 7;
    assert_eq!(s.position(), Some([0.0; 3]));
    assert_eq!(s.attitude(), None);
    assert_eq!(s.attitude_std(), None);
    s.cov_dim = MAX_COV as u32 + 1; // a garbled side is not read past the array
    assert_eq!(s.position_std(), None);
}

#[test]
fn roll_pitch_yaw_invert_the_zyx_rotation() {
    for rpy in [[0.1, -0.2, 2.5], [-3.0, 1.2, -1.0], [0.0, 0.0, -3.1], [0.7, -1.5, 0.3]] {
        let s = ins(from_rpy(rpy), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        let got = s.roll_pitch_yaw().unwrap();
        for (g, w) in got.iter().zip(rpy) {
            assert!((g - w).abs() < 1e-12, "{got:?} != {rpy:?}");
        }
    }
    // The conventions: yaw from east counter-clockwise, pitch positive nose down, roll right side down.
    let forward = rotate(from_rpy([0.0, 0.0, 0.5]), [1.0, 0.0, 0.0]);
    assert!((forward[1].atan2(forward[0]) - 0.5).abs() < 1e-15);
    assert!(rotate(from_rpy([0.0, 0.3, 0.0]), [1.0, 0.0, 0.0])[2] < 0.0);
    assert!(rotate(from_rpy([0.3, 0.0, 0.0]), [0.0, 1.0, 0.0])[2] > 0.0);
}

#[test]
fn roll_pitch_yaw_std_is_the_local_attitude_covariance_through_the_euler_angles() {
    // A full attitude covariance at a tilted attitude: compare E Σ Eᵀ with the
    // Jacobian of roll/pitch/yaw under q ⊗ Exp(δθ), by central differences.
    let rpy = [0.4, -0.6, 2.0];
    let cov = [[4e-4, 1e-4, -5e-5], [1e-4, 9e-4, 2e-4], [-5e-5, 2e-4, 2.5e-3]];
    let s = ins(from_rpy(rpy), cov);
    let angles = |d: [f64; 3]| {
        let t = ins(mul(from_rpy(rpy), exp(d)), cov);
        t.roll_pitch_yaw().unwrap()
    };
    let h = 1e-6;
    let mut jac = [[0.0; 3]; 3];
    for c in 0..3 {
        let (mut plus, mut minus) = ([0.0; 3], [0.0; 3]);
        plus[c] = h;
        minus[c] = -h;
        let (a, b) = (angles(plus), angles(minus));
        (0..3).for_each(|r| jac[r][c] = (a[r] - b[r]) / (2.0 * h));
    }
    let got = s.roll_pitch_yaw_std().unwrap();
    for r in 0..3 {
        let var: f64 =
            (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| jac[r][i] * cov[i][j] * jac[r][j]).sum();
        assert!((got[r] - var.sqrt()).abs() < 1e-8 * var.sqrt(), "row {r}: {} vs {}", got[r], var.sqrt());
    }
}

#[test]
fn health_and_reasons_decode_every_bit() {
    let mut s = StateSnapshot::default();
    assert_eq!(s.health(), Health::Initialising);
    s.health = health::OK;
    assert_eq!(s.health(), Health::Ok);
    s.health = 77;
    assert_eq!(s.health(), Health::Unknown(77));
    assert_eq!(s.health().to_string(), "unknown");
    s.health_reasons = u32::MAX;
    let all: Vec<HealthReason> = s.health_reasons().collect();
    assert_eq!(all.len(), 3 + SampleKind::COUNT);
    // Each reason's bit and name are the raw constants' (and the names the same as
    // health_reason_names gives).
    let names: Vec<&str> = s.health_reason_names().collect();
    assert_eq!(all.iter().map(|r| r.name()).collect::<Vec<_>>(), names);
    for r in &all {
        assert_eq!(HealthReason::decode(r.bit()).collect::<Vec<_>>(), [*r]);
    }
    assert_eq!(HealthReason::Stale(SampleKind::Imu).bit(), health::IMU_STALE);
    // Bits no reason has are skipped.
    assert_eq!(HealthReason::decode(1 << 30).count(), 0);
    assert_eq!(s.input_kind(), None); // INPUT_NONE
}
