//! ROS bags in, as a robot_localization user brings them: robot_localization's
//! own test bags (`../shared/data/robot_localization`, or the folder
//! `FUSION_RL_DATA` names; not in this repository) replayed by the real
//! `fusiond replay` with the configurations of the guide's ground-robot page,
//! ending within robot_localization's own tolerance of its expected position;
//! the same bag as ROS 2 (MCAP) giving the same estimate; bad bags giving clear
//! errors or counted refusals, never a panic.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fusion_daemon::replay::OutputLine;
use nalgebra::{UnitQuaternion, Vector3};

/// One of robot_localization's test bags: a ROS 1 bag from its `test/`
/// folder, a ROS 2 copy from `ros2/`. `None`, said on stderr with where the
/// bags come from, when they are absent (a failure instead where
/// `FUSION_REQUIRE_RL_DATA` is set, as in `.ci/run`).
fn data(name: &str) -> Option<PathBuf> {
    let root = std::env::var_os("FUSION_RL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/robot_localization"));
    let path = root.join(if name.ends_with(".bag") { "test" } else { "ros2" }).join(name);
    if path.exists() {
        return Some(path);
    }
    let said = format!(
        "{} is absent: robot_localization's test bags (its repository's test/ folder, BSD; the ROS 2 copies made \
         with rosbags-convert, see the README beside them) are read from ../shared/data/robot_localization or \
         the folder FUSION_RL_DATA names",
        path.display()
    );
    assert!(std::env::var_os("FUSION_REQUIRE_RL_DATA").is_none(), "{said}");
    eprintln!("skipped: {said}");
    None
}

/// The ```toml block of the ground-robot page whose first line is `# <name>`.
fn page_config(name: &str) -> String {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/ground-robots.md")).unwrap();
    let marker = format!("```toml\n# {name}");
    let start = page.find(&marker).unwrap_or_else(|| panic!("no {name} block on the page")) + "```toml\n".len();
    let end = start + page[start..].find("```").unwrap();
    page[start..end].to_string()
}

fn replay(dir: &Path, config: &str, input: &Path) -> (Output, PathBuf) {
    let config_path = dir.join("config.toml");
    std::fs::write(&config_path, config).unwrap();
    // By the whole file name: test2.bag's and test2.mcap's estimates side by side.
    let output = dir.join(format!("{}.jsonl", input.file_name().unwrap().to_string_lossy()));
    let out = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(&config_path)
        .arg("--input")
        .arg(input)
        .arg("--output")
        .arg(&output)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    (out, output)
}

/// `base_link`'s displacement from its position at the first attitude sample
/// (when the AHRS set the attitude; robot_localization starts `base_link` at
/// its world origin), with the IMU at `imu_in_base` in `base_link`.
fn base_link_end(output: &Path, imu_in_base: Vector3<f64>) -> Vector3<f64> {
    let lines: Vec<OutputLine> =
        std::fs::read_to_string(output).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let base = |l: &OutputLine| {
        let x = &l.x;
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(x[6], x[7], x[8], x[9]));
        Vector3::new(x[0], x[1], x[2]) - q * imu_in_base
    };
    let start = lines.iter().find(|l| l.kind == "attitude").expect("an attitude sample");
    base(lines.last().unwrap()) - base(start)
}

