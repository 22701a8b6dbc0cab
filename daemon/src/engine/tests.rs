//! The engine's unit tests.

use super::*;
use crate::filter::ChiSquareGate;
use crate::model::linear::LinearModel;
use fusion_shared::{ImuSample, PositionSample};

fn cfg() -> EngineConfig {
    EngineConfig {
        history_ns: 1_000_000_000,
        history_capacity: 4096,
        max_sensors: 4,
        max_future_ns: 50_000_000,
        ..EngineConfig::default()
    }
}

fn engine(gate: Option<ChiSquareGate>) -> Engine<LinearModel> {
    Engine::new(LinearModel::new(0.3, [0.0; 6], [100.0, 100.0, 100.0, 10.0, 10.0, 10.0], gate).unwrap(), cfg())
}

fn imu(t_ms: u64, seq: u64) -> Sample {
    let t = t_ms as f64 * 1e-3;
    Sample::Imu(ImuSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t_ms * 1_000_000, 0, seq),
        accel_mps2: [t.sin(), (0.7 * t).cos(), 0.1],
        ..Default::default()
    })
}

fn pos(t_ms: u64, seq: u64, x: f64) -> Sample {
    Sample::Position(PositionSample {
        header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t_ms * 1_000_000, 1, seq),
        pos_m: [x, 0.5 * x, -x],
        cov_m2: [0.25, 0.01, 0.0, 0.01, 0.25, 0.0, 0.0, 0.0, 0.5],
    })
}

fn stream() -> Vec<Sample> {
    let mut v = Vec::new();
    for i in 0..400u64 {
        v.push(imu(i * 5, i));
        if i % 20 == 7 {
            v.push(pos(i * 5 + 2, i / 20, (i as f64) * 0.01));
        }
    }
    v
}

fn run(engine: &mut Engine<LinearModel>, samples: &[Sample]) -> Vec<(SampleKey, Vec<f64>, Vec<f64>)> {
    let mut out = Vec::new();
    let mut sink =
        |e: &Entry<_>| out.push((e.key, LinearModel::x(&e.state).to_vec(), LinearModel::covariance(&e.state).to_vec()));
    for s in samples {
        engine.insert(s, None, &mut sink);
    }
    engine.flush(&mut sink);
    out
}

#[test]
fn late_position_is_fused_by_rewind() {
    let sorted = stream();
    let mut shuffled = sorted.clone();
    // Move every position 60 ms (12 IMU samples) later in arrival order.
    let positions: Vec<usize> = (0..shuffled.len()).filter(|i| matches!(shuffled[*i], Sample::Position(_))).collect();
    for &i in positions.iter().rev() {
        let s = shuffled.remove(i);
        shuffled.insert((i + 12).min(shuffled.len()), s);
    }
    let mut a = engine(None);
    let mut b = engine(None);
    let expect = run(&mut a, &sorted);
    let got = run(&mut b, &shuffled);
    assert_eq!(expect, got, "late fusion must equal sorted processing exactly");
    let s = &b.sensors()[1];
    assert_eq!((s.kind, s.stats.fused, s.stats.late), (SampleKind::Position, 20, 20));
    assert_eq!(b.stats().rewinds, 20);
}

#[test]
fn too_late_and_duplicates_are_counted_not_fused() {
    let mut e = engine(None);
    let mut sink = |_: &Entry<_>| {};
    for i in 0..300 {
        e.insert(&imu(i * 5, i), None, &mut sink);
    }
    // Newest is 1495 ms; the window is 1 s: 400 ms is too late, 600 ms is not.
    assert_eq!(e.insert(&pos(400, 0, 0.0), None, &mut sink), Insert::TooLate);
    assert!(matches!(e.insert(&pos(600, 1, 0.0), None, &mut sink), Insert::Processed { replayed, .. } if replayed > 0));
    assert_eq!(e.insert(&pos(600, 1, 0.0), None, &mut sink), Insert::Duplicate);
    assert_eq!(e.insert(&imu(5, 1), None, &mut sink), Insert::Duplicate);
    let p = e.sensors()[1].stats;
    assert_eq!((p.received, p.processed, p.too_late, p.duplicate, p.fused), (3, 1, 1, 1, 1));
    assert_eq!(e.sensors()[0].stats.duplicate, 1);
}

