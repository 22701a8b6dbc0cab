//! `[filter] form = "udu"` against the Joseph form: the real `fusiond replay` of
//! the same drives in both forms agrees to 1e-9 relative on x and P after every
//! sample, filtered and smoothed, with the same decisions (late fixes fused by
//! rewind, outliers gated).

mod common;

use std::path::Path;

use fusion_daemon::replay::OutputLine;

/// The config with `[filter] form = "udu"`.
fn udu(config: &str) -> String {
    assert!(config.contains("[filter]\n"));
    config.replacen("[filter]\n", "[filter]\nform = \"udu\"\n", 1)
}

/// Largest difference, relative to the largest entry of `want`.
fn rel(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(0f64, |m, v| m.max(v.abs()));
    got.iter().zip(want).fold(0f64, |m, (g, w)| m.max((g - w).abs())) / scale.max(f64::MIN_POSITIVE)
}

/// Runs both forms and compares them line by line; returns the worst relative
/// differences of x and P.
fn compare_forms(dir: &Path, config: &str, input: &Path, smooth: bool) -> (f64, f64, Vec<OutputLine>) {
    let (joseph, _) = common::run_replay(dir, config, input, smooth);
    let (factored, stderr) = common::run_replay(dir, &udu(config), input, smooth);
    assert!(stderr.contains("form udu"), "the run says its form: {stderr}");
    assert_eq!(joseph.len(), factored.len());
    let (mut worst_x, mut worst_p) = (0f64, 0f64);
    for (i, (j, u)) in joseph.iter().zip(&factored).enumerate() {
        assert_eq!((j.t_ns, &j.kind, j.sensor, j.seq, j.accepted), (u.t_ns, &u.kind, u.sensor, u.seq, u.accepted));
        let (dx, dp) = (rel(&u.x, &j.x), rel(&u.p, &j.p));
        assert!(dx <= 1e-9 && dp <= 1e-9, "line {i} ({} at {}): x differs by {dx:e}, P by {dp:e}", j.kind, j.t_ns);
        if let (Some(a), Some(b)) = (j.nis, u.nis) {
            assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "line {i}: NIS {a} against {b}");
        }
        (worst_x, worst_p) = (worst_x.max(dx), worst_p.max(dp));
    }
    (worst_x, worst_p, joseph)
}

#[test]
fn linear_reference_drive_udu_equals_joseph_filtered_and_smoothed() {
    let dir = tempfile::tempdir().unwrap();
    // The reference drive: 20 s, 200 Hz IMU with jitter, fixes 20–120 ms late, 8 % outliers.
    let scenario = common::acceptance_scenario(6, 0.08);
    let input = dir.path().join("drive.jsonl");
    common::write_input(&input, &scenario);
    let config = common::linear_config(Some(0.999));
    let (fx, fp, lines) = compare_forms(dir.path(), &config, &input, false);
    let gated = lines.iter().filter(|l| l.accepted == Some(false)).count();
    assert!(gated >= 8, "outliers gated in both forms: {gated}");
    let (sx, sp, _) = compare_forms(dir.path(), &config, &input, true);
    eprintln!("linear: filtered x {fx:.2e}, P {fp:.2e}; smoothed x {sx:.2e}, P {sp:.2e}");
}

#[test]
fn ins_drive_udu_equals_joseph_filtered_and_smoothed() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = std::fs::read_to_string(root.join("tests/golden/ins.toml")).unwrap();
    let input = root.join("tests/golden/ins_drive.jsonl");
    let (fx, fp, lines) = compare_forms(dir.path(), &config, &input, false);
    assert!(lines.iter().any(|l| l.accepted == Some(false)), "the drive's outliers are gated");
    assert!(lines.iter().filter(|l| l.accepted == Some(true)).count() >= 20);
    let (sx, sp, _) = compare_forms(dir.path(), &config, &input, true);
    eprintln!("ins: filtered x {fx:.2e}, P {fp:.2e}; smoothed x {sx:.2e}, P {sp:.2e}");
}

#[test]
fn an_unknown_form_is_refused_with_the_choices() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, common::linear_config(None).replacen("[filter]\n", "[filter]\nform = \"qr\"\n", 1)).unwrap();
    let out =
        std::process::Command::new(env!("CARGO_BIN_EXE_fusiond")).arg("check-config").arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("qr") && stderr.contains("joseph") && stderr.contains("udu"), "{stderr}");
}