#[test]
fn the_husky_bag_ends_within_robot_localizations_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let Some(bag) = data("test1.bag") else { return };
    let (out, output) = replay(dir.path(), &page_config("husky.toml"), &bag);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("/imu/data (sensor_msgs/Imu): 11865 messages -> 11865 attitude, 11865 imu"), "{stderr}");
    assert!(stderr.contains("3952 messages -> 3952 odometry"), "{stderr}");
    assert!(stderr.contains("/fix (sensor_msgs/NavSatFix): 989 messages, not mapped"), "{stderr}");
    let end = base_link_end(&output, Vector3::new(0.0, -0.3, 0.52));
    let expected = Vector3::new(-40.0454, -76.9988, -2.6974);
    let off = (end - expected).norm();
    println!(
        "test1.bag: base_link ends at {end:?}, {off:.3} m from robot_localization's expected (tolerance 1.0452 m)"
    );
    assert!(off < 1.0452, "{off} m off: {end:?}");
    // The same bag as ROS 2, in MCAP and in SQLite: the same estimate, bit for bit.
    let ros1 = std::fs::read(&output).unwrap();
    for (name, format) in [("test1.mcap", "bag (ROS 2 (MCAP))"), ("test1.db3", "bag (ROS 2 (SQLite))")] {
        let Some(ros2) = data(name) else { return };
        let (out, output) = replay(dir.path(), &page_config("husky.toml"), &ros2);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success() && stderr.contains(format), "{name}: {stderr}");
        assert_eq!(ros1, std::fs::read(&output).unwrap(), "test1.bag and {name} differ");
    }
}

/// `fusionctl plot --samples test1.bag` of the husky's replay: the bag's
/// `/fix` drawn beside the estimate, as a reference where no `[[sensor]]`
/// reads it, or fused and gated as the replay decided where one does; the
/// page's time 0 said as the bag's UTC date; the drive's end marked.
#[test]
fn a_bags_replay_is_plotted_with_its_fixes() {
    let dir = tempfile::tempdir().unwrap();
    let Some(bag) = data("test1.bag") else { return };
    let plot = |output: &Path, report: &str| {
        let out = Command::new(common::live::workspace_bin("fusionctl"))
            .args(["plot", "--input"])
            .arg(output)
            .arg("--samples")
            .arg(&bag)
            .arg("--output-dir")
            .arg(dir.path().join(report))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join(report).join("report.json")).unwrap())
                .unwrap();
        let n = |k: &str| json["points"][k].as_u64().unwrap();
        let svg = std::fs::read_to_string(dir.path().join(report).join("trajectory.svg")).unwrap();
        (stderr, [n("trajectory.fixes"), n("trajectory.gated"), n("trajectory.not_fused")], svg)
    };
    let (out, output) = replay(dir.path(), &page_config("husky.toml"), &bag);
    assert!(out.status.success());
    let (said, fates, svg) = plot(&output, "reference");
    assert!(said.contains("989 fixes of /fix (989 not fused)"), "{said}");
    assert_eq!(fates, [0, 0, 989]);
    assert!(svg.contains("fix, not fused (a reference)"), "the legend names them");
    assert!(svg.contains("2015-05-21 19:11:37.989 UTC"), "the bag's wall-clock start as a date");
    // The end: a 10-pixel black square (besides the legend's 8-pixel one).
    assert!(svg.contains(r##"width="10" height="10" opacity="1" fill="#000000""##), "the end is marked");
    // With the GNSS fused, every fix is fused or gated, found by its stamp.
    let gnss = format!(
        "{}\n[[sensor]]\nname = \"gnss\"\nid = 0\nkinds = [\"geodetic\"]\ntopic = \"/fix\"\n\n[gating]\nprobability = 0.999\n",
        page_config("husky.toml")
    );
    let (out, output) = replay(dir.path(), &gnss, &bag);
    assert!(out.status.success());
    let (said, [fused, gated, not_fused], _) = plot(&output, "fused");
    assert!(said.contains("989 fixes of /fix (0 not fused)"), "{said}");
    assert_eq!((fused + gated, not_fused), (989, 0));
    assert!(fused > 0 && gated > 0, "{fused} fused, {gated} gated");
}

/// The yaw σ of each line, rad: the attitude error's σ about world up.
fn yaw_sds(output: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(output).unwrap();
    let lines = text.lines().map(|l| serde_json::from_str::<OutputLine>(l).unwrap());
    lines
        .map(|l| {
            let x = &l.x;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(x[6], x[7], x[8], x[9]));
            common::heading_error(&q, &l.p, &q).1
        })
        .collect()
}

