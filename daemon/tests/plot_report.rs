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

    // Without the samples there are no fixes: the legend does not list them,
    // and it marks where the drive starts and ends.
    let bare = dir.path().join("bare");
    let plot = Command::new(workspace_bin("fusionctl"))
        .args(["plot", "--input"])
        .arg(&estimates)
        .arg("--output-dir")
        .arg(&bare)
        .output()
        .unwrap();
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));
    // The SVG's texts, one a line between their tags.
    let texts = |path: &std::path::Path| -> Vec<String> {
        let svg = std::fs::read_to_string(path).unwrap();
        svg.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('<')).map(String::from).collect()
    };
    let said = texts(&bare.join("trajectory.svg"));
    assert!(!said.iter().any(|t| t.contains("fix")), "fixes in the legend: {said:?}");
    assert!(said.contains(&"start".into()) && said.contains(&"end".into()), "no start and end: {said:?}");
    assert!(!said.iter().any(|t| t == "-0" || t == "-0.0"), "a tick reads -0: {said:?}");
    assert!(texts(&report.join("trajectory.svg")).contains(&"fix".into()), "the fixes drawn are in the legend");

    // Another run's truth (stamped 1000 s later): no error panels of nothing,
    // but an error that says the times do not meet.
    let other = dir.path().join("other.truth.jsonl");
    let shifted: String = std::fs::read_to_string(examples().join("drive.truth.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["t_ns"] = (v["t_ns"].as_u64().unwrap() + 1_000_000_000_000).into();
            v.to_string() + "\n"
        })
        .collect();
    std::fs::write(&other, shifted).unwrap();
    let mismatched = Command::new(workspace_bin("fusionctl"))
        .args(["plot", "--input"])
        .arg(&estimates)
        .arg("--truth")
        .arg(&other)
        .arg("--output-dir")
        .arg(dir.path().join("other"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&mismatched.stderr);
    assert_eq!(mismatched.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("no estimate falls within it") && stderr.contains("this run's truth"), "{stderr}");

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

    // For people: time since the start (the start in each page's title), a
    // metre as long east as north, a legend for the ±3σ lines, units on the axes.
    let t0 = lines[0].t_ns as f64 * 1e-9;
    assert_eq!(json["t0_s"].as_f64().unwrap(), t0);
    assert_eq!(json["smoothed"], false);
    let scales = &json["scales"];
    let (east, north) =
        (scales["trajectory.east_m_per_px"].as_f64().unwrap(), scales["trajectory.north_m_per_px"].as_f64().unwrap());
    assert!((east / north - 1.0).abs() < 1e-9, "{scales}");
    let page = |name: &str| std::fs::read_to_string(report.join(format!("{name}.svg"))).unwrap();
    for name in ["trajectory", "errors", "nis"] {
        assert!(page(name).contains(&format!("t = 0 at {t0:.3} s of CLOCK_MONOTONIC")), "{name}");
    }
    let errors = page("errors");
    assert_eq!(errors.matches("t since start, s").count(), 6);
    assert_eq!(errors.matches("±3σ").count(), 6, "a legend entry per panel");
    assert_eq!(errors.lines().filter(|l| l.trim() == "m/s").count(), 3, "the velocity panels' unit");
    assert!(!errors.contains("no truth"));
    // NIS: the scale is the fused values' (a gated outlier does not squash them),
    // and the outlier is marked on its edge.
    let nis = page("nis");
    assert!(nis.contains("NIS (no unit)") && nis.contains("gated, beyond the scale (1)"), "the outlier is marked");
    let outlier = lines.iter().filter(|l| l.accepted == Some(false)).filter_map(|l| l.nis).fold(0.0, f64::max);
    let top = scales["nis.position 1.top"].as_f64().unwrap();
    assert!(top < outlier && top < 20.0, "scale {top}, outlier {outlier}");
}

