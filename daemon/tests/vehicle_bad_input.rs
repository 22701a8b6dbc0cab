//! Bad input of the vehicle sensor kinds through the `ins` engine: impossible
//! odometry, headings, magnetometer fields, twists, pressures, poses and fixes
//! (and fixes with an impossible quality), mixed
//! into a drive, are rejected with their
//! reason and counted, and the estimate after the drive is bit for bit the one of
//! the same drive without them. A linear model refuses odometry and heading at
//! start-up with a clear error.

use std::sync::Arc;

use fusion_client::sim::{
    BarometerConfig, GeodeticConfig, HeadingConfig, ImuOutput, MagnetometerConfig, OdometryConfig, PoseConfig,
    Scenario, ScenarioConfig, TwistConfig,
};
use fusion_daemon::config::{Config, InsBuilt};
use fusion_daemon::engine::{Engine, EngineConfig, Insert};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::{InsModel, N};
use fusion_daemon::validate::Rejection;
use fusion_shared::snapshot::aux;
use fusion_shared::{
    BarometerSample, GeodeticSample, HeadingSample, ImuSample, MagnetometerSample, OdometrySample, PoseSample, Sample,
    SampleKind, TwistSample, fix,
};

const INS: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
    [filter]\ninitial_state = [0, 0, 0, 10, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]\n\
    initial_covariance_diagonal = [1, 1, 1, 100, 100, 4, 0.01, 0.01, 1, 0.0025, 0.0025, 0.0025, 1e-6, 1e-6, 1e-6]\n\
    [gating]\nprobability = 0.999\n\
    [[sensor]]\nname = \"wheels\"\nid = 0\nkinds = [\"odometry\"]\nlever_arm_m = [-1.3, 0.0, -0.3]\n\
    [[sensor]]\nname = \"compass\"\nid = 0\nkinds = [\"magnetometer\"]\n\
    [sensor.magnetic]\ndeclination_deg = 3.5\ninclination_deg = 64.5\nstrength_ut = 48.5\n\
    [[sensor]]\nname = \"baro\"\nid = 0\nkinds = [\"barometer\"]\n\
    [[sensor]]\nname = \"slam\"\nid = 0\nkinds = [\"pose\"]\n";

/// The model of [`INS`]: the barometer's bias and the pose frame are its five
/// auxiliary states.
type Ins = InsModel<{ N + 5 }>;

fn engine() -> Engine<Ins> {
    let config = Config::parse(INS).unwrap();
    let InsBuilt::Aux5(model) = InsBuilt::from_config(&config).unwrap() else { unreachable!("bias and frame") };
    Engine::new(model, EngineConfig::from_config(&config))
}