/// The Husky bag with the AHRS's roll and pitch only (`yaw = false`): nothing
/// gives a heading, and the one the configuration starts with is unknown
/// (1 rad²). It stays unknown: the yaw σ never falls (it fell from 57° to
/// 1.3° when the updates could move the heading); the estimate stays bounded,
/// and the height, which the constraint and the tilt do observe, ends within
/// robot_localization's tolerance of its expected one.
#[test]
fn without_a_heading_the_husky_bag_keeps_its_heading_unknown() {
    let dir = tempfile::tempdir().unwrap();
    let config = page_config("husky.toml")
        .replace("topic = \"/imu/data\"", "topic = \"/imu/data\"\n[sensor.attitude]\nyaw = false");
    assert!(config.contains("yaw = false"));
    let Some(bag) = data("test1.bag") else { return };
    let (out, output) = replay(dir.path(), &config, &bag);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let sds = yaw_sds(&output);
    let (start, least) = (sds[0], sds.iter().copied().fold(f64::INFINITY, f64::min));
    let end = base_link_end(&output, Vector3::new(0.0, -0.3, 0.52));
    println!(
        "test1.bag without a heading: yaw σ {:.2}° at the start, at least {:.2}°, {:.2}° at the end; base_link ends at \
         {end:?}",
        start.to_degrees(),
        least.to_degrees(),
        sds.last().unwrap().to_degrees()
    );
    assert!(least >= 0.999 * start, "the yaw σ fell from {start} to {least} rad");
    assert!(end.xy().norm() < 200.0, "the estimate ran away: {end:?}");
    assert!((end.z - -2.6974).abs() < 1.0452, "height {} against -2.6974", end.z);
}

#[test]
fn the_jackal_bag_ends_within_robot_localizations_tolerance_as_ros1_and_ros2() {
    let dir = tempfile::tempdir().unwrap();
    let config = page_config("jackal.toml");
    let (Some(bag), Some(mcap), Some(db3)) = (data("test2.bag"), data("test2.mcap"), data("test2.db3")) else {
        return;
    };
    let (out, ros1) = replay(dir.path(), &config, &bag);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let end = base_link_end(&ros1, Vector3::zeros());
    let off = (end - Vector3::new(1.0206, 3.4292, 0.7419)).norm();
    println!(
        "test2.bag: base_link ends at {end:?}, {off:.3} m from robot_localization's expected (tolerance 0.1383 m)"
    );
    assert!(off < 0.1383, "{off} m off: {end:?}");
    let (out, ros2) = replay(dir.path(), &config, &mcap);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("bag (ROS 2 (MCAP))") && stderr.contains("(sensor_msgs/msg/Imu): 3061 messages"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&ros1).unwrap(), std::fs::read(&ros2).unwrap(), "ROS 1 and ROS 2 differ");
    let (out, db3) = replay(dir.path(), &config, &db3);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("bag (ROS 2 (SQLite))")
            && stderr.contains("(nav_msgs/msg/Odometry): 3060 messages -> 3060 odometry"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&ros1).unwrap(), std::fs::read(&db3).unwrap(), "ROS 1 and ROS 2 in SQLite differ");
}

fn failure(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{stderr}");
    stderr
}

#[test]
fn a_bag_that_does_not_fit_its_topic_map_is_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let jackal = page_config("jackal.toml");
    let Some(test2) = data("test2.bag") else { return };
    // The IMU's topic mapped to a kind an Imu message does not give.
    let wrong = jackal.replace("kinds = [\"imu\", \"attitude\"]", "kinds = [\"imu\", \"twist\"]");
    let stderr = failure(&replay(dir.path(), &wrong, &test2).0);
    assert!(
        stderr.contains("topic /imu/data is a sensor_msgs/Imu, which gives no twist sample ([[sensor]] \"imu\"); it gives imu, attitude"),
        "{stderr}"
    );
    // No topic at all.
    let none = jackal.replace("topic = ", "# topic = ");
    let stderr = failure(&replay(dir.path(), &none, &test2).0);
    assert!(stderr.contains("no [[sensor]] has a topic"), "{stderr}");
    // A mapped topic that is not in the bag: said, and the rest replayed.
    let missing = jackal.replace("/jackal_velocity_controller/odom", "/wheel/odom");
    let (out, _) = replay(dir.path(), &missing, &test2);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && stderr.contains("/wheel/odom: mapped, but no message in the bag"), "{stderr}");
}

