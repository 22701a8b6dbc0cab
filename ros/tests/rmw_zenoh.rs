//! fusion-ros on rmw_zenoh against independent parts, with no ROS
//! installation: a Zenoh router on loopback (Zenoh's own, in this process),
//! and a ROS 2 node's stand-in in Python (`tests/python/ros_node.py`: Zenoh's
//! Python package for the transport, `rosbags` for the bag and the CDR).
//! The stand-in plays the first seconds of robot_localization's husky bag at
//! their pace with `/clock`; fusiond fuses them; fusion-ros sends odometry,
//! TF and diagnostics back; the last odometry is compared with `fusiond
//! replay` of the same messages. Everything is on 127.0.0.1, with multicast
//! scouting off in every session.

#[path = "../../daemon/tests/common/mod.rs"]
mod common;

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain};
use fusion_daemon::replay::OutputLine;
use fusion_shared::service::DOMAIN_ENV;
use nalgebra::{UnitQuaternion, Vector3};
use zenoh::Wait;

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// robot_localization's husky bag as ROS 2 (MCAP), or `None` with where it
/// comes from (a failure where `FUSION_REQUIRE_RL_DATA` is set).
fn husky_bag() -> Option<PathBuf> {
    let root = std::env::var_os("FUSION_RL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/robot_localization"));
    let path = root.join("ros2/test1.mcap");
    if path.exists() {
        return Some(path);
    }
    let said = format!(
        "{} is absent: robot_localization's test bags (BSD; the ROS 2 copies made with rosbags-convert) are read \
         from ../shared/data/robot_localization or the folder FUSION_RL_DATA names",
        path.display()
    );
    assert!(std::env::var_os("FUSION_REQUIRE_RL_DATA").is_none(), "{said}");
    eprintln!("skipped: {said}");
    None
}

/// The guide's husky configuration (docs/ground-robots.md), with a topic of
/// barometer messages for the flood, and the `[ros]` table of the test.
fn config() -> String {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/ground-robots.md")).unwrap();
    let start = page.find("```toml\n# husky.toml").unwrap() + "```toml\n".len();
    let husky = &page[start..start + page[start..].find("```").unwrap()];
    format!(
        "{husky}
[[sensor]]
name = \"pressure\"
id = 5
kinds = [\"barometer\"]
topic = \"/flood/pressure\"

[ros]
transport = \"zenoh\"
clock = \"sim\"
rate_hz = 0.0
base_link_position_m = [0.0, 0.3, -0.52]
max_topic_rate_hz = 200.0
diagnostics_period_s = 0.5
"
    )
}

/// A Zenoh router on 127.0.0.1:`port`, as `rmw_zenohd` is one.
fn router(port: u16) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", "\"router\"").unwrap();
    c.insert_json5("listen/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]")).unwrap();
    c.insert_json5("scouting/multicast/enabled", "false").unwrap();
    zenoh::open(c).wait().unwrap()
}

fn fusion_ros(domain: &TestDomain, config: &Path, port: u16, log: &Path) -> Running {
    Running(
        Command::new(env!("CARGO_BIN_EXE_fusion-ros"))
            .args(["--namespace", &domain.namespace, "--status-interval", "0.5", "--config"])
            .arg(config)
            .args(["--connect", &format!("tcp/127.0.0.1:{port}"), "--listen", "tcp/127.0.0.1:0"])
            .env(DOMAIN_ENV, &domain.domain)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log).unwrap())
            .spawn()
            .unwrap(),
    )
}

fn replay(config: &Path, bag: &Path, output: &Path) {
    let out = Command::new(common::live::fusiond())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--input")
        .arg(bag)
        .arg("--output")
        .arg(output)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// base_link's position and attitude of a replayed estimate (the IMU's pose
/// moved by `[ros] base_link_position_m`).
fn base_link(line: &OutputLine) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let x = &line.x;
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(x[6], x[7], x[8], x[9]));
    (Vector3::new(x[0], x[1], x[2]) + q * Vector3::new(0.0, 0.3, -0.52), q)
}