/// The bad samples at time `t`, each with its reason.
fn bad(t: u64, seq: u64) -> Vec<(Sample, Rejection)> {
    let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
    let mut not_spd = cov;
    (not_spd[1], not_spd[3]) = (1.0, 1.0);
    let geodetic = |lat, lon, cov| Sample::Geodetic(GeodeticSample::new(t, 3, seq, lat, lon, 520.0, cov));
    let quality = |code, sats, hdop| {
        Sample::Geodetic(GeodeticSample::new(t, 3, seq, 48.1, 11.5, 520.0, cov).with_quality(code, sats, hdop, 1.0))
    };
    let odometry = |speed, var| Sample::Odometry(OdometrySample::new(t, 0, seq, speed, var));
    let heading = |yaw, var| Sample::Heading(HeadingSample::new(t, 0, seq, yaw, var));
    let field = |field, cov| Sample::Magnetometer(MagnetometerSample::new(t, 0, seq, field, cov));
    let twist_cov = TwistSample::diagonal_cov([0.05; 3], [0.01; 3]);
    let mut twist_not_spd = twist_cov;
    (twist_not_spd[1], twist_not_spd[6]) = (1.0, 1.0);
    let twist = |lin, ang, cov| Sample::Twist(TwistSample::new(t, 0, seq, lin, ang, cov));
    let pressure = |p, var| Sample::Barometer(BarometerSample::new(t, 0, seq, p, var));
    let pose = |q, cov| Sample::Pose(PoseSample::new(t, 0, seq, [1.0, 2.0, 0.5], q, cov, 0));
    let unit = [0.6, 0.0, 0.0, 0.8];
    vec![
        (geodetic(91.0, 11.5, cov), Rejection::OutOfRange),
        (geodetic(-90.5, 11.5, cov), Rejection::OutOfRange),
        (geodetic(48.1, 180.01, cov), Rejection::OutOfRange),
        (geodetic(48.1, -200.0, cov), Rejection::OutOfRange),
        (geodetic(f64::NAN, 11.5, cov), Rejection::NonFinite),
        (geodetic(48.1, 11.5, not_spd), Rejection::CovarianceNotPositiveDefinite),
        // The receiver's quality: a fix type out of range, negative satellites, NaN HDOP.
        (quality(7, 12, 0.9), Rejection::OutOfRange),
        (quality(fix::THREE_D, -1, 0.9), Rejection::OutOfRange),
        (quality(fix::THREE_D, 12, f64::NAN), Rejection::NonFinite),
        (quality(fix::RTK_FIXED, 12, -0.5), Rejection::OutOfRange),
        (odometry(10.0, -0.01), Rejection::VarianceNotPositive),
        (odometry(f64::NAN, 0.01), Rejection::NonFinite),
        (odometry(1e5, 0.01), Rejection::OutOfRange),
        (heading(1e9, 1e-4), Rejection::OutOfRange),
        (heading(f64::INFINITY, 1e-4), Rejection::NonFinite),
        (heading(0.3, 0.0), Rejection::VarianceNotPositive),
        (field([20.0, f64::NAN, -43.0], cov), Rejection::NonFinite),
        (field([2000.0, 0.0, 0.0], cov), Rejection::OutOfRange),
        (field([20.0, 1.0, -43.0], not_spd), Rejection::CovarianceNotPositiveDefinite),
        (twist([10.0, f64::NAN, 0.0], [0.0; 3], twist_cov), Rejection::NonFinite),
        (twist([10.0, 0.0, 0.0], [0.0, 0.0, 100.0], twist_cov), Rejection::OutOfRange),
        (twist([10.0, 0.0, 0.0], [0.0; 3], twist_not_spd), Rejection::CovarianceNotPositiveDefinite),
        (pressure(0.0, 4.0), Rejection::OutOfRange),
        (pressure(-101_325.0, 4.0), Rejection::OutOfRange),
        (pressure(f64::NAN, 4.0), Rejection::NonFinite),
        (pressure(95_000.0, 0.0), Rejection::VarianceNotPositive),
        (pose([1.0, 0.0, 0.0, 0.1], twist_cov), Rejection::OutOfRange),
        (pose([0.0; 4], twist_cov), Rejection::OutOfRange),
        (pose([f64::NAN, 0.0, 0.0, 0.8], twist_cov), Rejection::NonFinite),
        (pose(unit, twist_not_spd), Rejection::CovarianceNotPositiveDefinite),
        (Sample::Imu(ImuSample::new(t, 0, seq, [f64::NAN, 0.0, 9.8], [0.0; 3])), Rejection::NonFinite),
    ]
}

