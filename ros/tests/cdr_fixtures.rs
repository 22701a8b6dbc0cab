//! fusiond's ROS 2 messages against an independent encoder: `rosbags`'
//! serializer and type store (ROS 2 Jazzy) in the tests' Python environment
//! (`tests/python/cdr_fixtures.py`). What fusion-ros writes is byte for byte
//! what rosbags writes; what rosbags writes of every type fusiond reads gives
//! the samples it says; and every type hash fusiond computes is rosbags' too.

#[path = "../../daemon/tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use fusion_shared::Sample;
use fusion_shared::ros::messages::{
    Odometry, Pose, PoseWithCovariance, Quaternion, Ros2Header, Twist, TwistWithCovariance, Vector3,
};
use fusion_shared::ros::ros2::{
    Clock, DiagnosticArray, DiagnosticStatus, KeyValue, TfMessage, Transform, TransformStamped, to_cdr,
};
use fusion_shared::ros::typehash::{TYPES, type_hash};
use fusion_shared::ros::{LiveReader, Route, decode_cdr};
use fusion_shared::sample::SampleKind;

fn fixtures() -> (BTreeMap<String, String>, BTreeMap<String, Vec<u8>>) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/cdr_fixtures.py");
    let out = Command::new(common::python_venv())
        .arg(script)
        .args(TYPES.iter().map(|t| t.name))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let hashes = v["hashes"].as_object().unwrap().iter().map(|(k, v)| (k.clone(), v.as_str().unwrap().into()));
    let hex = |s: &str| (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect();
    let messages = v["messages"].as_object().unwrap().iter().map(|(k, v)| (k.clone(), hex(v.as_str().unwrap())));
    (hashes.collect(), messages.collect())
}

fn header(frame: &str) -> Ros2Header {
    Ros2Header { sec: 1432235497, nanosec: 988949113, frame_id: frame.into() }
}

fn cov6(scale: f64) -> [[f64; 6]; 6] {
    std::array::from_fn(|r| std::array::from_fn(|c| scale * (r * 6 + c + 1) as f64))
}

fn pose() -> Pose {
    Pose { position: Vector3 { x: 1.0, y: 2.0, z: 3.0 }, orientation: Quaternion { x: 0.0, y: 0.0, z: 0.6, w: 0.8 } }
}

#[test]
fn every_type_hash_is_rosbags() {
    let (hashes, _) = fixtures();
    assert_eq!(hashes.len(), TYPES.len());
    for t in TYPES {
        assert_eq!(type_hash(t.name).as_ref(), hashes.get(t.name), "{}", t.name);
    }
}

#[test]
fn what_fusion_ros_writes_is_what_rosbags_writes() {
    let (_, m) = fixtures();
    let odometry = Odometry {
        header: header("odom"),
        child_frame_id: "base_link".into(),
        pose: PoseWithCovariance { pose: pose(), covariance: cov6(0.01) },
        twist: TwistWithCovariance {
            twist: Twist { linear: Vector3 { x: 1.5, y: -0.1, z: 0.0 }, angular: Vector3 { x: 0.0, y: 0.0, z: 0.3 } },
            covariance: cov6(0.001),
        },
    };
    assert_eq!(to_cdr(&odometry), m["nav_msgs/msg/Odometry"]);
    let p = pose();
    let tf = TfMessage {
        transforms: vec![TransformStamped {
            header: header("odom"),
            child_frame_id: "base_link".into(),
            transform: Transform { translation: p.position, rotation: p.orientation },
        }],
    };
    assert_eq!(to_cdr(&tf), m["tf2_msgs/msg/TFMessage"]);
    assert_eq!(decode_cdr::<TfMessage>(&m["tf2_msgs/msg/TFMessage"]), Ok(tf));
    let diagnostics = DiagnosticArray {
        header: header(""),
        status: vec![DiagnosticStatus {
            level: 1,
            name: "fusiond: estimate".into(),
            message: "degraded: imu stale".into(),
            hardware_id: String::new(),
            values: vec![KeyValue { key: "rewinds".into(), value: "3".into() }],
        }],
    };
    assert_eq!(to_cdr(&diagnostics), m["diagnostic_msgs/msg/DiagnosticArray"]);
    let clock: Clock = decode_cdr(&m["rosgraph_msgs/msg/Clock"]).unwrap();
    assert_eq!(clock.clock.ns(), Some(1_432_235_497_988_949_113));
}

/// Each type's samples, as the live reader (the bag reader's decoder and
/// table) takes them from rosbags' bytes.
#[test]
fn what_rosbags_writes_gives_fusionds_samples() {
    let (_, m) = fixtures();
    let t_ns = 1_432_235_497_988_949_113;
    let cases: [(&str, &[SampleKind]); 7] = [
        ("sensor_msgs/msg/Imu", &[SampleKind::Imu, SampleKind::Attitude]),
        ("nav_msgs/msg/Odometry", &[SampleKind::Twist, SampleKind::Pose]),
        ("sensor_msgs/msg/NavSatFix", &[SampleKind::Geodetic]),
        ("geometry_msgs/msg/TwistWithCovarianceStamped", &[SampleKind::Odometry]),
        ("geometry_msgs/msg/PoseWithCovarianceStamped", &[SampleKind::Pose]),
        ("sensor_msgs/msg/FluidPressure", &[SampleKind::Barometer]),
        ("sensor_msgs/msg/MagneticField", &[SampleKind::Magnetometer]),
    ];
    for (ty, kinds) in cases {
        let route = Route { topic: "/t".into(), kinds: kinds.to_vec(), sensor: 4, name: "s".into() };
        let mut reader = LiveReader::new(vec![route]);
        let mut samples = Vec::new();
        reader.message("/t", ty, &m[ty], |item| samples.push(item.sample.unwrap())).unwrap();
        assert_eq!(samples.len(), kinds.len(), "{ty}");
        for s in &samples {
            assert_eq!((s.t_ns(), s.header().sensor), (t_ns, 4), "{ty}");
        }
        match &samples[0] {
            Sample::Imu(s) => assert_eq!((s.gyro_radps, s.accel_mps2), ([0.01, 0.02, 0.03], [0.1, 0.2, 9.8])),
            Sample::Twist(s) => assert_eq!((s.linear_mps, s.cov[0]), ([1.5, -0.1, 0.0], 0.001)),
            Sample::Geodetic(s) => assert_eq!((s.lat_deg, s.lon_deg, s.height_m), (48.137, 11.575, 520.5)),
            Sample::Odometry(s) => assert_eq!((s.speed_mps, s.var_m2ps2), (1.5, 0.001)),
            Sample::Pose(s) => assert_eq!((s.position_m, s.orientation_wxyz), ([1.0, 2.0, 3.0], [0.8, 0.0, 0.0, 0.6])),
            Sample::Barometer(s) => assert_eq!((s.pressure_pa, s.var_pa2), (101325.0, 4.0)),
            Sample::Magnetometer(s) => {
                assert!((s.field_ut[0] - 20.0).abs() < 1e-9 && (s.field_ut[2] + 40.0).abs() < 1e-9)
            }
            other => panic!("{ty}: {other:?}"),
        }
    }
}
