//! Live → record → replay over real iceoryx2: `fusionctl record` writes what a
//! running fusiond received and published to MCAP; `fusiond replay --input
//! RUN.mcap --compare` reproduces every live snapshot bit for bit, and says
//! where a replay differs. The recording opens with the `mcap` crate and with
//! the `mcap` Python package.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::recording;
use fusion_shared::{Sample, SampleKind};

/// The daemon's config, which the replay must be given too: simulated time
/// lies far behind the daemon's clock, and the replay judges timestamps
/// against the recorded receive times as fusiond did.
fn config(accel_noise_std: f64) -> String {
    let c = common::linear_config(Some(0.999))
        .replace("[100, 100, 100, 10, 10, 10]", "[100, 100, 100, 225, 225, 225]")
        .replace("accel_noise_std = 0.3", &format!("accel_noise_std = {accel_noise_std}"));
    format!("{c}\n{}", common::live::RECORDED_TIME)
}

/// 3 s at 200 Hz, fixes arriving 20–120 ms late, one in ten an outlier.
fn drive() -> Vec<Sample> {
    let mut c = ScenarioConfig { seed: 21, duration_s: 3.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.position.delay_min_ns = 20_000_000;
    c.position.delay_max_ns = 120_000_000;
    c.position.outlier_probability = 0.1;
    Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect()
}

/// Records a live run of `samples` and returns the recording's path.
fn record_live_run(domain: &TestDomain, dir: &Path, samples: &[Sample]) -> std::path::PathBuf {
    record_live_run_with(domain, dir, samples, &config(0.3), "event")
}

/// [`record_live_run`] of a fusiond run with `config`, waiting as `wait` says.
fn record_live_run_with(
    domain: &TestDomain,
    dir: &Path,
    samples: &[Sample],
    config: &str,
    wait: &str,
) -> std::path::PathBuf {
    let mut daemon = Daemon::start(domain, config, wait);
    let mcap = dir.join("run.mcap");
    let mut recorder = common::live::start_recorder(domain, &mcap, Stdio::piped());
    common::live::publish_file(domain, &dir.join("drive.jsonl"), samples);
    // Every sample processed live before the recorder is stopped.
    let mut reader = domain.client().state_subscriber().unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let received: u64 =
            reader.latest().unwrap().map_or(0, |s| s.sensor_counters().iter().map(|c| c.counts.processed).sum());
        if received == samples.len() as u64 {
            break;
        }
        assert!(Instant::now() < deadline, "fusiond processed {received} of {}", samples.len());
        std::thread::sleep(Duration::from_millis(10));
    }
    drop(reader);
    let pid = recorder.0.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let status = recorder.wait_for(Duration::from_secs(20)).expect("fusionctl record did not stop");
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut recorder.0.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(status.success(), "fusionctl record failed: {stderr}");
    assert!(stderr.contains(&format!("recorded {} samples (0 not processed by fusiond)", samples.len())), "{stderr}");
    assert!(!stderr.contains("incomplete"), "{stderr}");
    assert!(daemon.terminate().success());
    mcap
}

