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
mod ros_common;

use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain};
use fusion_shared::service::DOMAIN_ENV;
use ros_common::{config, husky_bag, off_replay, replay};
use zenoh::Wait;

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
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

#[test]
fn a_ros_node_on_rmw_zenoh_gets_fusionds_odometry_of_its_bag() {
    let Some(bag) = husky_bag() else { return };
    let domain = TestDomain::new("ros-zenoh");
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("husky.toml");
    std::fs::write(&config_path, config("zenoh")).unwrap();
    let port = free_port();
    let router = router(port);
    let mut daemon = Daemon::start_with(&domain, &config("zenoh"), &[]);
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
    let lines = replay(&config_path, &segment.join("segment.mcap"), dir.path());
    let (off_m, off_rad) = off_replay(last, &lines);
    eprintln!("live vs replay at {stamp}: {off_m:e} m, {off_rad:e} rad ({} odometry messages)", r["odometry"]["count"]);
    assert!(off_m < 1e-9 && off_rad < 1e-9, "live {last} vs replay: {off_m} m, {off_rad} rad");

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
