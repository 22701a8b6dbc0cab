//! The live core against in-process sources and sinks.

use std::collections::VecDeque;

use fusion_shared::snapshot::health;
use fusion_shared::{ImuSample, PositionSample, VelocitySample};

use super::*;
use crate::config::Config;
use crate::engine::EngineConfig;
use crate::model::Model;
use crate::model::linear::LinearModel;

/// Hands out queued samples; once empty, asks for a stop.
struct QueueSource<'a> {
    queue: VecDeque<Sample>,
    stop: &'a AtomicBool,
}

impl SampleSource for QueueSource<'_> {
    fn next(&mut self, _: Option<(u64, u8)>) -> Option<Sample> {
        let s = self.queue.pop_front();
        if s.is_none() {
            self.stop.store(true, Ordering::Relaxed);
        }
        s
    }
    fn wait(&mut self, _: Duration) {}
}

/// A source with nothing in it.
fn none() -> QueueSource<'static> {
    static STOP: AtomicBool = AtomicBool::new(false);
    QueueSource { queue: VecDeque::new(), stop: &STOP }
}

/// Keeps every snapshot; refuses to send while `full`.
#[derive(Default)]
struct VecSink {
    sent: Vec<StateSnapshot>,
    next: Option<StateSnapshot>,
    flushes: usize,
    full: bool,
}

impl SnapshotSink for VecSink {
    fn publish(&mut self, fill: impl FnOnce(&mut StateSnapshot)) -> bool {
        let mut snap = self.next.take().unwrap_or_default();
        fill(&mut snap);
        if self.full {
            return false;
        }
        self.sent.push(snap);
        true
    }
    fn flush(&mut self) {
        self.flushes += 1;
    }
    fn refresh(&mut self) {}
    fn warm(&mut self) {}
}

fn core() -> LiveCore<LinearModel> {
    let config = Config::default_config();
    let engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    LiveCore::new(engine, config.health, Duration::from_secs(3600), now_ns())
}

const COV: [f64; 9] = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.25];

/// 0.3 s of samples stamped in the last second (not in the future).
fn samples() -> Vec<Sample> {
    let t0 = now_ns() - 1_000_000_000;
    let mut v = Vec::new();
    for k in 0..300u64 {
        let t = t0 + k * 1_000_000;
        v.push(ImuSample::new(t, 0, k, [0.1, 0.0, 0.0], [0.0; 3]).into());
        if k % 20 == 10 {
            // A fix arriving 5 ms late, and a velocity.
            v.push(PositionSample::new(t - 5_000_000, 1, k / 20, [0.0; 3], COV).into());
            v.push(VelocitySample::new(t, 2, k / 20, [0.0; 3], COV).into());
        }
    }
    v
}

