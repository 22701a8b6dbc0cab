//! The engine's unit tests.

use super::*;
use crate::filter::ChiSquareGate;
use crate::model::Model;
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
fn reordered_sequence_numbers_are_no_restart_and_no_loss() {
    // Samples in time order, the sequence numbers of every third pair swapped
    // (a driver numbering out of turn): nothing lost, no restart, and the
    // estimate of the same samples numbered in order.
    let steady = stream();
    let mut swapped = steady.clone();
    let imu_at: Vec<usize> =
        (0..swapped.len()).filter(|&i| swapped[i].kind() == fusion_shared::SampleKind::Imu).collect();
    for pair in imu_at.chunks_exact(2).step_by(3) {
        let (a, b) = (swapped[pair[0]].seq(), swapped[pair[1]].seq());
        swapped[pair[0]].header_mut().seq = b;
        swapped[pair[1]].header_mut().seq = a;
    }
    let (mut a, mut b) = (engine(None), engine(None));
    for (x, y) in steady.iter().zip(&swapped) {
        a.insert(x, Some(2_000_000_000), &mut |_| {});
        b.insert(y, Some(2_000_000_000), &mut |_| {});
    }
    assert_eq!(latest(&a), latest(&b));
    let imu = b.sensors()[0].stats;
    assert_eq!((imu.processed, imu.restarts, imu.lost, imu.duplicate), (400, 0, 0, 0), "{imu:?}");
    assert_accounted(&b);
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

/// The model of the comparisons between two engines (no gate).
fn model() -> LinearModel {
    LinearModel::new(0.3, [0.0; 6], [100.0, 100.0, 100.0, 10.0, 10.0, 10.0], None).unwrap()
}

/// A final entry's key, outcome and estimate, as two engines' are compared.
type Final = (SampleKey, StepOutcome, Vec<f64>, Vec<f64>);

/// Keeps a final entry for the comparison.
fn record(out: &mut Vec<Final>, e: &Entry<crate::model::linear::LinearState>) {
    out.push((e.key, e.outcome, LinearModel::x(&e.state).to_vec(), LinearModel::covariance(&e.state)));
}

/// Whether two inserts placed the sample alike (processed or placed with as
/// many later samples, or refused for the same reason). Appended after stale
/// entries, a measurement's own outcome is provisional: its NIS, and even its
/// gate decision, may differ until the correction has settled.
fn same_decision(a: &Insert, b: &Insert) -> bool {
    match (a, b) {
        (
            Insert::Processed { replayed: x, .. },
            Insert::Processed { replayed: y, .. } | Insert::Placed { replayed: y },
        ) => x == y,
        _ => a == b,
    }
}

/// Feeds `arrivals` to one engine that settles every late sample at once
/// ([`Engine::insert`]) and to one that defers the rewinds
/// ([`Engine::insert_deferred`]), re-stepping `slices[i]` stale entries before
/// arrival `i`. Checks that both decide the same for every sample, that the
/// deferred engine's estimate equals the other's whenever no correction is
/// pending, and that the final estimates (flush) are equal bit for bit.
/// Returns the deferred engine.
fn deferred_equals_settled(config: EngineConfig, arrivals: &[Sample], slices: &[usize]) -> Engine<LinearModel> {
    let (mut settled, mut deferred) = (Engine::new(model(), config), Engine::new(model(), config));
    let (mut want, mut got) = (Vec::new(), Vec::new());
    for (i, s) in arrivals.iter().enumerate() {
        for _ in 0..slices.get(i).copied().unwrap_or(0) {
            deferred.settle_step();
        }
        let stale_key = deferred.correction().map(|c| deferred.history[deferred.history.len() - c.steps].key);
        let exact = stale_key.is_none_or(|k| key_of(s) < k);
        let a = settled.insert(s, None, &mut |e| record(&mut want, e));
        let b = deferred.insert_deferred(s, None, &mut |e| record(&mut got, e));
        assert!(same_decision(&a, &b), "arrival {i}: {a:?} {b:?}");
        if exact && matches!(b, Insert::Processed { .. }) {
            // Stepped from an exact state, the sample's own outcome is final.
            assert_eq!(a, b, "arrival {i}");
        }
        if deferred.correction().is_none() {
            assert_eq!(latest(&deferred), latest(&settled), "arrival {i}: settled means exact");
        }
        assert!(settled.correction().is_none());
    }
    settled.flush(&mut |e| record(&mut want, e));
    deferred.flush(&mut |e| record(&mut got, e));
    assert_eq!(got, want, "final estimates");
    for (a, b) in settled.sensors().iter().zip(deferred.sensors()) {
        assert_eq!(a.stats, b.stats, "counters once settled");
    }
    deferred
}

#[test]
fn a_late_fix_leaves_the_samples_behind_it_stale_until_settled() {
    let mut e = engine(None);
    let mut sink = |_: &Entry<_>| {};
    for i in 0..100 {
        e.insert_deferred(&imu(i, i), None, &mut sink);
    }
    let before = latest(&e);
    // 30 ms late: placed before 30 IMU entries, not yet processed.
    let r = e.insert_deferred(&pos(69, 0, 1.0), None, &mut sink);
    assert_eq!(r, Insert::Placed { replayed: 30 });
    assert_eq!(e.correction(), Some(Correction { steps: 31, since_t_ns: 69_000_000 }));
    assert_eq!(latest(&e), before, "the head is not yet corrected");
    let p = e.sensors()[1].stats;
    assert_eq!((p.processed, p.late, p.fused), (1, 1, 0), "fused once the rewind reaches it");
    // The IMU sample behind it is stepped once, from the provisional head.
    e.insert_deferred(&imu(100, 100), None, &mut sink);
    assert_eq!(e.correction(), Some(Correction { steps: 32, since_t_ns: 69_000_000 }));
    assert_eq!(e.stats().settled_inline, 0, "nothing re-stepped on the way");
    assert!(e.settle_step());
    let mut first = Vec::new();
    e.take_first_outcomes(|slot, o, _| first.push((slot, *o)));
    assert!(matches!(first[..], [(1, StepOutcome::Fused { .. })]), "{first:?}");
    assert_eq!(e.sensors()[1].stats.fused, 1);
    assert_eq!(
        e.correction(),
        Some(Correction { steps: 31, since_t_ns: 69_000_000 }),
        "the fix's effect is not at the head yet"
    );
    // Each call steps one entry and says whether more are stale: 31 to go.
    let mut calls = 0;
    while e.settle_step() {
        calls += 1;
    }
    assert_eq!((calls + 1, e.stats().background_steps, e.correction()), (31, 32, None));
    e.take_first_outcomes(|_, _, _| panic!("taken already"));
    // Now exactly what settling at once gives.
    let mut reference = engine(None);
    for i in 0..100 {
        reference.insert(&imu(i, i), None, &mut sink);
    }
    reference.insert(&pos(69, 0, 1.0), None, &mut sink);
    reference.insert(&imu(100, 100), None, &mut sink);
    assert_eq!(latest(&e), latest(&reference));
    assert_ne!(latest(&e), before);
}

/// A late fix that lands among stale entries, one older than the entries being
/// re-stepped, one at the front of the history, a duplicate of a stale entry,
/// and flushing mid-rewind: all end in the settled estimate.
#[test]
fn late_samples_in_every_position_of_a_pending_rewind_give_the_settled_estimate() {
    let mut arrivals: Vec<Sample> = (0..200).map(|i| imu(i * 2, i)).collect();
    // A fix 100 ms late; then, while its rewind is half done, one 20 ms late
    // (inside the stale run), one 150 ms late (before the first fix, older than
    // the entries being re-stepped), and the oldest sample of all (front).
    arrivals.push(pos(300, 0, 1.0));
    arrivals.extend((200..205).map(|i| imu(i * 2, i)));
    arrivals.push(pos(390, 1, 1.5));
    arrivals.push(pos(250, 2, 0.5));
    arrivals.extend((205..210).map(|i| imu(i * 2, i)));
    arrivals.push(pos(1, 3, 0.0));
    arrivals.push(imu(2 * 150, 150)); // a duplicate of an entry that is stale
    arrivals.extend((210..220).map(|i| imu(i * 2, i)));
    arrivals.push(pos(435, 4, 2.0)); // flushed before its rewind ran
    let mut slices = vec![0; arrivals.len()];
    slices[206] = 20; // half of the first rewind, before the 20 ms late fix
    slices[208] = 3;
    slices[215] = 1;
    let mut e = deferred_equals_settled(cfg(), &arrivals, &slices);
    assert_eq!(e.stats().background_steps, 24);
    assert!(e.stats().settled_inline > 0, "the flush settled the last rewind");
    let mut first = 0;
    e.take_first_outcomes(|_, _, _| first += 1);
    assert_eq!(first, 5, "each late fix's outcome, once");
    assert_eq!(e.sensors()[0].stats.duplicate, 1);
    assert_eq!(e.sensors()[1].stats.late, 5);
}

/// The window moves on and the capacity fills while entries are stale: an
/// entry that leaves the history is re-stepped first, so every final estimate
/// is exact, and a sample before the front is too late as before.
#[test]
fn the_history_filling_during_a_rewind_settles_what_leaves_it() {
    for config in [EngineConfig { history_ns: 50_000_000, ..cfg() }, EngineConfig { history_capacity: 40, ..cfg() }] {
        let mut arrivals: Vec<Sample> = (0..100).map(|i| imu(i * 2, i)).collect();
        arrivals.push(pos(160, 0, 1.0)); // 38 ms late
        // 60 more IMU samples with no time to settle: the stale entries leave.
        arrivals.extend((100..160).map(|i| imu(i * 2, i)));
        arrivals.push(pos(100, 1, 1.0)); // too late by then
        arrivals.push(pos(300, 2, 1.0));
        let e = deferred_equals_settled(config, &arrivals, &[]);
        assert_eq!(e.stats().background_steps, 0);
        assert_eq!(e.sensors()[1].stats.too_late, 1);
    }
}

mod ahead;
mod no_time;
mod timeline;