#[test]
fn damaged_bags_get_clear_errors_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let jackal = page_config("jackal.toml");
    let (Some(test2), Some(test2_db3)) = (data("test2.bag"), data("test2.db3")) else { return };
    let bag = std::fs::read(test2).unwrap();
    // Cut off: the index (at the end) is gone.
    let cut = dir.path().join("cut.bag");
    std::fs::write(&cut, &bag[..bag.len() / 2]).unwrap();
    let stderr = failure(&replay(dir.path(), &jackal, &cut).0);
    assert!(stderr.contains("truncated") && stderr.contains("rosbag reindex"), "{stderr}");
    // Garbage over the middle: what comes before it is replayed, the damage named.
    let mut garbage = bag.clone();
    let mid = garbage.len() / 2;
    garbage[mid..mid + 4096].fill(0xff);
    let bad = dir.path().join("garbage.bag");
    std::fs::write(&bad, &garbage).unwrap();
    let (out, _) = replay(dir.path(), &jackal, &bad);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("the bag is damaged") || stderr.contains("does not decode"), "{stderr}");
    // A ROS 2 bag in SQLite cut in half, or to its first page: an error or
    // what comes before the damage, named; never a panic.
    let db3 = std::fs::read(test2_db3).unwrap();
    for (name, len) in [("half.db3", db3.len() / 2), ("page.db3", 4096)] {
        let cut = dir.path().join(name);
        std::fs::write(&cut, &db3[..len]).unwrap();
        let (out, _) = replay(dir.path(), &jackal, &cut);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("cannot be read as a ROS 2 bag") || stderr.contains("damaged"), "{name}: {stderr}");
    }
    // Not a bag at all.
    let text = dir.path().join("notes.bag");
    std::fs::write(&text, b"#ROSBAG V2.0\nhello").unwrap();
    let stderr = failure(&replay(dir.path(), &jackal, &text).0);
    assert!(stderr.contains("header record is damaged"), "{stderr}");
}

/// A ROS 2 bag written here: IMU messages on `/imu/data`, one with a NaN in its
/// orientation covariance and one with its orientation "not given", and an
/// image topic.
fn ros2_bag(path: &Path) {
    #[derive(serde::Serialize)]
    struct Stamp(i32, u32);
    #[derive(serde::Serialize)]
    struct Header(Stamp, String);
    #[derive(serde::Serialize)]
    struct Imu(Header, [f64; 4], [f64; 9], [f64; 3], [f64; 9], [f64; 3], [f64; 9]);
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").create(file).unwrap();
    let imu_schema = w.add_schema("sensor_msgs/msg/Imu", "ros2msg", b"").unwrap();
    let image_schema = w.add_schema("sensor_msgs/msg/Image", "ros2msg", b"").unwrap();
    let imu = w.add_channel(imu_schema, "/imu/data", "cdr", &Default::default()).unwrap();
    let image = w.add_channel(image_schema, "/camera/image", "cdr", &Default::default()).unwrap();
    let var = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4];
    for i in 0..400u32 {
        let t = 1_000_000_000 + u64::from(i) * 10_000_000;
        let mut cov = var;
        if i == 150 {
            cov[4] = f64::NAN;
        }
        if i == 151 {
            cov[0] = -1.0;
        }
        let header = Header(Stamp((t / 1_000_000_000) as i32, (t % 1_000_000_000) as u32), "base_link".into());
        let msg = Imu(header, [0.0, 0.0, 0.0, 1.0], cov, [0.0; 3], var, [0.0, 0.0, 9.80665], var);
        let data = cdr::serialize::<_, _, cdr::CdrLe>(&msg, cdr::Infinite).unwrap();
        let header = mcap::records::MessageHeader { channel_id: imu, sequence: i, log_time: t, publish_time: t };
        w.write_to_known_channel(&header, &data).unwrap();
        if i % 10 == 0 {
            let header = mcap::records::MessageHeader { channel_id: image, sequence: i, log_time: t, publish_time: t };
            w.write_to_known_channel(&header, b"\0\x01\0\0").unwrap();
        }
    }
    w.finish().unwrap();
}

