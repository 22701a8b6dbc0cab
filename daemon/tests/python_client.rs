//! The Python client (`client/python`, on iceoryx2's own Python package) against
//! the Rust types and a live fusiond: its ctypes mirrors have the layout and
//! type names of the wire types; it reads the snapshots `fusionctl echo` reads,
//! bit for bit, and its typed accessors give what the Rust ones give; fusiond
//! fuses what it publishes, and it refuses bad samples.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use common::live::{Daemon, Running, TestDomain, publish_in_lockstep, wait_for_state_readers, workspace_bin};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::sample::layout::WireLayout;
use fusion_shared::snapshot::{Counters, SensorCounters};
use fusion_shared::{SampleHeader, SampleKind, StateSnapshot};
use iceoryx2::prelude::ZeroCopySend;
use serde_json::{Value, json};

/// The layout of a wire type as the Python check reads it: its iceoryx2 type
/// name, size, alignment, and every field (name, offset, size), as the type
/// declares them beside it (`fusion_shared::sample::layout`, which checks that
/// they fill it exactly).
fn layout<T: WireLayout + ZeroCopySend>() -> (&'static str, Value) {
    T::check().unwrap();
    // SAFETY: only reads the name the type declares.
    let type_name = unsafe { <T as ZeroCopySend>::type_name() };
    let fields: Vec<Value> = T::fields().iter().map(|f| json!([f.name, f.offset, f.size])).collect();
    let rust = std::any::type_name::<T>().rsplit("::").next().unwrap();
    (rust, json!({ "type_name": type_name, "size": size_of::<T>(), "align": align_of::<T>(), "fields": fields }))
}

