//! `fusionctl plot` on the example drive: the replay output, its input and its
//! truth give a report with every file, and the points plotted are the drive's.

mod common;

use std::path::Path;
use std::process::Command;

use common::live::workspace_bin;

fn examples() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}

#[test]
fn the_example_drive_gives_a_report_with_its_points() {
    let dir = tempfile::tempdir().unwrap();
    let estimates = dir.path().join("estimates.jsonl");
    let replay = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(examples().join("linear.toml"))
        .arg("--input")
        .arg(examples().join("drive.jsonl"))
        .arg("--output")
        .arg(&estimates)
        .output()
        .unwrap();
    assert!(replay.status.success(), "{}", String::from_utf8_lossy(&replay.stderr));
    let report = dir.path().join("report");
    let plot = Command::new(workspace_bin("fusionctl"))
        .args(["plot", "--input"])
        .arg(&estimates)
        .arg("--samples")
        .arg(examples().join("drive.jsonl"))
        .arg("--truth")
        .arg(examples().join("drive.truth.jsonl"))
        .arg("--output-dir")
        .arg(&report)
        .output()
        .unwrap();
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));

    for page in ["trajectory", "errors", "nis"] {
        for ext in ["svg", "png"] {
            let f = report.join(format!("{page}.{ext}"));
            assert!(std::fs::metadata(&f).is_ok_and(|m| m.len() > 10_000), "{} missing or empty", f.display());
        }
    }
    let png = std::fs::read(report.join("trajectory.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");

    // What the drive holds, and what the report says it plotted.
    let input = std::fs::read_to_string(examples().join("drive.jsonl")).unwrap();
    let fixes = input.lines().filter(|l| l.starts_with(r#"{"position""#)).count();
    let lines: Vec<fusion_daemon::replay::OutputLine> =
        std::fs::read_to_string(&estimates).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let gated = lines.iter().filter(|l| l.accepted == Some(false)).count();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap()).unwrap();
    let points = &json["points"];
    assert_eq!(points["trajectory.fixes"].as_u64().unwrap() as usize + gated, fixes, "{points}");
    assert_eq!(points["trajectory.gated"].as_u64().unwrap() as usize, gated, "{points}");
    assert_eq!(points["trajectory.estimate"].as_u64().unwrap() as usize, lines.len(), "{points}");
    assert!(points["trajectory.truth"].as_u64().unwrap() > 100, "{points}");
    assert_eq!(points["nis.position 1"].as_u64().unwrap() as usize, fixes, "{points}");
    for k in 0..6 {
        assert_eq!(points[format!("errors.{k}.error")].as_u64().unwrap() as usize, lines.len(), "{points}");
    }
    // The SVG holds one circle per fused fix plus the legend's.
    let svg = std::fs::read_to_string(report.join("trajectory.svg")).unwrap();
    assert_eq!(svg.matches("<circle").count(), fixes - gated + 1);
}