/// The live core, driven in-process, publishes one snapshot per processed
/// sample with the estimate `fusiond replay`'s engine gives for the same
/// arrival order, and health and counters of every kind.
#[test]
fn the_live_core_publishes_what_the_engine_computes() {
    let stop = AtomicBool::new(false);
    let input = samples();
    let mut source = QueueSource { queue: input.iter().copied().collect(), stop: &stop };
    let mut sink = VecSink::default();
    let mut core = core();
    /// The reports the loop gave at its housekeeping.
    #[derive(Default)]
    struct Alive(Vec<RunReport>);
    impl LoopObserver for Alive {
        fn summary(&mut self, _: Summary) {}
        fn alive(&mut self, _: u64, report: RunReport) {
            self.0.push(report);
        }
    }
    let mut alive = Alive::default();
    let report = run(&mut core, &mut source, &mut sink, WaitMode::Spin, &stop, &mut alive);
    // One snapshot per sample, and one each time a late fix's correction landed.
    let with_input: Vec<&StateSnapshot> =
        sink.sent.iter().filter(|s| s.input_kind != fusion_shared::snapshot::INPUT_NONE).collect();
    assert_eq!(with_input.len(), input.len());
    assert_eq!(report, RunReport { received: input.len() as u64, snapshots: sink.sent.len() as u64 });
    // The first housekeeping is due at once: the loop said it turns, with its counts.
    assert!(!alive.0.is_empty());
    assert!(alive.0.windows(2).all(|w| w[0].received <= w[1].received));
    assert!(sink.flushes >= 1);

    // Each snapshot is what the engine gives when the rewind steps the loop did
    // in its idle time before that sample are done at the same points (the rule
    // of `fusiond replay --compare`); the provisional ones say so.
    let config = Config::default_config();
    let mut engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let mut settled = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let mut provisional = 0;
    for (i, (sample, snap)) in input.iter().zip(&with_input).enumerate() {
        while engine.stats().background_steps < snap.background_steps && engine.settle_step() {}
        assert_eq!(engine.stats().background_steps, snap.background_steps, "snapshot {i}");
        engine.insert_deferred(sample, None, &mut |_| {});
        settled.insert(sample, None, &mut |_| {});
        let latest = engine.latest().unwrap();
        assert_eq!(snap.state(), LinearModel::x(&latest.state), "snapshot {i}");
        assert_eq!(snap.covariance(), LinearModel::covariance(&latest.state), "snapshot {i}");
        assert_eq!((snap.input_seq, snap.input_kind), (sample.seq(), sample.kind() as u32));
        let pending = engine.correction().map_or((0, 0), |c| (c.steps as u64, c.since_t_ns));
        assert_eq!((snap.pending_steps, snap.pending_since_t_ns), pending, "snapshot {i}");
        if snap.settled() {
            assert_eq!(snap.state(), LinearModel::x(&settled.latest().unwrap().state), "snapshot {i}");
        } else {
            provisional += 1;
            assert!(snap.pending_since_t_ns <= snap.t_ns);
        }
    }
    assert!(provisional >= 15, "every late fix's own snapshot is provisional: {provisional}");
    assert!(sink.sent.windows(2).all(|w| w[1].seq == w[0].seq + 1));
    // At the stop, the correction in progress was settled and published.
    let last = sink.sent.last().unwrap();
    assert!(last.settled() && last.background_steps > 0);
    assert_eq!(last.state(), LinearModel::x(&settled.latest().unwrap().state));
    assert_eq!(last.covariance(), LinearModel::covariance(&settled.latest().unwrap().state));
    assert_eq!(last.health, health::OK, "reasons {:?}", last.health_reason_names().collect::<Vec<_>>());
    let velocity = last.sensor_counters().iter().find(|c| c.sample_kind() == Some(SampleKind::Velocity)).unwrap();
    assert_eq!((velocity.counts.received, velocity.counts.fused), (15, 15));
    assert!(last.rewinds > 0, "late fixes were fused by rewind");
}

#[test]
fn a_stream_that_stops_is_reported_stale_without_input_and_refused_sends_are_not_counted() {
    let mut core = core();
    let mut sink = VecSink::default();
    let t0 = now_ns();
    core.handle(ImuSample::new(t0, 0, 0, [0.0; 3], [0.0; 3]).into(), &mut sink);
    core.handle(PositionSample::new(t0, 1, 0, [0.0; 3], COV).into(), &mut sink);
    assert_eq!(core.health().pair(), (health::OK, 0));
    // 150 ms later the IMU (100 ms timeout) is stale: a health-only snapshot.
    assert!(core.housekeeping(t0 + 150_000_000, &mut none(), &mut sink).is_none());
    let last = sink.sent.last().unwrap();
    assert_eq!((last.health, last.health_reasons), (health::DEGRADED, health::IMU_STALE));
    assert_eq!(last.input_kind, fusion_shared::snapshot::INPUT_NONE);
    sink.full = true;
    core.handle(ImuSample::new(t0 + 1, 0, 1, [0.0; 3], [0.0; 3]).into(), &mut sink);
    assert_eq!(core.report(), RunReport { received: 3, snapshots: 3 });
}

