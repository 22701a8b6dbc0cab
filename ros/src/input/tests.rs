use super::*;

fn route(topic: &str, kinds: &[SampleKind]) -> Route {
    Route { topic: topic.into(), kinds: kinds.to_vec(), sensor: 0, name: "s".into() }
}

#[test]
fn a_topics_type_is_the_first_that_gives_its_kinds() {
    let routes = [
        route("/imu/data", &[SampleKind::Imu]),
        route("/odom", &[SampleKind::Twist]),
        route("/odom", &[SampleKind::Pose]),
        route("/gps/fix", &[SampleKind::Geodetic]),
        route("/wheel", &[SampleKind::Odometry]),
    ];
    let mut overrides = BTreeMap::new();
    overrides.insert("/wheel".to_string(), "geometry_msgs/msg/TwistWithCovarianceStamped".to_string());
    let t = input_topics(&routes, &overrides).unwrap();
    let names: Vec<(&str, &str)> = t.iter().map(|t| (t.topic.as_str(), t.ty.ros)).collect();
    assert_eq!(
        names,
        [
            ("/imu/data", "sensor_msgs/msg/Imu"),
            ("/odom", "nav_msgs/msg/Odometry"),
            ("/gps/fix", "sensor_msgs/msg/NavSatFix"),
            ("/wheel", "geometry_msgs/msg/TwistWithCovarianceStamped"),
        ]
    );
    overrides.insert("/imu/data".into(), "sensor_msgs/msg/MagneticField".into());
    assert!(input_topics(&routes, &overrides).unwrap_err().contains("gives no imu sample"));
}

#[test]
fn a_message_is_checked_before_it_is_decoded() {
    let imu = TopicType::of("sensor_msgs/msg/Imu").unwrap();
    let bucket = Mutex::new(Bucket::new(2.0, 0));
    let key = format!("0/imu/data/{}/{}", imu.dds, imu.hash);
    let a = Attachment { sequence_number: 1, source_timestamp_ns: 2, gid: [3; 16] }.to_bytes();
    assert!(admit(&imu, &key, Some(&a), &bucket, 0).is_ok());
    let humble = format!("0/imu/data/{}/TypeHashNotSupported", imu.dds);
    assert!(admit(&imu, &humble, Some(&a), &bucket, 0).unwrap_err().contains("another ROS distribution"));
    let other = "0/imu/data/sensor_msgs::msg::dds_::MagneticField_/RIHS01_e80f";
    assert!(admit(&imu, other, Some(&a), &bucket, 0).unwrap_err().contains("two types on one topic"));
    assert!(admit(&imu, &key, None, &bucket, 0).unwrap_err().contains("no attachment"));
    assert!(admit(&imu, &key, Some(b"\x0fsequence_number"), &bucket, 0).unwrap_err().contains("not rmw_zenoh's"));
    // 2 a second: the second passes, the third is a flood; half a second later one more.
    assert!(admit(&imu, &key, Some(&a), &bucket, 0).is_ok());
    assert!(admit(&imu, &key, Some(&a), &bucket, 0).unwrap_err().contains("flood"));
    assert!(admit(&imu, &key, Some(&a), &bucket, 500_000_000).is_ok());
}

#[test]
fn reasons_are_bounded() {
    let s = InputStats::default();
    for i in 0..100 {
        s.refuse("/t", &format!("reason {i}"));
    }
    let c = s.counts();
    assert_eq!(c["/t"].refused.len(), MAX_REASONS + 1);
    assert_eq!(c["/t"].refused["other reasons"], 100 - MAX_REASONS as u64);
}