#[test]
fn impossible_vehicle_samples_are_rejected_counted_and_change_nothing() {
    let mut c =
        ScenarioConfig { seed: 9, duration_s: 10.0, imu_output: ImuOutput::BodySpecificForce, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.position.rate_hz = 0.0;
    c.aiding.push(Arc::new(GeodeticConfig::default()));
    c.aiding.push(Arc::new(OdometryConfig::default()));
    c.aiding.push(Arc::new(HeadingConfig::default()));
    c.aiding.push(Arc::new(MagnetometerConfig::default()));
    c.aiding.push(Arc::new(TwistConfig::default()));
    c.aiding.push(Arc::new(BarometerConfig::default()));
    c.aiding.push(Arc::new(PoseConfig::default()));
    let samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let (mut clean, mut dirty) = (engine(), engine());
    let mut expected = [0u64; SampleKind::COUNT];
    for (i, s) in samples.iter().enumerate() {
        clean.insert(s, None, &mut |_| {});
        dirty.insert(s, None, &mut |_| {});
        // Every 200th sample, the whole set of bad ones at its time (their own
        // sequence numbers, so none is taken for a duplicate).
        if i % 200 == 100 {
            for (b, why) in bad(s.t_ns(), 1_000_000 + i as u64) {
                assert_eq!(dirty.insert(&b, None, &mut |_| {}), Insert::Rejected(why), "{b:?}");
                expected[b.kind().index()] += 1;
            }
        }
    }
    assert!(expected.iter().sum::<u64>() > 100);
    let (a, b) = (clean.latest().unwrap(), dirty.latest().unwrap());
    assert_eq!(a.state, b.state, "the estimate is untouched");
    assert_eq!(clean.model().frames().datum(), dirty.model().frames().datum());
    for &k in SampleKind::ALL {
        assert_eq!(dirty.totals(Some(k)).invalid, expected[k.index()], "{}", k.name());
        assert_eq!(clean.totals(Some(k)).invalid, 0);
    }
    // The good samples of the new kinds were fused.
    assert!(clean.totals(Some(SampleKind::Odometry)).fused > 300);
    assert!(clean.totals(Some(SampleKind::Heading)).fused > 30);
    assert!(clean.totals(Some(SampleKind::Magnetometer)).fused > 150);
    assert!(clean.totals(Some(SampleKind::Twist)).fused > 100);
    assert!(clean.totals(Some(SampleKind::Barometer)).fused > 150);
    assert!(clean.totals(Some(SampleKind::Pose)).fused > 50);
}

#[test]
fn the_linear_model_refuses_odometry_heading_and_mounts_at_start_up() {
    let linear = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
        initial_covariance_diagonal = [1,1,1,1,1,1]\n";
    let err = |sensor: &str| Config::parse(&format!("{linear}[[sensor]]\n{sensor}")).unwrap_err().to_string();
    assert!(err("name = \"wheels\"\nid = 0\nkinds = [\"odometry\"]\n").contains("cannot fuse odometry"));
    assert!(err("name = \"compass\"\nid = 0\nkinds = [\"heading\"]\n").contains("cannot fuse heading"));
    let magnetometer = "name = \"mag\"\nid = 0\nkinds = [\"magnetometer\"]\n\
        [sensor.magnetic]\ndeclination_deg = 3.5\ninclination_deg = 64.5\nstrength_ut = 48.5\n";
    assert!(err(magnetometer).contains("cannot fuse magnetometer"));
    assert!(err("name = \"vio\"\nid = 0\nkinds = [\"twist\"]\n").contains("cannot fuse twist"));
    assert!(err("name = \"baro\"\nid = 0\nkinds = [\"barometer\"]\n").contains("cannot fuse barometer"));
    assert!(err("name = \"slam\"\nid = 0\nkinds = [\"pose\"]\n").contains("cannot fuse pose"));
    assert!(
        err("name = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\nlever_arm_m = [1, 0, 1]\n")
            .contains("no rotation or lever arm")
    );
    assert!(err("name = \"imu\"\nid = 0\nkinds = [\"imu\"]\naxes = \"frd\"\n").contains("no rotation or lever arm"));
    Config::parse(&format!("{linear}[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\n")).unwrap();
}

/// What an `ins` config cannot have: more auxiliary states than a snapshot
/// carries (six: two estimated map frames, or three barometers beside one),
/// a half-configured frame, a `[sensor.pose]` on another kind. Several
/// barometers each have their bias.
#[test]
fn the_ins_model_refuses_what_its_states_cannot_hold_at_start_up() {
    let ins = INS.split("[[sensor]]").next().unwrap();
    let err = |sensors: &str| Config::parse(&format!("{ins}{sensors}")).unwrap_err().to_string();
    let baro = |id| format!("[[sensor]]\nname = \"baro{id}\"\nid = {id}\nkinds = [\"barometer\"]\n");
    let pose = |id, table: &str| format!("[[sensor]]\nname = \"slam{id}\"\nid = {id}\nkinds = [\"pose\"]\n{table}");
    let two = Config::parse(&format!("{ins}{}{}", baro(0), baro(1))).unwrap();
    let InsBuilt::Aux2(model) = InsBuilt::from_config(&two).unwrap() else { panic!("a bias per barometer") };
    let bit = |id| model.aux().first_bit(fusion_shared::SampleKind::Barometer, id);
    assert_eq!((bit(0), bit(1)), (Some(aux::BARO_BIAS), Some(aux::BARO_BIASES[1])));
    let budget = "a snapshot carries at most 6";
    assert!(err(&(pose(0, "") + &pose(1, ""))).contains(budget), "{}", err(&(pose(0, "") + &pose(1, ""))));
    let crowded = pose(0, "") + &baro(1) + &baro(2) + &baro(3);
    assert!(err(&crowded).contains("brings 7 auxiliary states (3 barometer bias"), "{}", err(&crowded));
    assert!(err(&crowded).contains("\"baro3\": the configuration brings"), "the first beyond: {}", err(&crowded));
    Config::parse(&format!("{ins}{}{}{}", pose(0, ""), baro(1), baro(2))).unwrap();
    let half = "[sensor.pose]\nframe_yaw_deg = 30\n";
    assert!(err(&pose(0, half)).contains("frame_origin_m"), "{}", err(&pose(0, half)));
    let on_gnss = "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\"]\n[sensor.pose]\nrelative = true\n";
    assert!(err(on_gnss).contains("applies to a pose sensor"));
    // A configured frame beside an estimated one is fine: only one is states.
    let fixed = "[sensor.pose]\nframe_yaw_deg = 30\nframe_origin_m = [1, 2, 3]\n";
    let config = Config::parse(&format!("{ins}{}{}", pose(0, ""), pose(1, fixed))).unwrap();
    assert!(matches!(InsBuilt::from_config(&config).unwrap(), InsBuilt::Aux4(_)));
}
