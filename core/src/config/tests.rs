//! The config parser's unit tests.

use super::*;

#[test]
fn print_config_is_the_defaults() {
    let text = default_config_text();
    assert_eq!(Config::parse(&text).unwrap(), Config::default());
    for &k in SampleKind::ALL {
        assert!(text.contains(&format!("\n{}_timeout_ns = ", k.name())), "{text}");
    }
    assert!(!text.contains('{'), "every placeholder is filled: {text}");
    assert!(text.contains("position_timeout_ns = 1_000_000_000\n"), "{text}");
    assert_eq!(
        (grouped(7), grouped(100), grouped(1000), grouped(100_000_000)),
        ("7".into(), "100".into(), "1_000".into(), "100_000_000".into())
    );
}

fn err(text: &str) -> String {
    Config::parse(text).unwrap_err().to_string()
}

const MIN: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\ninitial_covariance_diagonal = [1,1,1,1,1,1]\n";

#[test]
fn gating_is_off_without_its_table_and_defaults_apply() {
    let c = Config::parse(MIN).unwrap();
    assert!(c.gating.is_none());
    assert_eq!(c.filter.history_capacity, 4096);
    assert_eq!(c.validation, ValidationConfig::default());
    assert_eq!(c.health, HealthConfig::default());
}

#[test]
fn errors_name_the_key() {
    assert!(err(&format!("{MIN}bogus = 1\n")).contains("bogus"));
    assert!(err(&MIN.replace("accel_noise_std = 0.3", "accel_noise_sd = 0.3")).contains("accel_noise_sd"));
    assert!(err(&MIN.replace("0.3", "-1")).contains("model.accel_noise_std"));
    assert!(err(&MIN.replace("\"linear\"", "\"kalman\"")).contains("kalman"));
    assert!(err(&MIN.replace("[0,0,0,0,0,0]", "[0,0,0]")).contains("filter.initial_state"));
    assert!(err(&MIN.replace("[1,1,1,1,1,1]", "[1,1,1,1,1,0]")).contains("filter.initial_covariance_diagonal"));
    assert!(err(&format!("{MIN}[gating]\nprobability = 1.5\n")).contains("gating.probability"));
    assert!(err(&format!("{MIN}history_ns = 0\n")).contains("filter.history_ns"));
    assert!(err(&format!("{MIN}[validation]\nmax_sensors = 0\n")).contains("validation.max_sensors"));
    // More sensors than a snapshot has rows for would be tracked but not shown.
    assert!(err(&format!("{MIN}[validation]\nmax_sensors = 17\n")).contains("rows of a snapshot"));
    assert!(err(&format!("{MIN}[validation]\nmax_rate_hz = 0.0\n")).contains("validation.max_rate_hz"));
    assert!(err(&format!("{MIN}[validation]\nmax_burst = 0\n")).contains("validation.max_burst"));
    assert!(err(&format!("{MIN}[health]\nnis_window = 0\n")).contains("health.nis_window"));
    assert!(err(&format!("{MIN}[health]\nimu_timeout = 5\n")).contains("health.imu_timeout"));
    assert!(err(&format!("{MIN}[health]\nlidar_timeout_ns = 5\n")).contains("velocity_timeout_ns"));
    assert!(err(&format!("{MIN}[health]\nvelocity_timeout_ns = 0\n")).contains("health.velocity_timeout_ns"));
    assert!(err(&format!("{MIN}[alignment]\nstatic_samples = 5\n")).contains("[model.alignment]"));
    assert!(err(&format!("{MIN}[model.alignment]\nstatic_samples = 5\n")).contains("alignment"));
}

#[test]
fn health_timeouts_are_per_kind() {
    let c = Config::parse(&format!("{MIN}[health]\nvelocity_timeout_ns = 7\n")).unwrap();
    assert_eq!(c.health.timeout_ns(SampleKind::Velocity), 7);
    assert_eq!(c.health.timeout_ns(SampleKind::Imu), 100_000_000);
}