/// An `ins` run: the attitude and bias page, fixes named as the antenna's;
/// smoothed and without truth, the pages say so; with truth, the attitude errors.
#[test]
fn an_ins_run_gets_its_attitude_page_and_says_what_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let drive = dir.path().join("drive.jsonl");
    let truth = dir.path().join("truth.jsonl");
    let sim = Command::new(workspace_bin("fusion-sim"))
        .args(["record", "--imu-output", "body", "--duration", "10", "--imu-rate", "100", "--seed", "4", "--output"])
        .arg(&drive)
        .arg("--truth")
        .arg(&truth)
        .output()
        .unwrap();
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
    // The golden ins config, started at the truth.
    let first: serde_json::Value =
        serde_json::from_str(std::fs::read_to_string(&truth).unwrap().lines().next().unwrap()).unwrap();
    let v: Vec<f64> = first["vel"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let q: Vec<f64> = first["q_wxyz"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let golden = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/ins.toml")).unwrap();
    let config: String = golden
        .lines()
        .map(|l| {
            if l.starts_with("initial_state") {
                format!(
                    "initial_state = [0, 0, 0, {}, {}, {}, {}, {}, {}, {}, 0, 0, 0, 0, 0, 0]",
                    v[0], v[1], v[2], q[0], q[1], q[2], q[3]
                )
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let config_path = dir.path().join("ins.toml");
    std::fs::write(&config_path, config).unwrap();
    let replay = |smooth: bool| {
        let out = dir.path().join(if smooth { "smoothed.jsonl" } else { "filtered.jsonl" });
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_fusiond"));
        cmd.args(["replay", "--config"]).arg(&config_path).arg("--input").arg(&drive).arg("--output").arg(&out);
        if smooth {
            cmd.arg("--smooth");
        }
        let r = cmd.output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        out
    };
    let plot = |input: &Path, with_truth: bool, to: &str| {
        let report = dir.path().join(to);
        let mut cmd = Command::new(workspace_bin("fusionctl"));
        cmd.args(["plot", "--input"]).arg(input).arg("--samples").arg(&drive).arg("--output-dir").arg(&report);
        if with_truth {
            cmd.arg("--truth").arg(&truth);
        }
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        report
    };

    let smoothed = plot(&replay(true), false, "smoothed");
    let page = |report: &Path, name: &str| std::fs::read_to_string(report.join(format!("{name}.svg"))).unwrap();
    let attitude = page(&smoothed, "attitude");
    for needle in ["±3σ attitude about body z (yaw)", "gyro bias z", "deg/h", "m/s²", "RTS-smoothed estimates"] {
        assert!(attitude.contains(needle), "{needle}");
    }
    assert!(page(&smoothed, "trajectory").contains("fix (antenna, as measured)"));
    assert!(page(&smoothed, "errors").contains("no truth was given"));
    assert!(page(&smoothed, "errors").contains("RTS-smoothed estimates"));

    let filtered = plot(&replay(false), true, "filtered");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(filtered.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["smoothed"], false);
    let points = &json["points"];
    for axis in 0..3 {
        assert!(points[format!("attitude.{axis}.error")].as_u64().unwrap() > 500, "{points}");
    }
    assert!(page(&filtered, "attitude").contains("attitude error about body z (yaw)"));
    assert!(!page(&filtered, "attitude").contains("RTS-smoothed"));
}

/// A replay of geodetic fixes plotted with `--samples`: the fixes are drawn
/// (about the first one, fusiond's datum without a `[datum]` table), and the
/// NIS panels leave room for their legend; files of the wrong kind are named
/// for what they are.
#[test]
fn geodetic_fixes_are_drawn_and_wrong_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let drive = dir.path().join("drive.jsonl");
    let sim = Command::new(workspace_bin("fusion-sim"))
        .args(["record", "--duration", "5", "--imu-rate", "100", "--position-rate", "0", "--geodetic-rate", "5"])
        .args(["--seed", "2", "--output"])
        .arg(&drive)
        .output()
        .unwrap();
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
    let geodetic = std::fs::read_to_string(&drive).unwrap().lines().filter(|l| l.starts_with(r#"{"geodetic""#)).count();
    assert!(geodetic >= 20, "{geodetic} geodetic fixes");
    let estimates = dir.path().join("estimates.jsonl");
    let replay = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(examples().join("linear.toml"))
        .arg("--input")
        .arg(&drive)
        .arg("--output")
        .arg(&estimates)
        .output()
        .unwrap();
    assert!(replay.status.success(), "{}", String::from_utf8_lossy(&replay.stderr));
    let plot = |input: &Path, samples: &Path| {
        Command::new(workspace_bin("fusionctl"))
            .args(["plot", "--input"])
            .arg(input)
            .arg("--samples")
            .arg(samples)
            .arg("--output-dir")
            .arg(dir.path().join("report"))
            .output()
            .unwrap()
    };
    let out = plot(&estimates, &drive);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("placed about the first one"), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report/report.json")).unwrap()).unwrap();
    let points = &json["points"];
    let drawn = points["trajectory.fixes"].as_u64().unwrap() + points["trajectory.gated"].as_u64().unwrap();
    assert_eq!(drawn as usize, geodetic, "{points}");
    // The legend's room: the time axis runs well past the last value.
    let last_nis_t = std::fs::read_to_string(&estimates)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<fusion_daemon::replay::OutputLine>(l).unwrap())
        .map(|l| l.t_ns)
        .collect::<Vec<_>>();
    let span = (last_nis_t.last().unwrap() - last_nis_t[0]) as f64 * 1e-9;
    assert!(json["scales"]["nis.t_end"].as_f64().unwrap() >= 1.4 * span, "{}", json["scales"]);

    // Files of the wrong kind.
    let garbage = dir.path().join("garbage.mcap");
    std::fs::write(&garbage, [0xffu8, 0xfe, 0x00, 0x9c, 0x12, 0x80, 0x81, 0x82, 0x83]).unwrap();
    let binary = dir.path().join("binary.jsonl");
    std::fs::write(&binary, [0xffu8, 0xfe, 0x00, 0x9c, 0x12, 0x80, 0x81, 0x82, 0x83]).unwrap();
    let mcap = dir.path().join("recording.mcap");
    std::fs::write(&mcap, [&b"\x89MCAP0\r\n"[..], &[0u8; 32]].concat()).unwrap();
    for (input, samples, expected) in [
        (&garbage, &drive, "named .mcap but not an MCAP file"),
        (&binary, &drive, "not a text file"),
        (&estimates, &mcap, "give it as --input"),
        (&estimates, &binary, "not a text file (expected --samples"),
    ] {
        let out = plot(input, samples);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(expected), "{expected}: {stderr}");
        assert!(!stderr.contains("valid UTF-8"), "{stderr}");
    }
}