fn replay(dir: &Path, config: &str, mcap: &Path, extra: &[&str]) -> (bool, String) {
    let config_path = dir.join("replay.toml");
    std::fs::write(&config_path, config).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(&config_path)
        .arg("--input")
        .arg(mcap)
        .args(extra)
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// 2020-01-01 on the wall clock, ns since the Unix epoch.
const WALL_2020_NS: u64 = 1_577_836_800_000_000_000;

/// The `mcap` crate's view: every channel has a JSON Schema, and the sample
/// and snapshot channels hold what was recorded.
fn check_with_the_mcap_crate(mcap: &Path, samples: &[Sample]) {
    let bytes = std::fs::read(mcap).unwrap();
    let mut per_topic = std::collections::BTreeMap::<String, u64>::new();
    let (mut provisional, mut landed) = (0, 0);
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap_or_else(|| panic!("{} has no schema", m.channel.topic));
        assert_eq!(schema.encoding, recording::SCHEMA_ENCODING);
        assert_eq!(m.channel.message_encoding, recording::MESSAGE_ENCODING);
        serde_json::from_slice::<serde_json::Value>(&schema.data).unwrap();
        serde_json::from_slice::<serde_json::Value>(&m.data).unwrap();
        *per_topic.entry(m.channel.topic.clone()).or_default() += 1;
        // Log times are dates (wall clock), for Foxglove and PlotJuggler; the
        // times in fusiond's own messages stay its CLOCK_MONOTONIC.
        assert!(m.log_time > WALL_2020_NS, "{}: log time {}", m.channel.topic, m.log_time);
        if m.channel.topic == recording::POSE_TOPIC {
            let pose: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            assert!(pose["timestamp"]["sec"].as_u64().unwrap() > WALL_2020_NS / 1_000_000_000, "{pose}");
        }
        if m.channel.topic == recording::STATE_TOPIC {
            let s: recording::SnapshotJson = serde_json::from_slice(&m.data).unwrap();
            assert!(s.publish_ns < WALL_2020_NS && m.log_time - s.publish_ns > WALL_2020_NS);
            provisional += u64::from(s.has_input() && s.pending.is_some());
            landed += u64::from(!s.has_input() && s.pending.is_none() && s.background_steps > 0);
        }
    }
    // Each late fix's snapshot was provisional, and its correction landed later
    // in a snapshot of its own: the comparison covered both.
    let late = samples.iter().filter(|s| s.kind() == SampleKind::Position).count() as u64;
    assert!(provisional >= late / 2, "{provisional} provisional snapshots, {late} fixes");
    assert!(landed > 0, "no correction landed in a snapshot of its own");
    let of = |kind| samples.iter().filter(|s| s.kind() == kind).count() as u64;
    assert_eq!(per_topic[&recording::sample_topic(SampleKind::Imu)], of(SampleKind::Imu));
    assert_eq!(per_topic[&recording::sample_topic(SampleKind::Position)], of(SampleKind::Position));
    assert_eq!(per_topic[recording::POSE_TOPIC], samples.len() as u64);
    assert!(per_topic[recording::STATE_TOPIC] >= samples.len() as u64);
    // fusiond's configuration, as the recorder received it from fusiond.
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let index = summary.metadata_indexes.iter().find(|m| m.name == "fusion.config").expect("fusion.config metadata");
    let metadata = mcap::read::metadata(&bytes, index).unwrap();
    assert_eq!(metadata.metadata["toml"], config(0.3));
    assert_eq!(metadata.metadata["fusiond_version"], env!("CARGO_PKG_VERSION"));
    assert!(metadata.metadata["snapshot_wire"].starts_with("fusion.StateSnapshot.v"));
}

/// Another implementation, the `mcap` Python package, reads the summary,
/// every schema and every message.
fn check_with_python(mcap: &Path, samples: &[Sample]) {
    let script = r#"
import json, sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    summary = reader.get_summary()
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        assert schema.encoding == "jsonschema" and json.loads(schema.data), channel.topic
    counts = {}
    for schema, channel, message in reader.iter_messages():
        json.loads(message.data)
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
    print(json.dumps(counts))
"#;
    let out = Command::new(common::python_venv()).arg("-c").arg(script).arg(mcap).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let counts: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let imu = samples.iter().filter(|s| s.kind() == SampleKind::Imu).count();
    assert_eq!(counts[recording::sample_topic(SampleKind::Imu)], imu);
    assert_eq!(counts[recording::POSE_TOPIC], samples.len());
}