fn rust_layout() -> Value {
    struct Kinds(Vec<(&'static str, Value)>);
    impl fusion_shared::KindVisitor for Kinds {
        fn visit<T: fusion_shared::WireSample>(&mut self) {
            self.0.push(layout::<T>());
        }
    }
    let mut kinds = Kinds(vec![layout::<SampleHeader>()]);
    SampleKind::visit_all(&mut kinds);
    let mut types = kinds.0;
    types.extend([layout::<Counters>(), layout::<SensorCounters>(), layout::<StateSnapshot>()]);
    assert_eq!(types.len(), 4 + SampleKind::COUNT, "a new kind needs its layout here and a Python mirror");
    use fusion_shared::service as s;
    use fusion_shared::snapshot as snap;
    let mut constants = json!({
        "SAMPLE_BUFFER": s::SAMPLE_BUFFER,
        "MAX_SAMPLE_PUBLISHERS": s::MAX_SAMPLE_PUBLISHERS,
        "MAX_BORROWED_PER_PUBLISHER": s::MAX_BORROWED_PER_PUBLISHER,
        "MAX_SAMPLE_SUBSCRIBERS": s::MAX_SAMPLE_SUBSCRIBERS,
        "STATE_BUFFER": s::STATE_BUFFER,
        "MAX_NODES": s::MAX_NODES,
        "MAX_EVENT_PORTS": s::MAX_EVENT_PORTS,
        "READER_REFUSED_EVENT": s::READER_REFUSED_EVENT,
        "MAX_NAMESPACE_LEN": s::MAX_NAMESPACE_LEN,
        "MAX_STATE": snap::MAX_STATE,
        "MAX_COV": snap::MAX_COV,
        "MAX_SENSORS": snap::MAX_SENSORS,
        "INPUT_NONE": snap::INPUT_NONE,
        "MAX_REJECTIONS": snap::rejection::MAX,
    });
    for &kind in SampleKind::ALL {
        constants[format!("KIND_{}", kind.name().to_uppercase())] = json!(kind as u32);
    }
    constants["KIND_COUNT"] = json!(SampleKind::COUNT);
    // The code -> name tables of kinds and models, whole.
    let kinds: serde_json::Map<_, _> =
        SampleKind::ALL.iter().map(|&k| ((k as u32).to_string(), json!(k.name()))).collect();
    constants["KIND_NAMES"] = Value::Object(kinds);
    let models: serde_json::Map<_, _> =
        fusion_shared::snapshot::Model::ALL.iter().map(|m| (m.code().to_string(), json!(m.name()))).collect();
    constants["MODEL_NAMES"] = Value::Object(models);
    let dims: serde_json::Map<_, _> = fusion_shared::snapshot::Model::ALL
        .iter()
        .map(|m| (m.code().to_string(), json!([m.state_len(), m.cov_dim()])))
        .collect();
    constants["MODEL_DIMS"] = Value::Object(dims);
    let aux: serde_json::Map<_, _> =
        fusion_shared::snapshot::aux::ALL.iter().map(|(bit, name)| (bit.to_string(), json!(name))).collect();
    constants["AUX_NAMES"] = Value::Object(aux);
    constants["AUX_ODOMETRY_SCALE"] = json!(fusion_shared::snapshot::aux::ODOMETRY_SCALE);
    constants["AUX_BARO_BIAS"] = json!(fusion_shared::snapshot::aux::BARO_BIAS);
    constants["AUX_POSE_FRAME"] = json!(fusion_shared::snapshot::aux::POSE_FRAME);
    let fixes: serde_json::Map<_, _> =
        fusion_shared::fix::NAMES.iter().enumerate().map(|(code, name)| (code.to_string(), json!(name))).collect();
    constants["FIX_NAMES"] = Value::Object(fixes);
    let rejections: serde_json::Map<_, _> =
        snap::rejection::ALL.iter().map(|(code, name)| (code.to_string(), json!(name))).collect();
    constants["REJECTION_NAMES"] = Value::Object(rejections);
    for (name, code) in [
        ("REJECTION_NON_FINITE", snap::rejection::NON_FINITE),
        ("REJECTION_COVARIANCE_NOT_SYMMETRIC", snap::rejection::COVARIANCE_NOT_SYMMETRIC),
        ("REJECTION_COVARIANCE_NOT_POSITIVE_DEFINITE", snap::rejection::COVARIANCE_NOT_POSITIVE_DEFINITE),
        ("REJECTION_FUTURE_TIMESTAMP", snap::rejection::FUTURE_TIMESTAMP),
        ("REJECTION_PAST_TIMESTAMP", snap::rejection::PAST_TIMESTAMP),
        ("REJECTION_TIME_JUMP", snap::rejection::TIME_JUMP),
        ("REJECTION_TOO_MANY_SENSORS", snap::rejection::TOO_MANY_SENSORS),
        ("REJECTION_OUT_OF_RANGE", snap::rejection::OUT_OF_RANGE),
        ("REJECTION_VARIANCE_NOT_POSITIVE", snap::rejection::VARIANCE_NOT_POSITIVE),
        ("REJECTION_WRONG_KIND", snap::rejection::WRONG_KIND),
        ("REJECTION_TIME_STEP_BACK", snap::rejection::TIME_STEP_BACK),
    ] {
        constants[name] = json!(code);
    }
    assert_eq!(snap::rejection::ALL.len(), 11, "a new rejection code needs its REJECTION_ constant here");
    use fusion_shared::fix;
    for (name, code) in [
        ("FIX_UNKNOWN", fix::UNKNOWN),
        ("FIX_NONE", fix::NONE),
        ("FIX_2D", fix::TWO_D),
        ("FIX_3D", fix::THREE_D),
        ("FIX_DGNSS", fix::DGNSS),
        ("FIX_RTK_FLOAT", fix::RTK_FLOAT),
        ("FIX_RTK_FIXED", fix::RTK_FIXED),
    ] {
        constants[name] = json!(code);
    }
    json!({ "types": types.into_iter().map(|(n, l)| (n.to_string(), l)).collect::<serde_json::Map<_, _>>(), "constants": constants })
}

#[test]
fn the_python_mirrors_have_the_rust_layout() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("layout.json");
    std::fs::write(&path, rust_layout().to_string()).unwrap();
    let out = common::python_command("unused", "tests/check_layout.py", &[path.to_str().unwrap()]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("15 types, 53 constants: 0 differences"), "{said}");

    // The check sees a difference: a layout with one offset moved fails it.
    let mut broken = rust_layout();
    broken["types"]["ImuSample"]["fields"][2][1] = json!(57);
    broken["types"]["StateSnapshot"]["type_name"] = json!("fusion.StateSnapshot.v5");
    std::fs::write(&path, broken.to_string()).unwrap();
    let out = common::python_command("unused", "tests/check_layout.py", &[path.to_str().unwrap()]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(!out.status.success() && said.contains("2 differences"), "{said}");
}

fn drive() -> Vec<fusion_shared::Sample> {
    let mut c = ScenarioConfig { seed: 21, duration_s: 1.0, ..Default::default() };
    c.imu.rate_hz = 100.0;
    c.position.delay_min_ns = 20_000_000;
    c.position.delay_max_ns = 60_000_000;
    Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect()
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// IMU samples that continue `samples` in time (10 ms apart, after its last
/// sample): in order, so they bring no correction of their own.
fn continuation(samples: &[fusion_shared::Sample], n: usize) -> Vec<fusion_shared::Sample> {
    let last = *samples.iter().rev().find(|s| s.kind() == SampleKind::Imu).expect("an IMU sample");
    let end = samples.iter().map(|s| s.header().t_ns).max().unwrap();
    (1..=n as u64)
        .map(|i| {
            let mut s = last;
            let h = s.header_mut();
            h.t_ns = end + i * 10_000_000;
            h.seq += i;
            s
        })
        .collect()
}

#[test]
fn python_reads_the_snapshots_fusionctl_echo_reads() {
    let domain = TestDomain::new("py-echo");
    let _daemon = Daemon::start(&domain, &common::linear_config(Some(0.999)), "event");
    let samples = drive();
    // The drive's late fixes land when the daemon gets to them, each with a
    // snapshot of its own: at most one per sample. The readers take this many
    // snapshots; after the drive has settled, IMU samples fill the count up,
    // so the last snapshot both read is settled and holds every fix.
    let count = 2 * samples.len() + 1;
    let fusionctl = workspace_bin("fusionctl");

    let mut python = Running(
        common::python_command(&domain.domain, "tests/echo.py", &[&domain.namespace, &count.to_string()])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut python_out = BufReader::new(python.0.stdout.take().unwrap());
    let mut ready = String::new();
    python_out.read_line(&mut ready).unwrap();
    assert_eq!(ready, "ready\n", "the Python reader did not start");
    let mut echo = Running(
        Command::new(fusionctl)
            .args(["echo", "--namespace", &domain.namespace, "--count", &count.to_string(), "--idle-timeout", "20"])
            .env(fusion_shared::service::DOMAIN_ENV, &domain.domain)
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let echo_out = echo.0.stdout.take().unwrap();
    // Publish only once both readers have subscribed.
    wait_for_state_readers(&domain, 2, "fusionctl echo");

    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(16).unwrap();
    let mut last = *publish_in_lockstep(&client, &mut reader, &samples).last().unwrap();
    while !last.settled() {
        last = *reader.wait_next(Duration::from_secs(10)).unwrap().expect("the settled snapshot of the drive");
    }
    assert!((last.seq as usize) < count - 1, "{} snapshots for {} samples", last.seq + 1, samples.len());
    // Health-only snapshots (a stream goes stale) come when the wall clock says,
    // so the continuation goes one sample at a time until the count is reached.
    let mut publishers = fusion_client::SensorPublishers::all(&client).unwrap();
    for s in continuation(&samples, count) {
        if last.seq as usize + 1 >= count {
            break;
        }
        publishers.publish(s).unwrap().expect("an IMU publisher");
        last = common::live::snapshot_of(&mut reader, &s);
    }

    let python_lines: Vec<Value> = python_out.lines().map(|l| serde_json::from_str(&l.unwrap()).unwrap()).collect();
    let echo_lines: Vec<Value> =
        BufReader::new(echo_out).lines().map(|l| serde_json::from_str(&l.unwrap()).unwrap()).collect();
    assert!(python.wait_for(Duration::from_secs(20)).is_some_and(|s| s.success()));
    assert!(echo.wait_for(Duration::from_secs(20)).is_some_and(|s| s.success()));
    assert_eq!(python_lines.len(), count);
    assert_eq!(echo_lines.len(), count);

    let mut fused = 0;
    for (i, (py, rs)) in python_lines.iter().zip(&echo_lines).enumerate() {
        for key in
            ["snapshot_seq", "t_ns", "kind", "seq", "model", "health", "health_reasons", "pending", "background_steps"]
        {
            assert_eq!(py[key], rs[key], "snapshot {i}: {key}");
        }
        // Every double, bit for bit (both print the shortest exact decimal).
        assert_eq!(numbers(&py["x"]), numbers(&rs["x"]), "snapshot {i}: x");
        assert_eq!(numbers(&py["P"]), numbers(&rs["P"]), "snapshot {i}: P");
        let counters = rs["counters"].as_array().unwrap();
        let received: Vec<u64> = counters.iter().map(|c| c["received"].as_u64().unwrap()).collect();
        let fused_now: Vec<u64> = counters.iter().map(|c| c["fused"].as_u64().unwrap()).collect();
        assert_eq!(py["received"], json!(received), "snapshot {i}");
        assert_eq!(py["fused"], json!(fused_now), "snapshot {i}");
        fused = fused_now.iter().sum();
    }
    // The last snapshot both read is the settled one after the drive.
    assert!(python_lines[count - 1]["pending"].is_null());
    let fixes = samples.iter().filter(|s| s.kind() == SampleKind::Position).count();
    assert!(fused > 5, "the drive's {fixes} fixes were fused: {fused}");
}

#[test]
fn fusiond_fuses_what_python_publishes_and_python_refuses_bad_samples() {
    let domain = TestDomain::new("py-publish");
    let mut daemon = Daemon::start(&domain, &common::linear_config(None), "event");
    let out = common::python_command(&domain.domain, "tests/publish.py", &[&domain.namespace]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("refused: PositionSample with a NaN or infinite value"), "{said}");
    assert!(said.contains("refused: a PositionSample given to a ImuSample publisher"), "{said}");
    assert!(said.contains("published 220 samples, reached 220"), "{said}");

    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let s = *reader.wait_next(Duration::from_secs(10)).unwrap().expect("the latest snapshot");
    let counters = |kind: SampleKind| *s.sensor_counters().iter().find(|c| c.sample_kind() == Some(kind)).unwrap();
    let (imu, gnss) = (counters(SampleKind::Imu), counters(SampleKind::Position));
    assert_eq!((imu.sensor, imu.counts.received, imu.counts.processed, imu.counts.invalid), (0, 200, 200, 0));
    assert_eq!((gnss.sensor, gnss.counts.received, gnss.counts.fused, gnss.counts.invalid), (1, 20, 20, 0));
    assert_eq!(gnss.counts.lost, 0, "the NaN fix never left Python");
    // Fused, and nothing wrong but the streams that stopped when Python did.
    let reasons: Vec<_> = s.health_reason_names().collect();
    assert!(reasons.iter().all(|r| r.ends_with(" stale")), "{reasons:?}");
    // A stationary vehicle at the origin.
    assert!(s.state()[..3].iter().all(|p| p.abs() < 1.0), "{:?}", s.state());
    drop(reader);
    drop(client);
    assert!(daemon.terminate().success());
}

/// Two IMUs averaged, read from Python: one snapshot per instant, named after
/// the sample that completed it; an instant one IMU misses still gets its snapshot,
/// after fusiond's bounded wait.
#[test]
fn python_reads_one_snapshot_per_imu_instant() {
    let domain = TestDomain::new("py-instants");
    let config = common::two_averaged_imus_config();
    // Spin: the daemon never sleeps between an instant's samples (in event
    // mode an instant's snapshot also goes out when it would).
    let mut daemon = Daemon::start(&domain, &config, "spin");
    let out = common::python_command(
        &domain.domain,
        "tests/instants.py",
        &[&domain.namespace, &common::INSTANT_WAIT_NS.to_string()],
    )
    .output()
    .unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    common::assert_one_snapshot_per_instant(&said);
    assert!(daemon.terminate().success());
}

/// The robot kinds from Python: a magnetometer, a twist, a barometer and poses
/// reach an `ins` fusiond and are fused (the barometer's bias and the pose's
/// map frame set by their first samples); a NaN in a 6×6 covariance never
/// leaves Python, a skewed quaternion is refused by fusiond.
#[test]
fn fusiond_fuses_the_robot_kinds_python_publishes() {
    let domain = TestDomain::new("py-robot");
    let mut daemon = Daemon::start(&domain, common::ROBOT_INS_CONFIG, "event");
    let out = common::python_command(&domain.domain, "tests/publish_robot.py", &[&domain.namespace]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("refused: TwistSample with a NaN or infinite value"), "{said}");
    assert!(said.contains("published 281 samples, reached 281"), "{said}");

    common::assert_robot_samples_fused(&domain);
    assert!(daemon.terminate().success());
}

#[test]
fn the_python_example_reads_a_live_snapshot() {
    let domain = TestDomain::new("py-example");
    let mut daemon = Daemon::start(&domain, &common::linear_config(None), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(16).unwrap();
    let out = common::python_command(&domain.domain, "examples/example.py", &[&domain.namespace]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(
        said.starts_with("t_ns ")
            && said.contains(" position [")
            && said.contains(" sd [")
            && said.ends_with("health initialising\n"),
        "{said}"
    );
    // As an IMU of its own, not a vehicle's IMU 0.
    let s = *reader.wait_next(std::time::Duration::from_secs(10)).unwrap().expect("the example's snapshot");
    assert_eq!(s.sensor_counters().iter().map(|c| c.sensor).collect::<Vec<_>>(), [99], "{:?}", s.sensor_counters());
    drop((reader, client));
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());

    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/clients.md")).unwrap();
    let example =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../client/python/examples/example.py")).unwrap();
    assert!(
        guide.contains(&format!("```python\n{example}```\n")),
        "docs/clients.md's Python example differs from the tested one"
    );
}

#[test]
fn the_python_typed_accessors_agree_with_the_rust_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = common::typed::write_cases(dir.path());
    let out = common::python_command("unused", "tests/typed.py", &[path.to_str().unwrap()]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    common::typed::assert_agree(&String::from_utf8_lossy(&out.stdout));
}

/// `pip install ./client/python`, as the guide says, leaves nothing in the
/// source tree that git would see (setuptools builds in `build/` and writes
/// `*.egg-info` next to the package: both are ignored).
#[test]
fn installing_the_python_client_leaves_the_source_tree_clean() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // Files git would show as new under client/python (`None`: no git here).
    let untracked = || {
        let out = Command::new("git")
            .args(["ls-files", "--others", "--exclude-standard", "--", "client/python"])
            .current_dir(&root)
            .output()
            .ok()
            .filter(|o| o.status.success())?;
        Some(String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let before = untracked();
    let target = tempfile::tempdir().unwrap();
    let out = Command::new(common::python_venv())
        .args(["-m", "pip", "install", "--quiet", "--no-deps", "--target"])
        .arg(target.path())
        .arg(root.join("client/python"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(target.path().join("fusion_client/__init__.py").exists());
    assert!(root.join("client/python/build").exists(), "setuptools built in the tree (what this test is about)");
    assert_eq!(untracked(), before, "pip left files git sees");
}

/// A Python script that publishes one sample and ends at once, run again and
/// again: every sample reaches fusiond (the interpreter's exit waits until
/// fusiond could connect to the publisher).
#[test]
fn one_shot_python_scripts_lose_no_sample() {
    let domain = TestDomain::new("py-oneshot");
    let mut daemon = Daemon::start(&domain, &common::linear_config(None), "event");
    let runs = 12u64;
    for _ in 0..runs {
        let out =
            common::python_command(&domain.domain, "tests/oneshot.py", &[&domain.namespace, "43"]).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let received = common::live::received_by(&domain, 43, runs);
    assert_eq!(received, runs, "samples of one-shot scripts that reached fusiond");
    assert!(daemon.terminate().success());
}
