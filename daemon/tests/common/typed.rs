//! The typed snapshot accessors of the other languages against the Rust ones:
//! a set of snapshots written raw to a file, and the check of what a program
//! printed of them (a JSON object per snapshot, an array of numbers or `null`
//! for each accessor).

use std::path::{Path, PathBuf};

use fusion_shared::StateSnapshot;
use fusion_shared::snapshot::{Model, aux, model};
use serde_json::Value;

/// A tilted ins snapshot: roll, pitch, yaw (rad) as its attitude (the
/// quaternion scaled by `quaternion_scale`), a full attitude-error block and
/// distinct variances everywhere else.
fn ins_snapshot(rpy: [f64; 3], quaternion_scale: f64) -> StateSnapshot {
    let [r, p, y] = rpy.map(|a| a / 2.0);
    let (cr, sr, cp, sp, cy, sy) = (r.cos(), r.sin(), p.cos(), p.sin(), y.cos(), y.sin());
    // q of Rz(yaw) Ry(pitch) Rx(roll), [w, x, y, z].
    let q = [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ];
    let mut s = StateSnapshot { model: model::INS, state_len: 16, cov_dim: 15, ..Default::default() };
    let x = [1.0, -2.0, 3.5, 10.0, 0.5, -0.25, 0.0, 0.0, 0.0, 0.0, 0.01, -0.02, 0.03, 1e-4, -2e-4, 3e-4];
    s.x[..16].copy_from_slice(&x);
    for (i, c) in q.iter().enumerate() {
        s.x[6 + i] = c * quaternion_scale;
    }
    for i in 0..15 {
        s.cov[i * 15 + i] = 1e-3 * (i + 1) as f64;
    }
    let block = [[4e-4, 1e-4, -5e-5], [1e-4, 9e-4, 2e-5], [-5e-5, 2e-5, 2.5e-3]];
    for (i, row) in block.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            s.cov[(6 + i) * 15 + 6 + j] = *v;
        }
    }
    s
}

/// An ins snapshot with the odometry scale factor as its auxiliary state
/// (`k` = 1.012, σ 0.003), its covariance laid out 16×16.
fn ins_with_scale() -> StateSnapshot {
    let core = ins_snapshot([0.1, 0.05, -1.0], 1.0);
    let mut s = StateSnapshot { state_len: 17, cov_dim: 16, aux_states: aux::ODOMETRY_SCALE, ..core };
    s.cov = [0.0; fusion_shared::snapshot::MAX_COV_LEN];
    for r in 0..15 {
        for c in 0..15 {
            s.cov[r * 16 + c] = core.cov[r * 15 + c];
        }
    }
    s.x[16] = 1.012;
    s.cov[15 * 16 + 15] = 9e-6;
    s
}

/// An ins snapshot with every auxiliary state (scale 1.012, bias 480.5 m, a
/// pose frame [0.6 rad, 20, −15, 0.5 m]), its covariance laid out 21×21.
fn ins_with_every_aux() -> StateSnapshot {
    let core = ins_snapshot([0.1, 0.05, -1.0], 1.0);
    let mut s = StateSnapshot {
        state_len: 22,
        cov_dim: 21,
        aux_states: aux::ODOMETRY_SCALE | aux::BARO_BIAS | aux::POSE_FRAME,
        ..core
    };
    s.cov = [0.0; fusion_shared::snapshot::MAX_COV_LEN];
    for r in 0..15 {
        for c in 0..15 {
            s.cov[r * 21 + c] = core.cov[r * 15 + c];
        }
    }
    for (k, (x, var)) in
        [(1.012, 9e-6), (480.5, 4.0), (0.6, 1e-4), (20.0, 0.25), (-15.0, 0.36), (0.5, 0.49)].into_iter().enumerate()
    {
        s.x[16 + k] = x;
        s.cov[(15 + k) * 21 + 15 + k] = var;
    }
    s
}

/// A snapshot of `model` as fusiond would publish it: its state length and
/// covariance side, distinct values in every entry (a unit quaternion where the
/// layout has one) and distinct variances.
fn model_snapshot(model: Model) -> StateSnapshot {
    let mut s = StateSnapshot {
        model: model.code(),
        state_len: model.state_len() as u32,
        cov_dim: model.cov_dim() as u32,
        ..Default::default()
    };
    for (i, (name, _)) in model.state_layout().iter().enumerate() {
        s.x[i] = match name.split(' ').next() {
            Some("q_w") => 0.5,
            Some("q_x" | "q_y" | "q_z") => -0.5,
            _ => 0.25 * (i as f64 + 1.0) - 1.5,
        };
    }
    let n = model.cov_dim();
    (0..n).for_each(|i| s.cov[i * n + i] = 0.01 * (i + 1) as f64);
    s
}

