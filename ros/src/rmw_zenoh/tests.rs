use super::*;

const ODOMETRY_HASH: &str = "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0";
const IMU_HASH: &str = "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b";

fn node() -> Node {
    Node {
        domain: 0,
        zid: "a1b2c3d4e5f60718293a4b5c6d7e8f90".into(),
        id: 0,
        enclave: "/".into(),
        namespace: "/".into(),
        name: "fusiond".into(),
    }
}

#[test]
fn data_keys_lose_the_leading_slash() {
    let odom = TopicType::of("nav_msgs/msg/Odometry").unwrap();
    assert_eq!(
        topic_key(0, "/odometry/filtered", &odom),
        format!("0/odometry/filtered/nav_msgs::msg::dds_::Odometry_/{ODOMETRY_HASH}")
    );
    assert_eq!(topic_key_any_type(7, "/imu/data"), "7/imu/data/*/*");
    let key = format!("0/imu/data/sensor_msgs::msg::dds_::Imu_/{IMU_HASH}");
    assert_eq!(key_type(&key), Some(("sensor_msgs::msg::dds_::Imu_", IMU_HASH)));
    assert_eq!(TopicType::of_dds("sensor_msgs::msg::dds_::Imu_").map(|t| t.ros), Some("sensor_msgs/msg/Imu"));
    assert_eq!(TopicType::of_dds("sensor_msgs::msg::dds_::Image_"), None);
}

#[test]
fn tokens_are_rmw_zenohs() {
    let n = node();
    assert_eq!(n.token(), "@ros2_lv/0/a1b2c3d4e5f60718293a4b5c6d7e8f90/0/0/NN/%/%/fusiond");
    let odom = TopicType::of("nav_msgs/msg/Odometry").unwrap();
    assert_eq!(
        n.endpoint_token(3, EntityKind::Publisher, "/odometry/filtered", &odom, Qos::DEFAULT),
        format!(
            "@ros2_lv/0/a1b2c3d4e5f60718293a4b5c6d7e8f90/0/3/MP/%/%/fusiond/%odometry%filtered/\
             nav_msgs::msg::dds_::Odometry_/{ODOMETRY_HASH}/::,10:,:,:,,"
        )
    );
    let imu = TopicType::of("sensor_msgs/msg/Imu").unwrap();
    let robot = Node { namespace: "/robot".into(), ..node() };
    assert_eq!(
        robot.endpoint_token(1, EntityKind::Subscription, "/imu/data", &imu, Qos::SENSOR_DATA),
        format!(
            "@ros2_lv/0/a1b2c3d4e5f60718293a4b5c6d7e8f90/0/1/MS/%/%robot/fusiond/%imu%data/\
             sensor_msgs::msg::dds_::Imu_/{IMU_HASH}/2::,5:,:,:,,"
        )
    );
}

/// Each field only where it differs from rmw_zenoh's default (reliable,
/// volatile, keep-last 42): its default is all empty fields.
#[test]
fn qos_fields_are_written_only_where_they_differ() {
    assert_eq!(Qos { reliable: true, transient_local: false, depth: DEFAULT_DEPTH }.keyexpr(), "::,:,:,:,,");
    assert_eq!(Qos { reliable: true, transient_local: true, depth: 1 }.keyexpr(), ":1:,1:,:,:,,");
    assert_eq!(Qos::TF.keyexpr(), "::,100:,:,:,,");
}

/// Sequence number and source time (i64, little endian), then the GID after
/// its length byte 0x10: 33 bytes.
#[test]
fn attachments_are_33_bytes() {
    let gid: [u8; 16] = std::array::from_fn(|i| i as u8 + 1);
    let a = Attachment { sequence_number: 5, source_timestamp_ns: 1_700_000_000_123_456_789, gid };
    let bytes = a.to_bytes();
    let mut expected = 5i64.to_le_bytes().to_vec();
    expected.extend_from_slice(&1_700_000_000_123_456_789i64.to_le_bytes());
    expected.push(0x10);
    expected.extend_from_slice(&gid);
    assert_eq!(bytes, expected);
    assert_eq!(Attachment::from_bytes(&bytes), Ok(a));
    assert!(Attachment::from_bytes(&bytes[..20]).is_err());
    let mut long = bytes.clone();
    long.push(0);
    assert!(Attachment::from_bytes(&long).is_err());
    // Jazzy ≤ 0.2.3's labelled attachment is not this format.
    assert!(Attachment::from_bytes(b"\x0fsequence_number\x011").is_err());
}

/// XXH3-128 of the token, low half first (XXH3's published test vector: the
/// empty input hashes to 0x99aa06d3014798d86001c324468d497f).
#[test]
fn gids_are_the_tokens_hash() {
    let g = gid("");
    assert_eq!(u64::from_le_bytes(g[..8].try_into().unwrap()), 0x6001c324468d497f);
    assert_eq!(u64::from_le_bytes(g[8..].try_into().unwrap()), 0x99aa06d3014798d8);
    assert_ne!(gid(&node().token()), gid(""));
}
