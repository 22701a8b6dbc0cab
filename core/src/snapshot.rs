//! Filling a [`StateSnapshot`] from the engine: pure, no IPC, no allocation.

use fusion_shared::snapshot::{MAX_COV, MAX_SENSORS, MAX_STATE, outcome};
use fusion_shared::{Sample, SensorCounters, StateSnapshot};

use crate::engine::Engine;
use crate::health::HealthNow;
use crate::measurement::Steps;
use crate::model::StepOutcome;
use crate::reorder::key_of;
use crate::sensor_table::SensorRow;

pub use fusion_shared::snapshot::INPUT_NONE;

/// The input that triggered a snapshot.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// The sample.
    pub sample: &'a Sample,
    /// When the daemon received it, ns.
    pub received_ns: u64,
    /// Samples re-processed because it came late.
    pub replayed: usize,
}

fn outcome_code(o: &StepOutcome) -> u32 {
    match o {
        StepOutcome::Propagated => outcome::PROPAGATED,
        StepOutcome::Fused { .. } => outcome::FUSED,
        StepOutcome::Gated { .. } => outcome::GATED,
        StepOutcome::Refused => outcome::REFUSED,
    }
}

fn counters(s: &SensorRow) -> SensorCounters {
    SensorCounters {
        kind: s.kind as u32,
        sensor: s.sensor,
        counts: s.stats,
        last_nis: s.last_nis.unwrap_or(f64::NAN),
        last_t_ns: s.last_t_ns.unwrap_or(0),
        last_arrival_ns: s.last_arrival_ns.unwrap_or(0),
        rejection_reasons: s.rejection_reasons,
        last_rejection: s.last_rejection,
    }
}