#[test]
fn a_recorded_live_run_replays_bit_for_bit_and_a_changed_one_says_where() {
    let domain = TestDomain::new("record-replay");
    let dir = tempfile::tempdir().unwrap();
    let samples = drive();
    let mcap = record_live_run(&domain, dir.path(), &samples);
    assert!(domain.files().is_empty(), "left in /dev/shm: {:?}", domain.files());

    let (ok, stderr) = replay(dir.path(), &config(0.3), &mcap, &["--compare", "--output", "/dev/null"]);
    assert!(ok, "{stderr}");
    assert!(stderr.contains(&format!("{} compared, all equal bit for bit", samples.len())), "{stderr}");
    // The stream had late fixes and gated outliers.
    let count = |what: &str| -> u64 {
        let at = stderr.find(&format!(" {what} ")).unwrap_or_else(|| panic!("no {what} in {stderr}"));
        stderr[at + what.len() + 2..].split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
    };
    assert!(count("gated") > 0 && count("late") > 0, "{stderr}");

    // Another process noise: the replay fails and names the first difference,
    // and warns first that the configuration is not the recorded one.
    let (ok, stderr) = replay(dir.path(), &config(0.5), &mcap, &["--compare"]);
    assert!(!ok, "{stderr}");
    assert!(stderr.contains("differ") && stderr.contains("P["), "{stderr}");
    // In the words of a recording, not of Rust's Debug.
    assert!(!stderr.contains("Json {") && !stderr.contains("Some("), "{stderr}");
    assert!(stderr.contains("differs from the configuration"), "{stderr}");

    // The recording carries fusiond's configuration: without --config the
    // replay uses it, bit for bit.
    let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--compare", "--input"])
        .arg(&mcap)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("recorded with (fusiond "), "{stderr}");
    assert!(stderr.contains(&format!("{} compared, all equal bit for bit", samples.len())), "{stderr}");
    // A JSON-lines file carries none: --config is needed, and said so.
    let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--input"])
        .arg(dir.path().join("drive.jsonl"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--config is needed"));

    check_with_the_mcap_crate(&mcap, &samples);
    check_with_python(&mcap, &samples);
    a_damaged_chunk_is_read_up_to(dir.path(), &mcap);

    // The report of the recording: the fixes as fusiond judged them, and the
    // latency of the live run.
    let report = dir.path().join("report");
    let plot = Command::new(workspace_bin("fusionctl"))
        .args(["plot", "--input"])
        .arg(&mcap)
        .arg("--output-dir")
        .arg(&report)
        .output()
        .unwrap();
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap()).unwrap();
    let points = &json["points"];
    let fixes = samples.iter().filter(|s| s.kind() == SampleKind::Position).count() as u64;
    let plotted = points["trajectory.fixes"].as_u64().unwrap() + points["trajectory.gated"].as_u64().unwrap();
    assert_eq!(plotted, fixes, "{points}");
    // A late fix is judged when its rewind is worked in, after its own
    // snapshot: its cross is drawn from the snapshot where its sensor's gated
    // count goes up, on that fix (not on the next one): every gated fix has its cross.
    let crosses = points["trajectory.gated"].as_u64().unwrap();
    // (A changed decision, below, can move one.)
    assert!(crosses.abs_diff(count("gated")) <= 1, "{points}\n{stderr}");
    // On the right fixes: those gated when the samples are fused in time
    // order (a replay of them sorted: the same estimates, as the rewinds are exact).
    let mut sorted = samples.clone();
    sorted.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    let text: String = sorted.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(dir.path().join("sorted.jsonl"), text).unwrap();
    let (lines, _) = common::run_replay(dir.path(), &config(0.3), &dir.path().join("sorted.jsonl"), false);
    let gated_seqs: Vec<u64> =
        lines.iter().filter(|l| l.kind == "position" && l.accepted == Some(false)).map(|l| l.seq).collect();
    assert_eq!(gated_seqs.len() as u64, count("gated"));
    let mut expected: Vec<[f64; 2]> = sorted
        .iter()
        .filter_map(|s| match s {
            Sample::Position(p) if gated_seqs.contains(&p.header.seq) => Some([p.pos_m[0], p.pos_m[1]]),
            _ => None,
        })
        .collect();
    let mut drawn: Vec<[f64; 2]> = serde_json::from_value(json["gated_fixes"].clone()).unwrap();
    expected.sort_by(|a, b| a.partial_cmp(b).unwrap());
    drawn.sort_by(|a, b| a.partial_cmp(b).unwrap());
    // A rewind that changes the decision on a fix it re-steps leaves that fix's
    // cross where its first decision put it (the counters cannot say which fix
    // changed): at most one such here. The crosses drawn one fix late were
    // wrong for 3 of the 5 gated fixes of this drive.
    let misplaced = drawn.iter().filter(|d| !expected.contains(d)).count();
    assert!(misplaced <= 1, "crosses off the gated fixes: {drawn:?}, gated {expected:?}");
    assert!(points["latency.samples"].as_u64().unwrap() > 0, "{points}");
    assert!(report.join("latency.png").exists());
}