#[test]
fn invalid_samples_are_rejected_and_change_nothing() {
    let mut clean = engine(None);
    let mut dirty = engine(None);
    let mut sink = |_: &Entry<_>| {};
    let mut bad_cov = pos(12, 99, 0.0);
    if let Sample::Position(p) = &mut bad_cov {
        p.cov_m2 = [1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    }
    let mut nan = imu(13, 999);
    if let Sample::Imu(s) = &mut nan {
        s.accel_mps2[0] = f64::NAN;
    }
    for s in stream() {
        clean.insert(&s, None, &mut sink);
        dirty.insert(&s, None, &mut sink);
    }
    let now = 2_000_000_000;
    assert_eq!(
        dirty.insert(&bad_cov, Some(now), &mut sink),
        Insert::Rejected(Rejection::CovarianceNotPositiveDefinite)
    );
    assert_eq!(dirty.insert(&nan, Some(now), &mut sink), Insert::Rejected(Rejection::NonFinite));
    assert_eq!(dirty.insert(&imu(2_100, 1000), Some(now), &mut sink), Insert::Rejected(Rejection::FutureTimestamp));
    assert_eq!(clean.latest().unwrap().state, dirty.latest().unwrap().state);
    assert_eq!(dirty.sensors()[0].stats.invalid, 2);
    assert_eq!(dirty.sensors()[1].stats.invalid, 1);
}

/// A velocity sample with a NaN, a non-SPD covariance, a far-future time, a
/// duplicate or an unknown sensor is rejected and counted like the other
/// kinds, and never changes the estimate.
#[test]
fn bad_velocity_samples_are_counted_and_change_nothing() {
    use fusion_shared::VelocitySample;
    let mut clean = engine(None);
    let mut dirty = engine(None);
    let mut sink = |_: &Entry<_>| {};
    let cov = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04];
    let good = Sample::Velocity(VelocitySample::new(1_000_000_000, 5, 0, [0.1, 0.0, 0.0], cov));
    for s in stream() {
        clean.insert(&s, None, &mut sink);
        dirty.insert(&s, None, &mut sink);
    }
    clean.insert(&good, None, &mut sink);
    dirty.insert(&good, None, &mut sink);
    let now = 2_000_000_000;
    let bad = |seq, t, vel: [f64; 3], cov| Sample::Velocity(VelocitySample::new(t, 5, seq, vel, cov));
    let mut not_spd = cov;
    not_spd[0] = -1.0;
    assert_eq!(
        dirty.insert(&bad(1, 1_900_000_000, [f64::NAN, 0.0, 0.0], cov), Some(now), &mut sink),
        Insert::Rejected(Rejection::NonFinite)
    );
    assert_eq!(
        dirty.insert(&bad(2, 1_900_000_000, [0.0; 3], not_spd), Some(now), &mut sink),
        Insert::Rejected(Rejection::CovarianceNotPositiveDefinite)
    );
    assert_eq!(
        dirty.insert(&bad(3, 3_000_000_000, [0.0; 3], cov), Some(now), &mut sink),
        Insert::Rejected(Rejection::FutureTimestamp)
    );
    assert_eq!(dirty.insert(&good, Some(now), &mut sink), Insert::Duplicate);
    let mut wrong_kind = good;
    wrong_kind.header_mut().kind = SampleKind::Position as u32;
    wrong_kind.header_mut().seq = 4;
    assert_eq!(dirty.insert(&wrong_kind, Some(now), &mut sink), Insert::Rejected(Rejection::WrongKind));
    // The table holds 4 velocity sensors: a fifth is an unknown sensor.
    for id in 6..9 {
        let s = Sample::Velocity(VelocitySample::new(1_000_000_000, id, 0, [0.0; 3], cov));
        clean.insert(&s, None, &mut sink);
        dirty.insert(&s, None, &mut sink);
    }
    let fifth = Sample::Velocity(VelocitySample::new(1_900_000_000, 9, 0, [50.0; 3], cov));
    assert_eq!(dirty.insert(&fifth, Some(now), &mut sink), Insert::Rejected(Rejection::TooManySensors));
    assert_eq!(clean.latest().unwrap().state, dirty.latest().unwrap().state);
    let v = dirty.sensors().iter().find(|s| s.kind == SampleKind::Velocity && s.sensor == 5).unwrap().stats;
    assert_eq!((v.received, v.processed, v.fused, v.invalid, v.duplicate), (6, 1, 1, 4, 1));
    assert_eq!(dirty.stats().unknown_sensor, 1);
}

#[test]
fn sequence_gaps_count_as_lost_until_filled() {
    let mut e = engine(None);
    let mut sink = |_: &Entry<_>| {};
    for seq in [0, 1, 4, 5] {
        e.insert(&imu(seq * 5, seq), Some(7), &mut sink);
    }
    assert_eq!(e.sensors()[0].stats.lost, 2);
    e.insert(&imu(10, 2), None, &mut sink);
    assert_eq!(e.sensors()[0].stats.lost, 1);
    // A rejected sample still arrived: it is invalid, not lost.
    let mut nan = imu(30, 6);
    if let Sample::Imu(s) = &mut nan {
        s.accel_mps2[0] = f64::NAN;
    }
    e.insert(&nan, None, &mut sink);
    e.insert(&imu(35, 7), None, &mut sink);
    let s = e.sensors()[0].stats;
    assert_eq!((s.lost, s.invalid), (1, 1));
    assert_eq!(e.sensors()[0].last_arrival_ns, Some(7));
}