const INS: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[model.alignment]\nstatic_samples = 400\n\
    [filter]\ninitial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
    initial_covariance_diagonal = [1,1,1, 1,1,1, 0.1,0.1,0.1, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n";

#[test]
fn ins_config_uses_kalibr_names() {
    let c = Config::parse(INS).unwrap();
    let ModelConfig::Ins(p) = &c.model else { panic!() };
    assert_eq!((p.gyroscope_random_walk, p.gravity_mps2), (1e-5, 9.80665));
    assert_eq!(p.alignment.map(|a| a.static_samples), Some(400));
    assert!(err(&INS.replace("1,0,0,0, 0,0,0", "2,0,0,0, 0,0,0")).contains("quaternion"));
    assert!(err(&INS.replace("gyroscope_random_walk = 1.0e-5\n", "")).contains("gyroscope_random_walk"));
    assert!(err(&INS.replace("1e-6,1e-6,1e-6]", "1e-6,1e-6]")).contains("needs 15 values"));
    assert_eq!(p.constraints, None, "the motion constraint is opt-in");
    let with = |table: &str| Config::parse(&INS.replace("[filter]", &format!("[model.constraints]\n{table}[filter]")));
    let ModelConfig::Ins(p) = with("nonholonomic_std_mps = 0.2\n").unwrap().model.clone() else { panic!() };
    let nhc = p.constraints.unwrap();
    assert_eq!((nhc.std_mps, nhc.interval_ns, nhc.min_speed_mps, nhc.lever_arm_m), (0.2, 50_000_000, 0.0, [0.0; 3]));
    assert!(
        with("nonholonomic_std_mps = 0.1\nnonholonomic_lever_arm_m = [0, nan, 0]\n")
            .unwrap_err()
            .to_string()
            .contains("nonholonomic_lever_arm_m")
    );
    let bad = |table: &str| with(table).unwrap_err().to_string();
    assert!(bad("nonholonomic_std_mps = 0\n").contains("model.constraints.nonholonomic_std_mps"));
    assert!(bad("nonholonomic_std_mps = 0.1\nnonholonomic_min_speed_mps = -1\n").contains("min_speed"));
    assert!(err(&format!("{MIN}[constraints]\nnonholonomic_std_mps = 0.1\n")).contains("[model.constraints]"));
    assert!(err(&INS.replace("kind = \"ins\"", "kind = \"ins\"\naccel_noise_std = 1")).contains("accel_noise_std"));
    // The heading from the course over ground: opt-in, checked, with or without a
    // static alignment.
    let course = |keys: &str| {
        let c = Config::parse(&INS.replace("static_samples = 400\n", keys))?;
        let crate::config::InsBuilt::Core(m) = crate::config::InsBuilt::from_config(&c)? else { panic!("15 states") };
        Ok::<_, ConfigError>(m.course_alignment().copied())
    };
    assert_eq!(course("static_samples = 400\n").unwrap(), None);
    let on = course("heading_from_velocity_mps = 3.0\n").unwrap().unwrap();
    assert_eq!(on.min_speed_mps, 3.0);
    assert!((on.sideslip_std_rad - 2f64.to_radians()).abs() < 1e-15);
    let slip = course("heading_from_velocity_mps = 5\nheading_sideslip_std_deg = 0\n").unwrap().unwrap();
    assert_eq!((slip.min_speed_mps, slip.sideslip_std_rad), (5.0, 0.0));
    let bad = |keys: &str| course(keys).unwrap_err().to_string();
    assert!(bad("heading_from_velocity_mps = 0.0\n").contains("model.alignment.heading_from_velocity_mps"));
    assert!(bad("heading_from_velocity_mps = nan\n").contains("model.alignment.heading_from_velocity_mps"));
    let slip = bad("heading_from_velocity_mps = 3.0\nheading_sideslip_std_deg = -1\n");
    assert!(slip.contains("model.alignment.heading_sideslip_std_deg"), "{slip}");
    assert!(err("[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n").contains("filter"));
}

#[test]
fn standstill_is_opt_in_with_defaults_and_refuses_absurd_values() {
    use crate::model::ins::Standstill;
    let ModelConfig::Ins(p) = &Config::parse(INS).unwrap().model else { panic!() };
    assert_eq!(p.standstill, None, "standstill is opt-in");
    let with = |table: &str| Config::parse(&INS.replace("[filter]", &format!("[model.standstill]\n{table}[filter]")));
    let ModelConfig::Ins(p) = with("").unwrap().model.clone() else { panic!() };
    assert_eq!(p.standstill, Some(Standstill::default()));
    let ModelConfig::Ins(p) = with("window_ns = 500_000_000\nvelocity_std_mps = 0.02\n").unwrap().model.clone() else {
        panic!()
    };
    let tuned = p.standstill.unwrap();
    assert_eq!((tuned.window_ns, tuned.velocity_std_mps, tuned.imu_threshold), (500_000_000, 0.02, 3.0));
    let bad = |table: &str| with(table).unwrap_err().to_string();
    assert!(bad("window_ns = 1000\n").contains("model.standstill.window_ns"));
    assert!(bad("window_ns = 100_000_000_000\n").contains("model.standstill.window_ns"));
    assert!(bad("imu_threshold = 0\n").contains("model.standstill.imu_threshold"));
    assert!(bad("imu_threshold = nan\n").contains("model.standstill.imu_threshold"));
    assert!(bad("velocity_std_mps = -0.1\n").contains("model.standstill.velocity_std_mps"));
    assert!(bad("max_speed_mps = -1\n").contains("model.standstill.max_speed_mps"));
    assert!(bad("odometry_speed_mps = inf\n").contains("model.standstill.odometry_speed_mps"));
    assert!(bad("zupt = true\n").contains("zupt"), "unknown keys are errors");
}

/// `[model.gravity]`: its figures where the gravity reference is on (the
/// defaults without the table), each absurd value refused by its key.
#[test]
fn the_gravity_reference_takes_its_figures_and_refuses_absurd_ones() {
    use crate::model::ins::GravityReference;
    let with = |table: &str| Config::parse(&INS.replace("[filter]", &format!("[model.gravity]\n{table}[filter]")));
    let ModelConfig::Ins(p) = with("window_ns = 200_000_000\n").unwrap().model.clone() else { panic!() };
    assert_eq!(p.gravity, Some(GravityReference { window_ns: 200_000_000, ..GravityReference::default() }));
    let bad = |table: &str| with(table).unwrap_err().to_string();
    assert!(bad("window_ns = 1000\n").contains("model.gravity.window_ns"));
    assert!(bad("max_deviation_mps2 = 0\n").contains("model.gravity.max_deviation_mps2"));
    assert!(bad("variance_threshold = nan\n").contains("model.gravity.variance_threshold"));
    assert!(bad("acceleration_std_mps2 = -1\n").contains("model.gravity.acceleration_std_mps2"));
    assert!(bad("enabled = true\n").contains("enabled"), "unknown keys are errors");
}

#[test]
fn the_odometry_scale_state_is_opt_in_with_defaults_and_refuses_absurd_values() {
    use crate::config::InsBuilt;
    use crate::model::ins::OdometryScale;
    let config = Config::parse(INS).unwrap();
    let ModelConfig::Ins(p) = &config.model else { panic!() };
    assert_eq!(p.odometry_scale, None, "opt-in");
    assert!(matches!(InsBuilt::from_config(&config).unwrap(), InsBuilt::Core(_)), "15 states without it");
    let with =
        |table: &str| Config::parse(&INS.replace("[filter]", &format!("[model.odometry_scale]\n{table}[filter]")));
    let config = with("").unwrap();
    let ModelConfig::Ins(p) = &config.model else { panic!() };
    assert_eq!(p.odometry_scale, Some(OdometryScale::default()));
    let scaled = InsBuilt::from_config(&config).unwrap().scaled().expect("16 states with it");
    let s = crate::model::Model::initial_state(&scaled);
    assert_eq!(s.filter().variance(crate::model::ins::N), 0.02 * 0.02);
    assert_eq!(s.odometry_scale(), Some(1.0));
    assert!(crate::model::ins::InsModel::from_config(&config).is_err(), "not a 15-state model");
    let tuned = with("initial = 1.01\ninitial_std = 0.005\n").unwrap();
    let ModelConfig::Ins(p) = &tuned.model else { panic!() };
    assert_eq!(p.odometry_scale.map(|k| (k.initial, k.initial_std, k.random_walk)), Some((1.01, 0.005, 1e-5)));
    let bad = |table: &str| with(table).unwrap_err().to_string();
    assert!(bad("initial = 0\n").contains("model.odometry_scale.initial"));
    assert!(bad("initial = nan\n").contains("model.odometry_scale.initial"));
    assert!(bad("initial_std = 0\n").contains("model.odometry_scale.initial_std"));
    assert!(bad("initial_std = 3\n").contains("model.odometry_scale.initial_std"));
    assert!(bad("random_walk = -1e-5\n").contains("model.odometry_scale.random_walk"));
    assert!(bad("random_walk = inf\n").contains("model.odometry_scale.random_walk"));
    assert!(bad("scale = 1\n").contains("scale"), "unknown keys are errors");
}

#[test]
fn lockout_recovery_is_on_with_the_gate_and_can_be_tuned_or_turned_off() {
    use crate::model::lockout::LockoutConfig;
    assert_eq!(Config::parse(MIN).unwrap().lockout, None, "no gate, nothing to be locked out by");
    let gated = |extra: &str| Config::parse(&format!("{MIN}[gating]\nprobability = 0.99\n{extra}"));
    assert_eq!(gated("").unwrap().lockout, Some(LockoutConfig::default()));
    let tuned = gated("lockout_ns = 2_000_000_000\nlockout_fixes = 3\n").unwrap().lockout;
    assert_eq!(tuned, Some(LockoutConfig { after_ns: 2_000_000_000, fixes: 3 }));
    assert_eq!(gated("lockout_ns = 0\n").unwrap().lockout, None);
    assert!(gated("lockout_fixes = 1\n").unwrap_err().to_string().contains("gating.lockout_fixes"));
}

#[test]
fn a_receivers_quality_table_reaches_its_geodetic_fixes_and_nothing_else() {
    use fusion_shared::{GeodeticSample, fix};
    let gnss = "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"geodetic\", \"velocity\"]\n\
                [sensor.quality]\nrefuse = [\"none\", \"2d\"]\n\
                [sensor.quality.horizontal_floor_m]\nrtk_float = 0.3\n\"3d\" = 1.5\n";
    let config = Config::parse(&format!("{INS}{gnss}")).unwrap();
    let BuiltModel::Ins(crate::config::InsBuilt::Core(m)) = config.built() else { panic!() };
    let frames = crate::model::Model::frames(m);
    let cov = [0.0025, 0.0, 0.0, 0.0, 0.0025, 0.0, 0.0, 0.0, 0.01];
    let f = |code| GeodeticSample::new(0, 3, 0, 48.1, 11.5, 500.0, cov).with_quality(code, 12, 0.9, 1.4);
    let quality = |id| crate::measurement::settings::<GeodeticSample>(frames, id).copied().unwrap_or_default();
    let q = quality(3);
    assert!(q.noise(&f(fix::TWO_D)).is_err() && q.noise(&f(fix::NONE)).is_err());
    assert!((q.noise(&f(fix::RTK_FLOAT)).unwrap()[0] - 0.09).abs() < 1e-12);
    assert_eq!(q.noise(&f(fix::RTK_FIXED)).unwrap(), cov);
    // Another receiver without a table: fused as reported, no fix refused.
    let other = quality(4);
    assert_eq!(other.noise(&f(fix::TWO_D)).unwrap(), cov);
    assert!(other.noise(&f(fix::NONE)).is_err());
    // Only a geodetic sensor has a quality.
    let wheels = "[[sensor]]\nname = \"wheels\"\nid = 0\nkinds = [\"odometry\"]\n[sensor.quality]\n";
    assert!(err(&format!("{INS}{wheels}")).contains("quality"));
    let bad = gnss.replace("\"2d\"]", "\"rtk\"]");
    assert!(err(&format!("{INS}{bad}")).contains("quality.refuse"));
}

#[test]
fn an_unknown_key_in_the_model_table_is_reported_at_its_own_line() {
    let text = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\nbogus = 1\n\n[filter]\n\
                initial_state = [0, 0, 0, 0, 0, 0]\ninitial_covariance_diagonal = [1, 1, 1, 1, 1, 1]\n";
    let e = err(text);
    assert!(e.contains("model.bogus") && e.contains("line 4") && e.contains("accel_noise_std"), "{e}");
    // In a table of the model's ([model.alignment], [model.constraints]):
    // the key with its table and its own line (it said line 1, `[model]`).
    for table in ["alignment", "constraints"] {
        let text = format!(
            "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
             accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[model.{table}]\nbogus_key = 3\n"
        );
        let e = err(&text);
        assert!(e.contains(&format!("model.{table}.bogus_key")) && e.contains("line 8"), "{e}");
    }
    // Elsewhere the parser's own position stays.
    let ipc = err(&format!("{MIN}[ipc]\nbogus = 1\n"));
    assert!(ipc.contains("line 8") && ipc.contains("bogus"), "{ipc}");
}

/// A mistake inside `[model.constraints]` or `[model.alignment]` (read
/// through the model's tagged table) is named at its own key and line, not at
/// the `[model]` header: an unknown key, a value of the wrong type, a value
/// out of its type's range.
#[test]
fn a_mistake_in_a_model_sub_table_names_its_own_line() {
    let text = |table: &str, line: &str| format!("# a robot\n[model]\nkind = \"ins\"\n\n[model.{table}]\n{line}\n");
    for (table, line, key) in [
        ("constraints", "nonholonomic_stdd_mps = 0.05", "model.constraints.nonholonomic_stdd_mps"),
        ("constraints", "nonholonomic_std_mps = \"fast\"", "model.constraints.nonholonomic_std_mps"),
        ("alignment", "static_samples = -3", "model.alignment.static_samples"),
        ("alignment", "static_samples = 1.5", "model.alignment.static_samples"),
    ] {
        let e = Config::parse(&text(table, line)).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains("(line 6)"), "{line}: {e}");
    }
}