/// Writes the engine's current estimate, counters and the given input and health
/// into `snap` (all but `seq` and `publish_ns`, which the publisher stamps).
///
/// Every field that can change is written. The ones left alone stay as they
/// were: the state and covariance beyond the model's size, sensor rows beyond
/// the sensors seen (which only grow), and the estimate fields before the first
/// processed sample. So filling a default snapshot, as the live loop does in a
/// fresh shared-memory chunk, gives the same as refilling one snapshot.
pub fn fill<M: Steps>(snap: &mut StateSnapshot, engine: &Engine<M>, input: Option<Input<'_>>, health: HealthNow) {
    snap.model = M::CODE;
    if let Some(d) = engine.model().frames().datum() {
        (snap.datum_lat_deg, snap.datum_lon_deg, snap.datum_height_m) = (d.latitude_deg, d.longitude_deg, d.height_m);
        snap.datum_set = 1;
    }
    if let Some(latest) = engine.latest() {
        let key = latest.key;
        snap.t_ns = key.t_ns;
        snap.sample_seq = key.seq;
        snap.sample_sensor = key.sensor;
        snap.sample_kind = key.kind as u32;
        snap.outcome = outcome_code(&latest.outcome);
        snap.nis = latest.outcome.nis().unwrap_or(f64::NAN);
        let x = M::x(&latest.state);
        let n = x.len().min(MAX_STATE);
        snap.x[..n].copy_from_slice(&x[..n]);
        snap.state_len = n as u32;
        const { assert!(M::COV_DIM <= MAX_COV, "the snapshot holds the covariance") };
        M::write_covariance(&latest.state, &mut snap.cov[..M::COV_DIM * M::COV_DIM]);
        snap.cov_dim = M::COV_DIM as u32;
        snap.aux_states = M::aux_states(&latest.state);
        let d = M::diagnostics(&latest.state);
        let (tau, sd, n) = d.velocity_time_offset.unwrap_or((0.0, 0.0, 0));
        (snap.velocity_offset_ns, snap.velocity_offset_std_ns, snap.velocity_offset_samples) = (tau * 1e9, sd * 1e9, n);
        snap.reinitialisations = d.reinitialisations;
        snap.standing = u32::from(d.standing);
        snap.standstill_updates = d.standstill_updates;
    }
    match input {
        Some(i) => {
            let key = key_of(i.sample);
            snap.input_t_ns = key.t_ns;
            snap.input_sent_ns = i.sample.sent_ns();
            snap.input_received_ns = i.received_ns;
            snap.input_seq = key.seq;
            snap.input_sensor = key.sensor;
            snap.input_kind = key.kind as u32;
            snap.input_replayed = i.replayed.min(u32::MAX as usize) as u32;
        }
        None => {
            snap.input_t_ns = 0;
            snap.input_sent_ns = 0;
            snap.input_received_ns = 0;
            snap.input_seq = 0;
            snap.input_sensor = 0;
            snap.input_kind = INPUT_NONE;
            snap.input_replayed = 0;
        }
    }
    (snap.health, snap.health_reasons, snap.stale_sensors, snap.nis_sensors) =
        (health.state, health.reasons, health.stale_sensors, health.nis_sensors);
    let sensors = engine.sensors();
    let count = sensors.len().min(MAX_SENSORS);
    for (dst, src) in snap.sensors.iter_mut().zip(&sensors[..count]) {
        *dst = counters(src);
    }
    snap.sensor_count = count as u32;
    let stats = engine.stats();
    snap.rewinds = stats.rewinds;
    snap.replayed = stats.replayed;
    snap.unknown_sensor = stats.unknown_sensor;
    snap.rejections = stats.rejections;
    snap.background_steps = stats.background_steps;
    (snap.pending_steps, snap.pending_since_t_ns) =
        engine.correction().map_or((0, 0), |c| (c.steps as u64, c.since_t_ns));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::{EngineConfig, Entry};
    use crate::model::Model;
    use crate::model::linear::LinearModel;
    use fusion_shared::snapshot::health;
    use fusion_shared::{ImuSample, PositionSample};

    #[test]
    fn snapshot_carries_estimate_input_and_counters() {
        let mut e = Engine::new(
            LinearModel::new(0.3, [1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [1.0; 6], None).unwrap(),
            EngineConfig {
                history_ns: 1_000_000_000,
                history_capacity: 64,
                max_sensors: 4,
                max_future_ns: u64::MAX,
                ..EngineConfig::default()
            },
        );
        let mut sink = |_: &Entry<_>| {};
        let imu = Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader {
                t_ns: 100,
                sent_ns: 150,
                seq: 3,
                ..fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 0, 0, 0)
            },
            ..Default::default()
        });
        e.insert(&imu, Some(170), &mut sink);
        let pos = Sample::Position(PositionSample {
            header: fusion_shared::SampleHeader {
                t_ns: 90,
                sent_ns: 160,
                seq: 7,
                sensor: 2,
                kind: fusion_shared::SampleKind::Position as u32,
            },
            pos_m: [1.0, 2.0, 3.0],
            cov_m2: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        });
        e.insert(&pos, Some(180), &mut sink);
        let mut snap = StateSnapshot::default();
        fill(
            &mut snap,
            &e,
            Some(Input { sample: &pos, received_ns: 180, replayed: 1 }),
            HealthNow { state: health::OK, reasons: 0, stale_sensors: 0, nis_sensors: 0 },
        );
        // The estimate is after the newest sample (the IMU at 100), the input was the late fix at 90.
        assert_eq!((snap.t_ns, snap.sample_seq, snap.sample_kind, snap.outcome), (100, 3, 1, outcome::PROPAGATED));
        assert_eq!((snap.input_t_ns, snap.input_sent_ns, snap.input_received_ns), (90, 160, 180));
        assert_eq!((snap.input_seq, snap.input_sensor, snap.input_kind, snap.input_replayed), (7, 2, 2, 1));
        assert_eq!((snap.state_len, snap.cov_dim, snap.model), (6, 6, fusion_shared::snapshot::model::LINEAR));
        let latest = e.latest().unwrap();
        assert_eq!(snap.state(), LinearModel::x(&latest.state));
        assert_eq!(snap.covariance(), LinearModel::covariance(&latest.state));
        assert_eq!(snap.sensor_count, 2);
        let p = snap.sensor_counters()[1];
        assert_eq!(
            (p.kind, p.sensor, p.counts.received, p.counts.fused, p.counts.late, p.last_arrival_ns),
            (2, 2, 1, 1, 1, 180)
        );
        assert_eq!(snap.rewinds, 1);
        fill(
            &mut snap,
            &e,
            None,
            HealthNow { state: health::DEGRADED, reasons: health::IMU_STALE, stale_sensors: 1, nis_sensors: 0 },
        );
        assert_eq!((snap.input_kind, snap.input_t_ns, snap.health), (INPUT_NONE, 0, health::DEGRADED));
    }

    /// fusiond fills each snapshot in a freshly loaned chunk that holds a default
    /// snapshot: that must give what filling one snapshot over and over gives.
    #[test]
    fn filling_a_default_snapshot_gives_the_same_as_refilling_one() {
        let mut e = Engine::new(
            LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap(),
            EngineConfig {
                history_ns: 50_000_000,
                history_capacity: 64,
                max_sensors: 4,
                max_future_ns: u64::MAX,
                ..EngineConfig::default()
            },
        );
        let mut kept = StateSnapshot::default();
        for k in 0..200u64 {
            let t = 1_000_000 * k;
            // IMU sensor 0, a fix every 10th (some late), a second IMU sensor from
            // sample 100 on (a new counter row), a health-only snapshot every 50th.
            let mut samples = vec![Sample::Imu(ImuSample {
                header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t, 0, k),
                accel_mps2: [0.1, 0.0, 0.0],
                ..Default::default()
            })];
            if k % 10 == 9 {
                let late = if k % 30 == 29 { 5_000_000 } else { 0 };
                samples.push(Sample::Position(PositionSample {
                    header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t - late, 1, k),
                    cov_m2: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                    ..Default::default()
                }));
            }
            if k >= 100 {
                samples.push(Sample::Imu(ImuSample {
                    header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t, 3, k),
                    ..Default::default()
                }));
            }
            for sample in &samples {
                let crate::engine::Insert::Processed { replayed, .. } = e.insert(sample, Some(t), &mut |_| {}) else {
                    panic!("sample {k} not processed");
                };
                let input = Some(Input { sample, received_ns: t + 1, replayed });
                let health =
                    HealthNow { state: health::OK, reasons: k as u32, stale_sensors: k as u32, nis_sensors: k as u32 };
                let mut fresh = StateSnapshot::default();
                fill(&mut kept, &e, input, health);
                fill(&mut fresh, &e, input, health);
                // Debug output compares NaN fields (no last NIS yet) as equal.
                assert_eq!(format!("{fresh:?}"), format!("{kept:?}"), "sample {k}");
            }
            if k % 50 == 49 {
                let mut fresh = StateSnapshot::default();
                fill(
                    &mut kept,
                    &e,
                    None,
                    HealthNow { state: health::DEGRADED, reasons: 0, stale_sensors: 0, nis_sensors: 0 },
                );
                fill(
                    &mut fresh,
                    &e,
                    None,
                    HealthNow { state: health::DEGRADED, reasons: 0, stale_sensors: 0, nis_sensors: 0 },
                );
                assert_eq!(format!("{fresh:?}"), format!("{kept:?}"), "health-only snapshot {k}");
            }
        }
        assert_eq!(kept.sensor_count, 3);
        assert!(kept.rewinds > 0, "late fixes were replayed");
    }
}
