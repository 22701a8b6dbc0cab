//! The live core against in-process sources and sinks.

use std::collections::VecDeque;

use fusion_shared::snapshot::health;
use fusion_shared::{ImuSample, PositionSample, VelocitySample};

use super::*;
use crate::config::Config;
use crate::engine::EngineConfig;
use crate::model::Model;
use crate::model::linear::LinearModel;

/// Calls of a trickling [`QueueSource`] per sample: the sample, the end of
/// its turn, then [`IDLE_TURNS`] idle turns.
const TRICKLE_CALLS: u8 = 2 + IDLE_TURNS;

/// Idle turns after each sample of a trickling [`QueueSource`]. Each idle
/// turn does at least one step of a pending rewind ([`LiveCore::settle_slice`]),
/// however fast the machine: a late fix here replays at most 7 samples, so by
/// its next sample every rewind has landed and a later idle turn has stepped
/// ahead. What the loop does between two samples then depends on the input
/// alone, not on how many steps fit in a slice of [`SLICE_NS`].
const IDLE_TURNS: u8 = 12;

/// Hands out queued samples; once empty, asks for a stop. `trickle`: one
/// sample a turn, and [`IDLE_TURNS`] turns with none (idle) after each.
struct QueueSource<'a> {
    queue: VecDeque<Sample>,
    stop: &'a AtomicBool,
    trickle: bool,
    /// Trickle: calls since the last sample (the turn's end, then idle turns).
    calls: u8,
}

impl SampleSource for QueueSource<'_> {
    fn next(&mut self, _: Option<(u64, u8)>) -> Option<Sample> {
        if self.trickle {
            self.calls = (self.calls + 1) % TRICKLE_CALLS;
            if self.calls != 1 {
                return None;
            }
        }
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
    QueueSource { queue: VecDeque::new(), stop: &STOP, trickle: false, calls: 0 }
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
    publishes_what_the_engine_computes(false);
}

/// The same with a turn of idle time after each sample: the loop settles the
/// rewinds there and steps the estimate ahead to the next IMU instant
/// ([`Engine::step_ahead`]), and every snapshot is still the engine's estimate.
#[test]
fn idle_steps_ahead_leave_every_estimate_as_it_was() {
    let core = publishes_what_the_engine_computes(true);
    let stats = core.engine().stats();
    // Of the 300 IMU samples, each after the first two (the interval is known
    // from the second) starts from a state stepped ahead in the idle turns
    // before it. The 15 late fixes and 15 velocities each discard the state
    // stepped ahead (it was stepped past them), and the idle turns after them
    // step ahead again; the last idle turns step past the last sample too.
    // Every rewind lands within the idle turns (`IDLE_TURNS`), so none of
    // this depends on the machine's speed.
    assert_eq!(stats.stepped_from_ahead, 298, "{stats:?}");
    assert_eq!(stats.stepped_ahead, 298 + 15 + 15 + 1, "{stats:?}");
}

