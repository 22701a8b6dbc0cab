use super::*;
use crate::engine::{Engine, EngineConfig, Entry};
use crate::model::linear::LinearModel;
use fusion_shared::{ImuSample, PositionSample, Sample};

fn engine() -> Engine<LinearModel> {
    Engine::new(
        LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap(),
        EngineConfig {
            history_ns: 1_000_000_000,
            history_capacity: 64,
            max_sensors: 4,
            max_future_ns: u64::MAX,
            ..EngineConfig::default()
        },
    )
}

/// A dead-reckoning model (`ins`: IMU and wheels, no GNSS) reads `ok`
/// once ready, without a position fix (it never left `initialising`).
#[test]
fn a_dead_reckoning_model_is_ok_without_a_fix() {
    let mut h = HealthMonitor::new(HealthConfig::default()).without_position();
    let mut e = engine();
    assert_eq!(h.evaluate(e.sensors(), 500, true, 0).state, health::INITIALISING, "it still waits for the IMU");
    let imu = Sample::Imu(ImuSample::new(1_000, 0, 0, [0.0; 3], [0.0; 3]));
    e.insert(&imu, Some(1_000), &mut |_| {});
    assert_eq!(h.evaluate(e.sensors(), 1_000, true, 0).state, health::OK);
    assert_eq!(h.evaluate(e.sensors(), 1_000, false, 0).state, health::INITIALISING, "the model not ready");
    let mut waits = HealthMonitor::new(HealthConfig::default());
    assert_eq!(waits.evaluate(e.sensors(), 1_000, true, 0).state, health::INITIALISING, "linear waits for a fix");
}

#[test]
fn initialising_then_ok_then_stale() {
    let mut e = engine();
    let mut h = HealthMonitor::new(HealthConfig::default());
    let mut sink = |_: &Entry<_>| {};
    let imu = Sample::Imu(ImuSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 10, 0, 0),
        ..Default::default()
    });
    e.insert(&imu, Some(1_000), &mut sink);
    assert_eq!(h.evaluate(e.sensors(), 1_000, true, 0).state, health::INITIALISING);
    let pos = Sample::Position(PositionSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, 11, 1, 0),
        cov_m2: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    });
    e.insert(&pos, Some(2_000), &mut sink);
    assert_eq!(h.evaluate(e.sensors(), 2_000, true, 0).pair(), (health::OK, 0));
    assert_eq!(h.evaluate(e.sensors(), 2_000, false, 0).state, health::INITIALISING);
    // 150 ms later: the IMU (100 ms timeout) is stale, the position (1 s) is not.
    assert_eq!(
        h.evaluate(e.sensors(), 150_002_000, true, 0),
        HealthNow { state: health::DEGRADED, reasons: health::IMU_STALE, stale_sensors: 0b01, nis_sensors: 0 }
    );
    let now = h.evaluate(e.sensors(), 1_100_000_000, true, 0);
    assert_eq!((now.reasons, now.stale_sensors), (health::IMU_STALE | health::POSITION_STALE, 0b11));
}

fn fix_engine() -> Engine<LinearModel> {
    let mut e = engine();
    let mut sink = |_: &Entry<_>| {};
    e.insert(&Sample::Imu(ImuSample::default()), Some(0), &mut sink);
    e.insert(
        &Sample::Position(PositionSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, 0, 1, 0),
            cov_m2: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            ..Default::default()
        }),
        Some(0),
        &mut sink,
    );
    e
}

#[test]
fn persistently_inconsistent_nis_is_flagged_and_recovers() {
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    let (lo, hi) = h.nis_band(3, 10);
    // A 2-D measurement (the motion constraint): χ²₂₀ at 0.0005 and 0.9995 (tables: 5.40 and 47.50).
    let (lo2, hi2) = h.nis_band(2, 10);
    assert!((lo2 - 5.40).abs() < 0.01 && (hi2 - 47.50).abs() < 0.01, "{lo2} {hi2}");
    // χ²₃₀ at 0.0005 and 0.9995 (tables: 10.80 and 62.16).
    assert!((lo - 10.80).abs() < 0.01 && (hi - 62.16).abs() < 0.01, "{lo} {hi}");
    let e = fix_engine();
    // Out of the band from the first full window on: flagged after a
    // window more (persistently).
    for i in 0..19 {
        h.record(1, &StepOutcome::Fused { nis: 9.0 }, false);
        let flagged = h.evaluate(e.sensors(), 0, true, 0).reasons == health::NIS_OUT_OF_BOUNDS;
        assert_eq!(flagged, i >= 18, "after {} measurements", i + 1);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::DEGRADED, health::NIS_OUT_OF_BOUNDS));
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).nis_sensors, 0b10, "the fix sensor (slot 1) is named");
    for _ in 0..10 {
        h.record(1, &StepOutcome::Fused { nis: 3.0 }, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::OK, 0));
    for _ in 0..20 {
        h.record(1, &StepOutcome::Fused { nis: 0.05 }, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).reasons, health::NIS_OUT_OF_BOUNDS, "far too pessimistic");
    // IMU steps carry no NIS and change nothing.
    h.record(0, &StepOutcome::Propagated, false);
}