/// Two IMUs averaged, with late fixes: live, an IMU sample that leaves its
/// instant open publishes nothing, and the replay still equals every live
/// snapshot bit for bit, counting the samples that had none of their own.
/// (`fusion-sim run --input` publishes an instant's IMU samples together and
/// waits for the instant's snapshot.)
#[test]
fn a_live_run_with_averaged_imus_replays_bit_for_bit() {
    let domain = TestDomain::new("record-instants");
    let dir = tempfile::tempdir().unwrap();
    let mut c = ScenarioConfig { seed: 5, duration_s: 3.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.extra_imus.push(fusion_client::sim::ImuConfig { sensor: 7, ..c.imu.clone() });
    c.position.delay_min_ns = 20_000_000;
    c.position.delay_max_ns = 120_000_000;
    let samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let imus = samples.iter().filter(|s| s.kind() == SampleKind::Imu).count();
    let config = format!(
        "{}\n[[sensor]]\nname = \"imu-a\"\nid = 0\nkinds = [\"imu\"]\n[[sensor]]\nname = \"imu-b\"\nid = 7\n\
         kinds = [\"imu\"]\n[imu]\ncombine = \"average\"\n",
        config(0.3)
    );
    // Spin: the daemon never sleeps between an instant's samples (in event
    // mode an instant's snapshot also goes out when it would).
    let mcap = record_live_run_with(&domain, dir.path(), &samples, &config, "spin");
    assert!(domain.files().is_empty(), "left in /dev/shm: {:?}", domain.files());
    let (ok, stderr) = replay(dir.path(), &config, &mcap, &["--compare", "--output", "/dev/null"]);
    assert!(ok, "{stderr}");
    // About one IMU sample an instant had no snapshot of its own.
    let held: usize = stderr
        .split("compared, all equal bit for bit (x, P, NIS, counters); ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(held > imus / 2 - 20 && held <= imus / 2, "{held} of {imus} IMU samples: {stderr}");
    assert!(stderr.contains(&format!("{} compared", samples.len() - held)), "{stderr}");
}

/// 16 bytes of 0xff over a chunk's header (its sizes and compression name, or
/// its record length) of a recording with a summary: `fusiond replay`,
/// `replay --compare` and `fusionctl plot` read the recording up to the
/// damaged chunk and say where it is, never believing the sizes it declares
/// (an allocation of exabytes aborted them). (`recording_cut.rs` replays the
/// samples before a damaged chunk.)
fn a_damaged_chunk_is_read_up_to(dir: &Path, mcap: &Path) {
    let clean = std::fs::read(mcap).unwrap();
    let summary = mcap::Summary::read(&clean).unwrap().unwrap();
    let mut chunks: Vec<u64> = summary.chunk_indexes.iter().map(|c| c.chunk_start_offset).collect();
    chunks.sort();
    assert!(chunks.len() >= 3, "{} chunks", chunks.len());
    let at = chunks[chunks.len() / 2] as usize;
    for (i, over) in [at + 9 + 16, at + 1].into_iter().enumerate() {
        let mut bytes = clean.clone();
        bytes[over..over + 16].fill(0xff);
        let damaged = dir.join(format!("damaged-{i}.mcap"));
        std::fs::write(&damaged, &bytes).unwrap();
        let said = format!("is damaged at byte {at}");
        for extra in [&["--output", "/dev/null"][..], &["--compare"]] {
            let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
                .args(["replay", "--input"])
                .arg(&damaged)
                .args(extra)
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            // Replayed up to the damage, the exit status saying so (4), or a
            // clear error when no sample comes before the damage (this
            // recording's samples share a chunk); never a signal.
            assert!(out.status.code().is_some_and(|c| c == 4 || c == 1), "{extra:?}: {:?}\n{stderr}", out.status);
            assert!(stderr.contains(&said), "{extra:?}: {stderr}");
        }
        let plot = Command::new(workspace_bin("fusionctl"))
            .args(["plot", "--input"])
            .arg(&damaged)
            .arg("--output-dir")
            .arg(dir.join(format!("damaged-report-{i}")))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&plot.stderr);
        assert_eq!(plot.status.code(), Some(4), "{stderr}");
        assert!(stderr.contains(&said) && stderr.contains("bytes after it are not read"), "{stderr}");
    }
}

/// A recording started while fusiond already ran (its first samples not in
/// it): the comparison cannot be equal, and it says why, naming where the
/// recording began, instead of listing every snapshot as a difference.
#[test]
fn a_recording_begun_mid_run_says_so_when_compared() {
    let domain = TestDomain::new("record-midrun");
    let dir = tempfile::tempdir().unwrap();
    let samples = drive();
    let (before, after) = samples.split_at(samples.len() / 3);
    let config = config(0.3);
    let mut daemon = Daemon::start(&domain, &config, "event");
    common::live::publish_file(&domain, &dir.path().join("before.jsonl"), before);
    let mcap = dir.path().join("late.mcap");
    let mut recorder = common::live::start_recorder(&domain, &mcap, Stdio::null());
    common::live::publish_file(&domain, &dir.path().join("after.jsonl"), after);
    assert!(Command::new("kill").args(["-INT", &recorder.0.id().to_string()]).status().unwrap().success());
    assert!(recorder.wait_for(Duration::from_secs(20)).is_some_and(|s| s.success()));
    assert!(daemon.terminate().success());
    let (ok, stderr) = replay(dir.path(), &config, &mcap, &["--compare"]);
    assert!(!ok, "{stderr}");
    assert!(stderr.contains("the recording began at snapshot") && stderr.contains("a run already going"), "{stderr}");
    assert!(stderr.contains(&format!("fusiond had taken {} samples", before.len())), "{stderr}");
}