fn publishes_what_the_engine_computes(trickle: bool) -> LiveCore<LinearModel> {
    let stop = AtomicBool::new(false);
    let input = samples();
    let mut source = QueueSource { queue: input.iter().copied().collect(), stop: &stop, trickle, calls: 0 };
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
    core
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

/// The default config with two IMUs (ids 0 and 1) averaged, waiting `wait_ns`
/// for an instant's last sample.
fn two_imu_config(wait_ns: u64) -> Config {
    let text = crate::config::default_config_text()
        .replace("instant_wait_ns = 250_000", &format!("instant_wait_ns = {wait_ns}"))
        + "[[sensor]]\nname = \"imu-a\"\nid = 0\nkinds = [\"imu\"]\n\
           [[sensor]]\nname = \"imu-b\"\nid = 1\nkinds = [\"imu\"]\n";
    let config = Config::parse(&text).unwrap();
    assert_eq!(config.imu.instant_wait_ns, wait_ns);
    config
}

/// A core whose config has two IMUs (ids 0 and 1) averaged, waiting `wait_ns`
/// for an instant's last sample.
fn two_imu_core(wait_ns: u64) -> LiveCore<LinearModel> {
    let config = two_imu_config(wait_ns);
    let engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    LiveCore::new(engine, config.health, Duration::from_secs(3600), now_ns())
}

/// Two IMUs averaged: one snapshot per instant, after its last sample, with
/// the engine's estimate after it. An IMU that misses an instant delays its
/// snapshot to the due time (once: the next instant expects the IMUs of this
/// one), another sample publishes an open instant at once, and a wait of 0
/// gives a snapshot per sample again.
#[test]
fn averaged_imus_publish_one_snapshot_per_instant() {
    let mut core = two_imu_core(1_000_000);
    let mut sink = VecSink::default();
    let t0 = now_ns() - 500_000_000;
    let imu = |k: u64, sensor: u32| -> Sample {
        ImuSample::new(t0 + k * 1_000_000, sensor, k, [0.1, 0.0, 0.0], [0.0; 3]).into()
    };
    let config = two_imu_config(1_000_000);
    let mut engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let mut step = |s: &Sample| engine.insert(s, None, &mut |_| {});
    let expect = |core: &LiveCore<LinearModel>, sink: &VecSink, n: usize, named: (u32, u64)| {
        assert_eq!(sink.sent.len(), n);
        let snap = sink.sent.last().unwrap();
        assert_eq!((snap.input_sensor, snap.input_seq), named);
        assert_eq!(snap.state(), LinearModel::x(&core.engine().latest().unwrap().state));
        assert_eq!(core.instant_due(), None);
    };
    // The first instant: nothing known to wait for.
    for s in [imu(0, 0), imu(0, 1)] {
        core.handle(s, &mut sink);
        step(&s);
    }
    expect(&core, &sink, 2, (1, 0));
    for k in 1..50 {
        core.handle(imu(k, 0), &mut sink);
        step(&imu(k, 0));
        assert!(core.instant_due().is_some(), "instant {k} open");
        core.handle(imu(k, 1), &mut sink);
        step(&imu(k, 1));
        expect(&core, &sink, 2 + k as usize, (1, k));
    }
    // The replay engine, with a snapshot per instant, computed the same.
    let last = sink.sent.last().unwrap();
    assert_eq!(last.state(), LinearModel::x(&engine.latest().unwrap().state));
    assert_eq!(last.covariance(), LinearModel::covariance(&engine.latest().unwrap().state));

    // IMU 1 misses instant 50: nothing goes out before the due time, then the
    // snapshot names IMU 0's sample.
    core.handle(imu(50, 0), &mut sink);
    let due = core.instant_due().expect("instant 50 open");
    assert!(!core.publish_due(due - 1, &mut sink));
    assert_eq!(sink.sent.len(), 51);
    assert!(core.publish_due(due, &mut sink));
    expect(&core, &sink, 52, (0, 50));
    // Instant 51 expects IMU 0 alone: its sample publishes at once; IMU 1
    // coming back publishes again.
    core.handle(imu(51, 0), &mut sink);
    expect(&core, &sink, 53, (0, 51));
    core.handle(imu(51, 1), &mut sink);
    expect(&core, &sink, 54, (1, 51));
    // A fix while an instant is open carries it.
    core.handle(imu(52, 0), &mut sink);
    let fix = PositionSample::new(t0 + 52_000_000 + 1, 1, 0, [0.0; 3], COV);
    core.handle(fix.into(), &mut sink);
    assert_eq!(sink.sent.last().unwrap().input_kind, SampleKind::Position as u32);
    expect(&core, &sink, 55, (1, 0));
    // Instant 52 had IMU 0 alone: both samples of 53 publish. At the stop,
    // an open instant is published.
    core.handle(imu(53, 0), &mut sink);
    expect(&core, &sink, 56, (0, 53));
    core.handle(imu(53, 1), &mut sink);
    core.handle(imu(54, 0), &mut sink);
    assert_eq!(sink.sent.len(), 57);
    core.settle_all(&mut sink);
    expect(&core, &sink, 58, (0, 54));

    // A wait of 0: a snapshot per sample.
    let mut core = two_imu_core(0);
    let mut sink = VecSink::default();
    for k in 0..10 {
        core.handle(imu(k, 0), &mut sink);
        core.handle(imu(k, 1), &mut sink);
    }
    assert_eq!(sink.sent.len(), 20);
}

/// In the loop, an instant one IMU misses goes out though nothing else
/// arrives: in spin mode at its due time, in event mode before the loop sleeps.
#[test]
fn the_loop_publishes_an_open_instant_when_it_is_due() {
    /// Nothing arrives; stops the loop 20 ms after the start. Records the
    /// snapshots sent by the time of each wait.
    struct Quiet<'a> {
        stop: &'a AtomicBool,
        started: std::time::Instant,
        waits: usize,
    }
    impl SampleSource for Quiet<'_> {
        fn next(&mut self, _: Option<(u64, u8)>) -> Option<Sample> {
            if self.started.elapsed() > Duration::from_millis(20) {
                self.stop.store(true, Ordering::Relaxed);
            }
            None
        }
        fn wait(&mut self, timeout: Duration) {
            std::thread::sleep(timeout.min(Duration::from_millis(1)));
            self.waits += 1;
        }
    }
    struct Nothing;
    impl LoopObserver for Nothing {
        fn summary(&mut self, _: Summary) {}
    }
    for mode in [WaitMode::Spin, WaitMode::Event] {
        let t0 = now_ns() - 500_000_000;
        let imu = |k: u64, sensor: u32| -> Sample {
            ImuSample::new(t0 + k * 1_000_000, sensor, k, [0.1, 0.0, 0.0], [0.0; 3]).into()
        };
        let mut core = two_imu_core(2_000_000);
        let mut sink = VecSink::default();
        for s in [imu(0, 0), imu(0, 1), imu(1, 0), imu(1, 1), imu(2, 0)] {
            core.handle(s, &mut sink);
        }
        assert_eq!((sink.sent.len(), core.instant_due().is_some()), (3, true));
        let held_received = now_ns();
        let stop = AtomicBool::new(false);
        let mut source = Quiet { stop: &stop, started: std::time::Instant::now(), waits: 0 };
        run(&mut core, &mut source, &mut sink, mode, &stop, &mut Nothing);
        let imus: Vec<&StateSnapshot> = sink.sent.iter().filter(|s| s.input_kind == SampleKind::Imu as u32).collect();
        assert_eq!(imus.len(), 4, "{mode:?}");
        let snap = imus[3];
        assert_eq!((snap.input_sensor, snap.input_seq), (0, 2), "{mode:?}");
        assert_eq!(core.instant_due(), None);
        match mode {
            // The due time: 2 ms after the sample arrived.
            WaitMode::Spin => assert!(snap.publish_ns >= snap.input_received_ns + 2_000_000),
            // Before the first sleep.
            WaitMode::Event => assert!(snap.publish_ns < held_received + 1_000_000, "published before sleeping"),
        }
    }
}
