use super::*;
use crate::measurement::Kinds;
use crate::measurement::magnetometer::field::EarthField;

fn sensor(name: &str, id: u32, kinds: &[&str]) -> SensorConfig {
    SensorConfig {
        name: name.into(),
        id,
        kinds: kinds.iter().map(|k| k.to_string()).collect(),
        axes: Axes::Flu,
        rotation_rpy_deg: [0.0; 3],
        lever_arm_m: [0.0; 3],
        time_offset_ns: 0,
        topic: None,
        tables: toml::Table::new(),
    }
}

/// An FRD IMU turned 90° to the left: its x axis is the body's y axis, its y
/// axis (right) the body's x axis, its z axis (down) the body's −z.
#[test]
fn frd_then_yaw_maps_sensor_axes_into_the_body() {
    let m = Mount::new(Axes::Frd, [0.0, 0.0, 90f64.to_radians()], [0.0; 3]);
    let body = |v: [f64; 3]| m.rotation * Vector3::from(v);
    assert!((body([1.0, 0.0, 0.0]) - Vector3::new(0.0, 1.0, 0.0)).amax() < 1e-15);
    assert!((body([0.0, 1.0, 0.0]) - Vector3::new(1.0, 0.0, 0.0)).amax() < 1e-15);
    assert!((body([0.0, 0.0, 1.0]) - Vector3::new(0.0, 0.0, -1.0)).amax() < 1e-15);
    assert!(!m.unrotated && m.at_origin);
    assert!(Mount::new(Axes::Flu, [0.0; 3], [0.0; 3]).unrotated);
    // Roll 90°: the sensor's y axis is the body's z axis.
    let r = Mount::new(Axes::Flu, [90f64.to_radians(), 0.0, 0.0], [0.0; 3]);
    assert!((r.rotation * Vector3::y() - Vector3::z()).amax() < 1e-15);
}