/// The snapshots the accessors are compared on, each with how many of the 13
/// accessors must give a value (both languages agreeing on `None` for the rest).
///
/// One snapshot of every model in the model list (so a new model's layout is
/// compared without a line here; it must at least have a position and its σ),
/// two tilted ins snapshots (the second with a quaternion of norm 2), a linear
/// one, and what must read as missing: an unknown model, a short state, a
/// garbled covariance side, a default (never published) snapshot.
pub fn cases() -> Vec<(StateSnapshot, Option<usize>)> {
    let ins = ins_snapshot([0.3, -0.2, 2.0], 1.0);
    let mut linear = StateSnapshot { model: model::LINEAR, state_len: 6, cov_dim: 6, ..Default::default() };
    linear.x[..6].copy_from_slice(&[4.0, 5.0, 6.0, 0.1, 0.2, 0.3]);
    (0..6).for_each(|i| linear.cov[i * 6 + i] = 0.5 + i as f64);
    let mut cases: Vec<_> = Model::ALL.iter().map(|&m| (model_snapshot(m), None)).collect();
    cases.extend([
        // Every accessor of both ins snapshots; position to velocity_std of the
        // linear one; of the short state its position and the five standard
        // deviations its covariance has (not roll/pitch/yaw: no attitude); of the
        // garbled side the six state accessors.
        (ins, Some(12)),
        (ins_snapshot([-1.2, 0.7, -2.9], 2.0), Some(12)),
        (linear, Some(4)),
        (StateSnapshot { model: 9, ..ins }, Some(0)),
        (StateSnapshot { state_len: 5, ..ins }, Some(6)),
        (StateSnapshot { cov_dim: 22, ..ins }, Some(6)),
        (StateSnapshot::default(), Some(0)),
        // The odometry scale after the ins states, and what must not be read
        // as it: the bit without the room, the room without the bit, a bit
        // this version does not know.
        (ins_with_scale(), Some(13)),
        (StateSnapshot { aux_states: aux::ODOMETRY_SCALE, ..ins }, Some(12)),
        (StateSnapshot { aux_states: 0, ..ins_with_scale() }, Some(12)),
        (StateSnapshot { aux_states: aux::ODOMETRY_SCALE | 1 << 7, ..ins_with_scale() }, Some(12)),
        // Every auxiliary state: the scale, the barometer's bias, the pose frame.
        (ins_with_every_aux(), Some(15)),
        // Refusals by reason (every code, and one past them the names do not read).
        (
            StateSnapshot { rejections: std::array::from_fn(|c| if c == 0 { 0 } else { 1000 + c as u64 }), ..ins },
            Some(12),
        ),
    ]);
    cases
}

/// Writes [`cases`] raw, one `StateSnapshot` after another, to `dir/snapshots.bin`.
pub fn write_cases(dir: &Path) -> PathBuf {
    let path = dir.join("snapshots.bin");
    let bytes: Vec<u8> = cases().iter().flat_map(|(s, _)| super::snapshot_bytes(s).to_vec()).collect();
    std::fs::write(&path, bytes).unwrap();
    path
}

type Accessor = fn(&StateSnapshot) -> Option<Vec<f64>>;

/// Every typed accessor, by the name the other languages give it.
const ACCESSORS: [(&str, Accessor); 15] = [
    ("position", |s| s.position().map(Vec::from)),
    ("velocity", |s| s.velocity().map(Vec::from)),
    ("attitude", |s| s.attitude().map(Vec::from)),
    ("roll_pitch_yaw", |s| s.roll_pitch_yaw().map(Vec::from)),
    ("accel_bias", |s| s.accel_bias().map(Vec::from)),
    ("gyro_bias", |s| s.gyro_bias().map(Vec::from)),
    ("position_std", |s| s.position_std().map(Vec::from)),
    ("velocity_std", |s| s.velocity_std().map(Vec::from)),
    ("attitude_std", |s| s.attitude_std().map(Vec::from)),
    ("roll_pitch_yaw_std", |s| s.roll_pitch_yaw_std().map(Vec::from)),
    ("accel_bias_std", |s| s.accel_bias_std().map(Vec::from)),
    ("gyro_bias_std", |s| s.gyro_bias_std().map(Vec::from)),
    ("odometry_scale", |s| Some(vec![s.odometry_scale()?, s.odometry_scale_std()?])),
    ("baro_bias", |s| s.baro_bias().map(Vec::from)),
    ("pose_frame", |s| s.pose_frame().map(Vec::from)),
];

/// Asserts that `printed` (a JSON line per case of [`cases`]) has what the Rust
/// accessors give: the same missing ones, the values to 1e-12 relative.
pub fn assert_agree(printed: &str) {
    let lines: Vec<Value> = printed.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let cases = cases();
    assert_eq!(lines.len(), cases.len(), "{printed}");
    for (i, ((case, expected), line)) in cases.iter().zip(&lines).enumerate() {
        let mut compared = 0;
        for (name, accessor) in ACCESSORS {
            match (accessor(case), &line[name]) {
                (None, Value::Null) => {}
                (Some(rust), Value::Array(values)) => {
                    let other: Vec<f64> = values.iter().map(|v| v.as_f64().unwrap()).collect();
                    assert_eq!(other.len(), rust.len(), "case {i}: {name}");
                    for (a, b) in other.iter().zip(&rust) {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                            "case {i}: {name}: {other:?}, rust {rust:?}"
                        );
                    }
                    compared += 1;
                }
                (rust, v) => panic!("case {i}: {name}: printed {v}, rust {rust:?}"),
            }
        }
        // The refusals by reason name.
        let rust: serde_json::Map<String, Value> = case
            .rejection_counts()
            .map(|(code, n)| (fusion_shared::snapshot::rejection::name(code).to_string(), Value::from(n)))
            .collect();
        assert_eq!(line["rejections"], Value::Object(rust), "case {i}: rejections");
        match expected {
            Some(n) => assert_eq!(compared, *n, "case {i}: accessors with a value\n{printed}"),
            None => {
                let model = case.model().expect("a listed model");
                assert!(case.position().is_some() && case.position_std().is_some(), "{model}: no position");
                assert!(compared >= 2, "{model}: {compared} accessors with a value\n{printed}");
            }
        }
    }
}
