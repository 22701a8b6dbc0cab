//! What the end-to-end tests of both middlewares share: the husky bag, its
//! configuration, and the comparison with `fusiond replay`.

use std::path::{Path, PathBuf};
use std::process::Command;

use fusion_daemon::replay::OutputLine;
use nalgebra::{UnitQuaternion, Vector3};

/// robot_localization's husky bag as ROS 2 (MCAP), or `None` with where it
/// comes from (a failure where `FUSION_REQUIRE_RL_DATA` is set).
pub fn husky_bag() -> Option<PathBuf> {
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

/// base_link in the husky's body frame (the nonholonomic constraint's point).
pub const BASE_LINK: [f64; 3] = [0.0, 0.3, -0.52];

/// The guide's husky configuration (docs/ground-robots.md), with a topic of
/// barometer messages for the flood, and a `[ros]` table on `transport`.
pub fn config(transport: &str) -> String {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/ground-robots.md")).unwrap();
    let start = page.find("```toml\n# husky.toml").unwrap() + "```toml\n".len();
    let husky = &page[start..start + page[start..].find("```").unwrap()];
    let [x, y, z] = BASE_LINK;
    format!(
        "{husky}
[[sensor]]
name = \"pressure\"
id = 5
kinds = [\"barometer\"]
topic = \"/flood/pressure\"

[ros]
transport = \"{transport}\"
clock = \"sim\"
rate_hz = 0.0
base_link_position_m = [{x:?}, {y:?}, {z:?}]
max_topic_rate_hz = 200.0
diagnostics_period_s = 0.5
"
    )
}

/// `fusiond replay` of `bag` with `config`: its lines.
pub fn replay(config: &Path, bag: &Path, dir: &Path) -> Vec<OutputLine> {
    let output = dir.join("replay.jsonl");
    let out = Command::new(crate::common::live::fusiond())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--input")
        .arg(bag)
        .arg("--output")
        .arg(&output)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::read_to_string(&output).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// How far the odometry `odom` (`stamp_ns`, `position`, `orientation` as
/// w x y z) is from base_link of the replay's estimate at its stamp: metres
/// and radians.
pub fn off_replay(odom: &serde_json::Value, lines: &[OutputLine]) -> (f64, f64) {
    let stamp = odom["stamp_ns"].as_u64().unwrap();
    let at = lines.iter().rev().find(|l| l.t_ns == stamp).expect("replay has the stamp");
    let x = &at.x;
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(x[6], x[7], x[8], x[9]));
    let p = Vector3::new(x[0], x[1], x[2]) + q * Vector3::from(BASE_LINK);
    let (got, o) = (floats(&odom["position"]), floats(&odom["orientation"]));
    let live_q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o[0], o[1], o[2], o[3]));
    ((Vector3::new(got[0], got[1], got[2]) - p).norm(), live_q.angle_to(&q))
}