#[test]
fn ros2_messages_that_give_no_sample_are_counted_with_their_reasons() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot.mcap");
    ros2_bag(&path);
    let jackal = page_config("jackal.toml");
    let (out, output) = replay(dir.path(), &jackal, &path);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(
            "/imu/data (sensor_msgs/msg/Imu): 400 messages -> 399 attitude, 400 imu; \
                         1 refused: attitude orientation not given (orientation_covariance[0] = -1)"
        ),
        "{stderr}"
    );
    assert!(stderr.contains("/camera/image (sensor_msgs/msg/Image): 40 messages, not mapped"), "{stderr}");
    // The NaN covariance is a sample the daemon's validation refuses, the
    // orientation not given one that was never made: both counted invalid.
    assert!(stderr.contains("invalid 2") && stderr.contains("  message 166: non-finite value"), "{stderr}");
    let lines = std::fs::read_to_string(&output).unwrap();
    assert!(lines.lines().all(|l| !l.contains("NaN") && !l.contains("null,\"P\"")));
    // The image topic mapped: an error naming it and what fusiond reads.
    let camera =
        format!("{jackal}\n[[sensor]]\nname = \"camera\"\nid = 0\nkinds = [\"pose\"]\ntopic = \"/camera/image\"\n");
    let stderr = failure(&replay(dir.path(), &camera, &path).0);
    assert!(
        stderr.contains("topic /camera/image (mapped to [[sensor]] \"camera\") is a sensor_msgs/msg/Image, which fusiond does not read; it reads sensor_msgs/Imu"),
        "{stderr}"
    );
}

/// `fusion-sim run --input robot.mcap --config robot.toml` publishes a bag
/// live, restamped onto this host's clock: a running fusiond takes every
/// sample (the imu and attitude of each message, less the two refused), the
/// message without an orientation is said, none is refused for its time.
#[test]
fn fusion_sim_publishes_a_bag_live() {
    use common::live::{Daemon, TestDomain, workspace_bin};
    use fusion_shared::SampleKind;
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("robot.mcap");
    ros2_bag(&bag);
    let config = page_config("jackal.toml");
    let config_path = dir.path().join("robot.toml");
    std::fs::write(&config_path, &config).unwrap();
    let domain = TestDomain::new("sim-bag");
    let mut daemon = Daemon::start(&domain, &config, "event");
    let out = Command::new("timeout")
        .arg("60")
        .arg(workspace_bin("fusion-sim"))
        .args(["run", "--namespace", &domain.namespace, "--input"])
        .arg(&bag)
        .arg("--config")
        .arg(&config_path)
        .env(fusion_shared::service::DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("400 messages -> 399 attitude, 400 imu; 1 refused: attitude orientation not given"),
        "{stderr}"
    );
    assert!(stderr.contains("published 799 samples") && stderr.contains("1 messages gave none"), "{stderr}");
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let snap = match reader.latest().unwrap() {
        Some(s) => *s,
        None => *reader.wait_next(std::time::Duration::from_secs(5)).unwrap().expect("a snapshot"),
    };
    let counts = |kind: SampleKind| {
        let rows = &snap.sensors[..snap.sensor_count as usize];
        rows.iter().find(|r| r.kind == kind as u32).map(|r| r.counts).expect("its row")
    };
    let (imu, attitude) = (counts(SampleKind::Imu), counts(SampleKind::Attitude));
    assert_eq!((imu.received, imu.processed), (400, 400), "{imu:?}");
    // The NaN covariance is refused by fusiond's validation; the rest fused
    // (the first sets the attitude).
    assert_eq!((attitude.received, attitude.invalid), (399, 1), "{attitude:?}");
    assert!(attitude.fused >= 390, "{attitude:?}");
    assert_eq!(snap.rejected(), 1, "none refused for its time: {:?}", snap.rejections);
    drop((reader, client));
    assert!(daemon.terminate().success());
}