#[test]
fn sensor_table_is_bounded() {
    let mut e = engine(None);
    let mut sink = |_: &Entry<_>| {};
    for id in 0..5u32 {
        let s = Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 1, id, 0),
            ..Default::default()
        });
        let r = e.insert(&s, None, &mut sink);
        assert_eq!(r == Insert::Rejected(Rejection::TooManySensors), id == 4);
    }
    assert_eq!(e.stats().unknown_sensor, 1);
}

#[test]
fn gate_decisions_follow_rewinds() {
    // An outlier is gated whether it arrives in order or late.
    let gate = ChiSquareGate::new(0.999).unwrap();
    let mut samples = stream();
    let outlier = pos(1_950, 100, 500.0);
    let at = samples.iter().position(|s| key_of(s) > key_of(&outlier)).unwrap();
    samples.insert(at, outlier);
    let mut a = engine(Some(gate.clone()));
    run(&mut a, &samples);
    samples.remove(at);
    samples.push(outlier);
    let mut b = engine(Some(gate));
    run(&mut b, &samples);
    let (sa, sb) = (a.sensors()[1].stats, b.sensors()[1].stats);
    assert_eq!((sa.gated, sa.late, sb.late), (1, 0, 1));
    assert_eq!(sa, SensorStats { late: 0, ..sb });
}

#[test]
fn capacity_bounds_the_history() {
    let mut e = Engine::new(
        LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap(),
        EngineConfig { history_capacity: 16, ..cfg() },
    );
    let mut finals = 0;
    let mut sink = |_: &Entry<_>| finals += 1;
    for i in 0..100 {
        e.insert(&imu(i, i), None, &mut sink);
    }
    assert_eq!(e.pending().count(), 16);
    assert_eq!(e.stats().evicted_by_capacity, 84);
    // Older than everything retained, and the initial state is gone: too late.
    assert_eq!(e.insert(&pos(50, 0, 0.0), None, &mut sink), Insert::TooLate);
    assert_eq!(finals, 84);
}

/// The latest state's mean and covariance, for bit-for-bit comparisons.
fn latest(e: &Engine<LinearModel>) -> (Vec<f64>, Vec<f64>) {
    let s = &e.latest().unwrap().state;
    (LinearModel::x(s).to_vec(), LinearModel::covariance(s).to_vec())
}

/// Every sample of every row is accounted for once.
fn assert_accounted(e: &Engine<LinearModel>) {
    for s in e.sensors() {
        let n = s.stats;
        assert_eq!(n.received, n.processed + n.invalid + n.duplicate + n.too_late + n.rate_limited, "{n:?}");
    }
}

#[test]
fn a_restarted_sensor_is_fused_after_its_restart() {
    // The same stream, once with the IMU's sequence running on, once with the
    // IMU restarting (sequence from 0 again) at 1 s and the fixes' at 1.2 s.
    let steady = stream();
    let restarted: Vec<Sample> = steady
        .iter()
        .map(|s| {
            let mut s = *s;
            let kind = s.kind();
            let h = s.header_mut();
            match kind {
                fusion_shared::SampleKind::Imu if h.t_ns >= 1_000_000_000 => h.seq -= 200,
                fusion_shared::SampleKind::Position if h.t_ns >= 1_200_000_000 => h.seq -= 12,
                _ => {}
            }
            s
        })
        .collect();
    let (mut a, mut b) = (engine(None), engine(None));
    let now = Some(2_000_000_000);
    for (x, y) in steady.iter().zip(&restarted) {
        a.insert(x, now, &mut |_| {});
        b.insert(y, now, &mut |_| {});
    }
    assert_eq!(latest(&a), latest(&b), "the restart changes nothing");
    let (imu, fix) = (b.sensors()[0].stats, b.sensors()[1].stats);
    assert_eq!((imu.restarts, fix.restarts), (1, 1));
    assert_eq!((imu.processed, imu.duplicate, imu.lost), (400, 0, 0));
    assert_eq!((fix.processed, fix.duplicate, fix.lost), (20, 0, 0));
    // A true duplicate after the restart is still one.
    assert_eq!(b.insert(&restarted[restarted.len() - 1], now, &mut |_| {}), Insert::Duplicate);
    assert_accounted(&b);
}