/// An AHRS's attitude (another filter's estimate, its errors correlated over
/// seconds) with NIS values far below the band, as robot_localization's test1
/// bag gives (mean 0.22 for 3 degrees of freedom): not flagged; far above it:
/// flagged. A position fix's small NIS still is.
#[test]
fn a_filtered_sensors_small_nis_is_no_fault_but_a_large_one_is() {
    let mut e = engine();
    let mut sink = |_: &Entry<_>| {};
    e.insert(&Sample::Imu(ImuSample::default()), Some(0), &mut sink);
    let attitude = fusion_shared::AttitudeSample::new(
        0,
        2,
        0,
        [1.0, 0.0, 0.0, 0.0],
        [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
    );
    e.insert(&Sample::Attitude(attitude), Some(0), &mut sink);
    let slot = e.slot_of(fusion_shared::SampleKind::Attitude, 2).expect("the attitude's row");
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    for _ in 0..40 {
        h.record(slot, &StepOutcome::Fused { nis: 0.05 }, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).nis_sensors, 0, "a small NIS of a filtered sensor");
    for _ in 0..40 {
        h.record(slot, &StepOutcome::Fused { nis: 30.0 }, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).nis_sensors, 1 << slot, "a large one");
}

/// The snapshots between two measurements (IMU instants, a dozen per fix)
/// each evaluate the health: those evaluations move no streak, so a monitor
/// evaluated a hundred times between measurements reads as one evaluated once
/// per measurement, through in-band, out-of-band and gated stretches.
#[test]
fn evaluations_between_measurements_change_no_verdict() {
    let config = HealthConfig { nis_window: 8, ..Default::default() };
    let (mut often, mut once) = (HealthMonitor::new(config), HealthMonitor::new(config));
    let e = fix_engine();
    let mut flagged = 0;
    for i in 0..400u32 {
        // A deterministic mix: consistent, far too large, far too small, gated.
        let outcome = match (i / 40) % 4 {
            0 => StepOutcome::Fused { nis: 1.0 + f64::from(i % 5) },
            1 => StepOutcome::Fused { nis: 40.0 },
            2 if i % 3 == 0 => StepOutcome::Gated { nis: 500.0 },
            _ => StepOutcome::Fused { nis: 0.01 },
        };
        often.record(1, &outcome, false);
        once.record(1, &outcome, false);
        let expected = once.evaluate(e.sensors(), 0, true, 0);
        for _ in 0..100 {
            assert_eq!(often.evaluate(e.sensors(), 0, true, 0), expected, "after {} measurements", i + 1);
        }
        flagged += usize::from(expected.reasons == health::NIS_OUT_OF_BOUNDS);
    }
    assert!(flagged > 100 && flagged < 300, "both verdicts were seen: {flagged} of 400 flagged");
}

/// An AHRS fused for roll and pitch only gives 2-D innovations: its NIS is
/// judged against χ² of 2 degrees of freedom per measurement (against the
/// kind's 3, a consistent stream read far too low); other sensors keep
/// their kind's.
#[test]
fn a_sensor_fusing_fewer_dimensions_is_judged_by_them() {
    let toml = |id, yaw| format!("name = \"ahrs{id}\"\nid = {id}\nkinds = [\"attitude\"]\n[attitude]\nyaw = {yaw}\n");
    let twist = "name = \"wheels\"\nid = 1\nkinds = [\"twist\"]\n[twist]\nfuse = [\"vx\", \"vy\", \"vyaw\"]\n";
    let pose = "name = \"slam\"\nid = 1\nkinds = [\"pose\"]\n[pose]\nfuse = [\"x\", \"y\", \"yaw\"]\n";
    let sensors: Vec<crate::frames::SensorConfig> = [toml(1, false), toml(2, true), twist.into(), pose.into()]
        .iter()
        .map(|t| ::toml::from_str(t).unwrap())
        .collect();
    let frames =
        crate::frames::Frames::from_config(None, &sensors, Default::default(), &crate::measurement::Kinds).unwrap();
    let h = HealthMonitor::new(HealthConfig::default()).with_frames(&frames);
    assert_eq!(h.innovation_dim(SampleKind::Attitude, 1), 2);
    assert_eq!(h.innovation_dim(SampleKind::Attitude, 2), 3);
    assert_eq!(h.innovation_dim(SampleKind::Attitude, 3), 3, "an unconfigured one: the full attitude");
    assert_eq!(h.innovation_dim(SampleKind::Position, 1), 3);
    assert_eq!((h.innovation_dim(SampleKind::Twist, 1), h.innovation_dim(SampleKind::Twist, 2)), (3, 6));
    assert_eq!(h.innovation_dim(SampleKind::Pose, 1), 3);
}

/// Wheels that stand read exactly 0: far below the band, and no fault
/// (a car at a traffic light read `degraded` for its whole stop).
#[test]
fn exact_readings_are_no_evidence_of_a_pessimistic_filter() {
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    let e = fix_engine();
    for _ in 0..10 {
        h.record(1, &StepOutcome::Fused { nis: 3.0 }, false);
    }
    for _ in 0..50 {
        h.record(1, &StepOutcome::Fused { nis: 1e-6 }, true);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::OK, 0));
    let wheels = |speed_mps| Sample::Odometry(fusion_shared::OdometrySample::new(0, 0, 0, speed_mps, 0.01));
    assert!(measurement::exact(&wheels(0.0)) && !measurement::exact(&wheels(0.01)));
}