#[test]
fn mounts_are_found_by_kind_and_id_and_checked() {
    let mut gnss = sensor("gnss", 3, &["geodetic", "velocity"]);
    gnss.lever_arm_m = [1.2, 0.0, 1.0];
    let mut imu = sensor("imu-b", 1, &["imu"]);
    imu.axes = Axes::Frd;
    let f = Frames::from_config(
        None,
        &[gnss.clone(), sensor("imu-a", 0, &["imu"]), imu.clone()],
        ImuConfig::default(),
        &Kinds,
    )
    .unwrap();
    assert_eq!(f.mount(SampleKind::Velocity, 3).lever_arm, Vector3::new(1.2, 0.0, 1.0));
    assert_eq!(f.mount(SampleKind::Geodetic, 3).lever_arm, Vector3::new(1.2, 0.0, 1.0));
    assert_eq!(f.mount(SampleKind::Geodetic, 4), &Mount::IDENTITY);
    assert_eq!((f.imus().index(0), f.imus().index(1), f.imus().index(7)), (Some(0), Some(1), None));
    let named = |kind, id| f.sensors().iter().find(|m| m.kind == kind && m.id == id).map(|m| m.name.as_str());
    assert_eq!((named(SampleKind::Imu, 1), named(SampleKind::Velocity, 3)), (Some("imu-b"), Some("gnss")));
    assert_eq!(Frames::new(None).imus().index(42), Some(0), "no IMU configured: any id is the IMU");

    let err = |sensors: &[SensorConfig]| {
        Frames::from_config(None, sensors, ImuConfig::default(), &Kinds).unwrap_err().to_string()
    };
    assert!(err(&[gnss.clone(), gnss.clone()]).contains("configured twice"));
    assert!(err(&[sensor("x", 0, &["lidar"])]).contains("unknown kind \"lidar\""));
    assert!(err(&[sensor("x", 0, &[])]).contains("names no kind"));
    let mut rotated_gnss = gnss.clone();
    rotated_gnss.rotation_rpy_deg = [0.0, 0.0, 10.0];
    let said = err(&[rotated_gnss]);
    assert!(said.contains("own axes (imu, magnetometer, twist, pose, attitude), not to geodetic"), "{said}");
    let mut imu_arm = imu.clone();
    imu_arm.lever_arm_m = [0.1, 0.0, 0.0];
    assert!(err(&[imu_arm]).contains("body origin"));
    let mut far = gnss.clone();
    far.lever_arm_m = [f64::NAN, 0.0, 0.0];
    assert!(err(&[far]).contains("lever_arm_m"));
    let many: Vec<SensorConfig> = (0..=MAX_IMUS as u32).map(|i| sensor("i", i, &["imu"])).collect();
    assert!(err(&many).contains("at most"));
    // A magnetometer: rotated like an IMU, with the Earth's field, which no
    // other kind takes.
    let mut mag = sensor("compass", 2, &["magnetometer"]);
    assert!(err(std::slice::from_ref(&mag)).contains("needs the Earth's field"));
    let field = |strength: f64| {
        let table = format!("declination_deg = 3.5\ninclination_deg = 64.5\nstrength_ut = {strength}\n");
        toml::Table::from_iter([("magnetic".to_string(), toml::Value::Table(table.parse().unwrap()))])
    };
    (mag.axes, mag.rotation_rpy_deg, mag.tables) = (Axes::Frd, [0.0, 0.0, 90.0], field(48.5));
    let f = Frames::from_config(None, std::slice::from_ref(&mag), ImuConfig::default(), &Kinds).unwrap();
    let earth = |id| f.settings::<EarthField>(SampleKind::Magnetometer, id);
    assert!((earth(2).unwrap().world_ut.norm() - 48.5).abs() < 1e-12);
    assert!(earth(3).is_none());
    assert!(f.settings::<()>(SampleKind::Magnetometer, 2).is_none(), "typed: the kind's own type only");
    assert!(!f.mount(SampleKind::Magnetometer, 2).unrotated);
    let mut gnss_field = gnss.clone();
    gnss_field.tables = field(48.5);
    assert!(err(&[gnss_field]).contains("applies to a magnetometer sensor"));
    let mut typo = gnss.clone();
    typo.tables = toml::Table::from_iter([("lever_arm".to_string(), toml::Value::Integer(1))]);
    let said = err(&[typo]);
    assert!(
        said.contains("lever_arm: unknown key; a [[sensor]] has name, id,") && said.contains(", quality,"),
        "{said}"
    );
    mag.tables = field(-1.0);
    assert!(err(&[mag]).contains("sensor[0] (\"compass\").magnetic.strength_ut"));
}

#[test]
fn time_offsets_are_per_sensor_and_bounded() {
    let mut gnss = sensor("gnss", 3, &["geodetic", "velocity"]);
    gnss.time_offset_ns = 80_000_000;
    let f =
        Frames::from_config(None, &[gnss.clone(), sensor("imu", 0, &["imu"])], ImuConfig::default(), &Kinds).unwrap();
    assert_eq!(f.time_offset_ns(SampleKind::Geodetic, 3), 80_000_000);
    assert_eq!(f.time_offset_ns(SampleKind::Velocity, 3), 80_000_000, "one receiver, one clock");
    assert_eq!(f.time_offset_ns(SampleKind::Imu, 0), 0);
    assert_eq!(f.time_offset_ns(SampleKind::Geodetic, 4), 0, "not configured");
    gnss.time_offset_ns = -20_000_000;
    let early = Frames::from_config(None, std::slice::from_ref(&gnss), ImuConfig::default(), &Kinds).unwrap();
    assert_eq!(early.time_offset_ns(SampleKind::Geodetic, 3), -20_000_000);
    for absurd in [MAX_TIME_OFFSET_NS + 1, -MAX_TIME_OFFSET_NS - 1, i64::MIN] {
        gnss.time_offset_ns = absurd;
        let e = Frames::from_config(None, std::slice::from_ref(&gnss), ImuConfig::default(), &Kinds).unwrap_err();
        assert!(e.to_string().contains("time_offset_ns") && e.to_string().contains("10 s"), "{e}");
    }
}