#[test]
fn invalid_samples_take_no_sensor_row_and_move_no_sequence() {
    let mut e = engine(None);
    let nan = |sensor: u32, seq: u64| {
        let mut s = imu(1, seq);
        if let Sample::Imu(x) = &mut s {
            x.header.sensor = sensor;
            x.accel_mps2[0] = f64::NAN;
        }
        s
    };
    for id in 1..=20 {
        assert_eq!(e.insert(&nan(id, id as u64), None, &mut |_| {}), Insert::Rejected(Rejection::NonFinite));
    }
    assert_eq!((e.sensors().len(), e.stats().unknown_sensor), (0, 20));
    for k in 0..10 {
        assert!(matches!(e.insert(&imu(k, k), None, &mut |_| {}), Insert::Processed { .. }));
    }
    // A bad sample with an absurd sequence number of a known sensor moves nothing.
    e.insert(&nan(0, u64::MAX), None, &mut |_| {});
    e.insert(&imu(10, 10), None, &mut |_| {});
    let s = e.sensors()[0].stats;
    assert_eq!((s.processed, s.invalid, s.lost), (11, 1, 0));
    assert_accounted(&e);
}

#[test]
fn timestamps_far_behind_the_clock_are_refused() {
    let mut e = engine(None);
    let now = Some(100_000_000_000); // 100 s
    assert_eq!(e.insert(&imu(0, 0), now, &mut |_| {}), Insert::Rejected(Rejection::PastTimestamp));
    assert!(e.latest().is_none(), "nothing processed");
    assert!(matches!(e.insert(&imu(96_000, 1), now, &mut |_| {}), Insert::Processed { .. }));
    assert_eq!(e.insert(&imu(94_000, 2), now, &mut |_| {}), Insert::Rejected(Rejection::PastTimestamp));
}

#[test]
fn no_more_sensors_are_tracked_than_a_snapshot_shows() {
    let mut e = Engine::new(
        LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap(),
        EngineConfig { max_sensors: 12, ..cfg() },
    );
    for id in 0..12u32 {
        let mut s = imu(1, 0);
        s.header_mut().sensor = id;
        e.insert(&s, None, &mut |_| {});
    }
    for id in 0..7u32 {
        let mut s = pos(2, 0, 0.0);
        s.header_mut().sensor = id;
        e.insert(&s, None, &mut |_| {});
    }
    assert_eq!(e.sensors().len(), fusion_shared::snapshot::MAX_SENSORS);
    assert_eq!(e.stats().unknown_sensor, 3);
}

#[test]
fn a_flooding_sensor_is_rate_limited_and_the_others_are_not() {
    let mut e = Engine::new(
        LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap(),
        EngineConfig { max_rate_hz: 2000.0, max_burst: 10, ..cfg() },
    );
    let mut clean = engine(None);
    let mut flood_seq = 0;
    for k in 0..200u64 {
        // 50 samples per ms from sensor 7, all at the same instant.
        for _ in 0..50 {
            let mut s = imu(k, flood_seq);
            s.header_mut().sensor = 7;
            e.insert(&s, None, &mut |_| {});
            flood_seq += 1;
        }
        let good = pos(k, k, 0.01 * k as f64);
        assert!(matches!(e.insert(&good, None, &mut |_| {}), Insert::Processed { .. }));
        clean.insert(&good, None, &mut |_| {});
    }
    let flood = e.sensors()[0].stats;
    // The burst, then 2 per ms.
    assert_eq!(flood.processed, 10 + 2 * 199);
    assert_eq!(flood.rate_limited, 200 * 50 - flood.processed);
    assert_eq!(e.sensors()[1].stats.rate_limited, 0);
    assert_accounted(&e);
}

#[test]
fn without_a_clock_a_time_jump_is_refused_until_a_run_confirms_it() {
    let mut e = engine(None);
    for k in 0..10 {
        e.insert(&imu(k, k), None, &mut |_| {});
    }
    let mut far = imu(0, 10);
    far.header_mut().t_ns = u64::MAX;
    assert_eq!(e.insert(&far, None, &mut |_| {}), Insert::Rejected(Rejection::TimeJump));
    // Later samples are fused as if it had not been there.
    for k in 11..20 {
        assert!(matches!(e.insert(&imu(k, k), None, &mut |_| {}), Insert::Processed { replayed: 0, .. }));
    }
    // A real gap in a recording: after a run of samples past the jump, time moves on.
    let gap_ms = 3_600_000;
    let outcomes: Vec<Insert> =
        (0..=JUMP_CONFIRMATION as u64).map(|k| e.insert(&imu(gap_ms + k, 20 + k), None, &mut |_| {})).collect();
    assert!(outcomes[..JUMP_CONFIRMATION as usize].iter().all(|o| *o == Insert::Rejected(Rejection::TimeJump)));
    assert!(matches!(outcomes[JUMP_CONFIRMATION as usize], Insert::Processed { .. }));
    assert_accounted(&e);
}