/// A cluster of large but normal values (the χ² tail, values just inside
/// the gate) takes the window out of its band while it is in it, shorter
/// than a window: no alarm, the health stays ok throughout.
#[test]
fn a_stretch_out_of_band_shorter_than_a_window_is_not_persistent() {
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    let e = fix_engine();
    let (_, hi) = h.nis_band(3, 10);
    let mut out = 0;
    let values = [3.0; 10].into_iter().chain([12.0; 4]).chain([3.0; 12]);
    for nis in values {
        h.record(1, &StepOutcome::Fused { nis }, false);
        assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::OK, 0));
        let w = &h.windows[1];
        out += usize::from(w.sum > hi);
    }
    assert!(out >= 5, "the window was out of its band for {out} measurements");
}

/// Measurements the model refused before it could use them (odometry
/// before the attitude is known) are no evidence: no alarm however many.
#[test]
fn measurements_the_model_cannot_use_yet_are_no_evidence() {
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    let e = fix_engine();
    for _ in 0..30 {
        h.record(1, &StepOutcome::Refused, false);
        assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::OK, 0));
    }
}

#[test]
fn an_occasional_gated_outlier_is_fine_but_a_lock_out_is_not() {
    let mut h = HealthMonitor::new(HealthConfig { nis_window: 10, ..Default::default() });
    let e = fix_engine();
    for i in 0..10 {
        let o = if i == 4 { StepOutcome::Gated { nis: 3000.0 } } else { StepOutcome::Fused { nis: 3.0 } };
        h.record(1, &o, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).pair(), (health::OK, 0));
    for _ in 0..15 {
        h.record(1, &StepOutcome::Gated { nis: 50.0 }, false);
    }
    assert_eq!(h.evaluate(e.sensors(), 0, true, 0).reasons, health::NIS_OUT_OF_BOUNDS, "most fixes gated");
}

#[test]
fn losses_are_reported_for_a_while() {
    let mut e = engine();
    let mut h = HealthMonitor::new(HealthConfig { timeouts_ns: [u64::MAX; KINDS], ..Default::default() });
    let mut sink = |_: &Entry<_>| {};
    e.insert(
        &Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 0, 0, 0),
            ..Default::default()
        }),
        Some(0),
        &mut sink,
    );
    e.insert(
        &Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 1, 0, 5),
            ..Default::default()
        }),
        Some(0),
        &mut sink,
    );
    assert_eq!(h.evaluate(e.sensors(), 10, true, 0).reasons, health::SAMPLES_LOST);
    assert_eq!(h.evaluate(e.sensors(), 10 + LOSS_HOLD_NS, true, 0).reasons, 0);
}