#[test]
fn a_ros_node_on_rmw_zenoh_gets_fusionds_odometry_of_its_bag() {
    let Some(bag) = husky_bag() else { return };
    let domain = TestDomain::new("ros-zenoh");
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("husky.toml");
    std::fs::write(&config_path, config()).unwrap();
    let port = free_port();
    let router = router(port);
    let mut daemon = Daemon::start_with(&domain, &config(), &[]);
    let log = dir.path().join("fusion-ros.log");
    let mut node = fusion_ros(&domain, &config_path, port, &log);
    let (segment, result) = (dir.path().join("segment"), dir.path().join("result.json"));
    let out = Command::new(common::python_venv())
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/ros_node.py"))
        .args(["--router", &format!("tcp/127.0.0.1:{port}"), "--seconds", "12", "--hostile", "--bag"])
        .arg(&bag)
        .arg("--segment")
        .arg(&segment)
        .arg("--result")
        .arg(&result)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "stand-in: {}\n{}", String::from_utf8_lossy(&out.stderr), read(&log));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&result).unwrap()).unwrap();
    assert!(node.stop(Duration::from_secs(10)).is_some_and(|s| s.success()), "{}", read(&log));
    assert!(daemon.terminate().success(), "{}", daemon.stderr());
    let _ = router.close().wait();
    let log = read(&log);
    eprintln!("{log}");

    // The graph: fusiond's node, and its publishers of odometry and TF.
    let tokens: Vec<&str> = r["tokens"].as_array().unwrap().iter().map(|t| t.as_str().unwrap()).collect();
    assert!(tokens.iter().any(|t| t.contains("/NN/%/%/fusiond") && t.ends_with("fusiond")), "{tokens:?}");
    for topic in ["%odometry%filtered/nav_msgs::msg::dds_::Odometry_/", "%tf/tf2_msgs::msg::dds_::TFMessage_/"] {
        assert!(tokens.iter().any(|t| t.contains("/MP/") && t.contains(topic)), "{topic}: {tokens:?}");
    }
    assert!(tokens.iter().any(|t| t.contains("/MS/") && t.contains("%imu%data")), "{tokens:?}");
    // Every message with rmw_zenoh's attachment, in order, of one publisher.
    for stream in ["odometry", "tf", "diagnostics"] {
        let s = &r[stream];
        assert!(s["count"].as_u64().unwrap() > 0, "{stream}: {s}");
        assert_eq!(s["problems"].as_array().unwrap().len(), 0, "{stream}: {s}");
        assert_eq!((s["seq_in_order"].as_bool(), s["gids"].as_u64()), (Some(true), Some(1)), "{stream}: {s}");
    }
    // The stand-in subscribed before fusiond's first estimate (diagnostics come before it).
    assert_eq!(r["odometry"]["first_seq"].as_i64(), Some(1));
    // One odometry per snapshot ([ros] rate_hz = 0), stamped with its samples' stamps.
    let last = &r["odometry"]["last"];
    let stamp = last["stamp_ns"].as_u64().unwrap();
    assert_eq!(stamp, r["last_stamp_ns"].as_u64().unwrap(), "the last odometry is of the last sample");
    assert_eq!((last["frame"].as_str(), last["child"].as_str()), (Some("odom"), Some("base_link")));
    let stamps: Vec<u64> = r["stamps"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    let odom_stamps = r["odometry"]["all_stamps"].as_array().unwrap();
    assert!(odom_stamps.iter().all(|s| stamps.binary_search(&s.as_u64().unwrap()).is_ok()), "stamps kept");
    assert_eq!(r["tf"]["last"]["translation"], last["position"]);

    // The same messages replayed: the same estimate at the same stamp.
    let replayed = dir.path().join("replay.jsonl");
    replay(&config_path, &segment.join("segment.mcap"), &replayed);
    let lines: Vec<OutputLine> =
        std::fs::read_to_string(&replayed).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let at = lines.iter().rev().find(|l| l.t_ns == stamp).expect("replay has the stamp");
    let (p, q) = base_link(at);
    let got: Vec<f64> = last["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let off = (Vector3::new(got[0], got[1], got[2]) - p).norm();
    eprintln!("live vs replay at {stamp}: {off:e} m ({} odometry messages)", r["odometry"]["count"]);
    assert!(off < 1e-9, "live {got:?} vs replay {p:?}: {off} m");
    let o: Vec<f64> = last["orientation"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let live_q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o[0], o[1], o[2], o[3]));
    assert!(live_q.angle_to(&q) < 1e-9);

    // Hostile input: each counted and named once; nothing of it reached fusiond.
    for why in [
        "does not decode",
        "type hash TypeHashNotSupported",
        "no attachment",
        "two types on one topic",
        "a flood",
        "pressure variance unknown",
    ] {
        assert_eq!(log.matches(why).count(), 1, "{why:?} said once: {log}");
    }
    let diagnostics = r["diagnostics"]["last"].as_array().unwrap();
    let input = diagnostics.iter().find(|s| s["name"] == "fusiond: ROS input").unwrap();
    assert_eq!(input["level"], 1, "{input}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_default()
}

/// Starting with no router: fusion-ros says so and goes on.
#[test]
fn no_router_is_said() {
    let domain = TestDomain::new("ros-norouter");
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("c.toml");
    std::fs::write(
        &config_path,
        "[ros]\ntransport = \"zenoh\"\n[[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\ntopic = \"/imu/data\"\n",
    )
    .unwrap();
    let log = dir.path().join("log");
    let mut node = fusion_ros(&domain, &config_path, free_port(), &log);
    let deadline = Instant::now() + Duration::from_secs(30);
    while !read(&log).contains("no Zenoh router reached") {
        assert!(Instant::now() < deadline, "{}", read(&log));
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(node.stop(Duration::from_secs(10)).is_some_and(|s| s.success()), "{}", read(&log));
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}