#[test]
fn summaries_come_at_their_interval_with_counts_per_kind() {
    let config = Config::default_config();
    let engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let t0 = now_ns();
    let mut core = LiveCore::new(engine, config.health, Duration::from_secs(1), t0);
    let mut sink = VecSink::default();
    for s in samples().into_iter().take(40) {
        core.handle(s, &mut sink);
    }
    assert!(core.housekeeping(t0 + 500_000_000, &mut none(), &mut sink).is_none());
    let s = core.housekeeping(t0 + 1_500_000_000, &mut none(), &mut sink).expect("a summary after 1 s");
    // IMU samples 0..=35 and a fix and a velocity after the 10th and the 30th.
    assert_eq!(s.kinds[SampleKind::Imu.index()].received, 36);
    assert_eq!(s.kinds[SampleKind::Velocity.index()].received, 2);
    // One per sample, and a health-only one at each housekeeping: the IMU went
    // stale (after 100 ms), then the position and velocity (after 1 s).
    assert_eq!(s.snapshots, 42);
    assert_eq!(
        s.health.1,
        health::stale(SampleKind::Imu) | health::stale(SampleKind::Position) | health::stale(SampleKind::Velocity)
    );
}

/// Every sample refused (stamped on another clock): no sample publishes a
/// snapshot, but the housekeeping does, at most every REFUSAL_SNAPSHOT_NS, with
/// the refusals by reason (the sensor has no row); the summary counts them.
#[test]
fn refused_samples_are_published_by_reason_while_nothing_else_is() {
    let config = Config::default_config();
    let engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let t0 = now_ns();
    let mut core = LiveCore::new(engine, config.health, Duration::from_secs(1), t0);
    let mut sink = VecSink::default();
    for k in 0..50 {
        core.handle(ImuSample::new(1_000_000 + k, 0, k, [0.0; 3], [0.0; 3]).into(), &mut sink);
    }
    core.handle(ImuSample::new(now_ns(), 3, 0, [f64::NAN; 3], [0.0; 3]).into(), &mut sink);
    assert!(sink.sent.is_empty());
    assert!(core.housekeeping(t0 + REFUSAL_SNAPSHOT_NS, &mut none(), &mut sink).is_none());
    assert_eq!(sink.sent.len(), 1);
    let snap = sink.sent[0];
    assert_eq!(snap.input_kind, fusion_shared::snapshot::INPUT_NONE);
    assert_eq!((snap.health, snap.sensor_count, snap.state_len), (health::INITIALISING, 0, 0));
    assert_eq!(
        snap.rejection_counts().collect::<Vec<_>>(),
        [(rejection::NON_FINITE, 1), (rejection::PAST_TIMESTAMP, 50)]
    );
    assert_eq!((snap.rejected(), snap.unknown_sensor), (51, 51));
    // Nothing new: nothing published. New refusals: not before the interval.
    core.housekeeping(t0 + REFUSAL_SNAPSHOT_NS + HOUSEKEEPING_NS, &mut none(), &mut sink);
    core.handle(ImuSample::new(1_000_000, 0, 99, [0.0; 3], [0.0; 3]).into(), &mut sink);
    core.housekeeping(t0 + REFUSAL_SNAPSHOT_NS + 2 * HOUSEKEEPING_NS, &mut none(), &mut sink);
    assert_eq!(sink.sent.len(), 1);
    core.housekeeping(t0 + 2 * REFUSAL_SNAPSHOT_NS + 2 * HOUSEKEEPING_NS, &mut none(), &mut sink);
    assert_eq!(sink.sent.len(), 2);
    assert_eq!(sink.sent[1].rejections[rejection::PAST_TIMESTAMP as usize], 51);
    let summary = core.housekeeping(t0 + 1_500_000_000, &mut none(), &mut sink).expect("a summary");
    assert_eq!(summary.rejections[rejection::PAST_TIMESTAMP as usize], 51);
    assert!(
        crate::summary::format(&summary).contains("invalid 52 (non-finite value 1, timestamp too far in the past 51)")
    );
}
