//! The live core: engine, health, snapshot filling, housekeeping and summary
//! pacing, behind two small traits, with no transport in it.
//!
//! - A [`SampleSource`] gives the next received sample (the iceoryx2 source merges
//!   its subscribers by timestamp) and sleeps until woken.
//! - A [`SnapshotSink`] lends a snapshot to fill and sends it, wakes readers after
//!   a batch, lets late readers connect, and keeps its next chunks warm.
//!
//! [`run`] is the loop of `fusiond run`: each turn takes the waiting samples (at
//! most [`BATCH`]), feeds each to the engine with the daemon's clock and publishes
//! one [`StateSnapshot`] per processed sample, then flushes the sink once. Several
//! IMUs averaged make one snapshot per IMU instant: a sample that leaves its
//! instant open (an IMU of the instant before has yet to send) publishes
//! nothing; the sample that completes it, or any other sample, publishes the
//! instant's snapshot, and an IMU that misses the instant delays it by at most
//! [`ImuConfig::instant_wait_ns`](crate::frames::ImuConfig::instant_wait_ns).
//! In event mode the instant's snapshot also goes out when the loop has
//! nothing else to do and would sleep. No rewind slice runs while an instant
//! is open. Every
//! [`HOUSEKEEPING_NS`] it re-evaluates the health (a stream that stopped is
//! marked stale even though nothing arrives, and a health-only snapshot says so),
//! refreshes the sink's connections, tells the [`LoopObserver`] that the loop
//! turns (the systemd watchdog), and every summary interval hands it a
//! [`Summary`]. Between turns it busy-polls ([`WaitMode::Spin`],
//! warming what the next sample touches every [`WARM_NS`]) or sleeps on the
//! source ([`WaitMode::Event`]).
//!
//! A late sample does not hold up the samples behind it: the engine only
//! places it ([`Engine::insert_deferred`], no filter step), an in-order sample
//! waiting beside it is taken first, the samples after it are published at
//! in-order cost from the provisional head, and the rewind's
//! re-processing runs in slices of at most [`SLICE_NS`] while no sample waits
//! (and at least every [`SLICE_GAP_NS`] under a sustained backlog). Snapshots
//! published meanwhile say they are provisional
//! ([`StateSnapshot::pending_steps`]); when the correction lands, a settled
//! snapshot is published at once. At shutdown a pending correction is settled
//! and published before the loop returns.
//!
//! The propagation to the next IMU instant runs in idle time too: once nothing
//! waits, the loop steps the estimate ahead to the instant the IMU's interval
//! says comes next ([`Engine::step_ahead`]), and the sample at that time only
//! fuses. The estimates are the same bits either way.
//!
//! A test drives it in-process with a vector source and a recording sink
//! (`tests` below); `ipc.rs` plugs in iceoryx2.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fusion_shared::snapshot::rejection;
use fusion_shared::{Counters, Sample, SampleKind, StateSnapshot, now_ns};
use hdrhistogram::Histogram;

use crate::engine::{Engine, Insert};
use crate::health::{HealthConfig, HealthMonitor, HealthNow};
use crate::measurement::{self, Steps};
use crate::model::StepOutcome;
use crate::snapshot::{self, Input};
use crate::summary::{Rejections, Summary};
use refusals::{ModelRefusalWarnings, RefusalWarnings};

mod instant;
mod refusals;

use instant::HeldInstant;

/// Health and housekeeping period.
pub const HOUSEKEEPING_NS: u64 = 10_000_000;
/// While samples are refused in validation and nothing else is published,
/// a snapshot (input [`INPUT_NONE`](fusion_shared::snapshot::INPUT_NONE))
/// carrying the refusal counters is published at most this often, ns: a
/// reader sees why there is no estimate.
pub const REFUSAL_SNAPSHOT_NS: u64 = 100_000_000;
/// Spin mode: while no sample arrives, the memory the next sample will touch is
/// read (and the sink's next snapshot written) this often, so that the next
/// sample finds it in the cache.
pub const WARM_NS: u64 = 100_000;
/// Samples per turn before housekeeping gets a look in.
pub const BATCH: usize = 512;
/// Longest slice of a pending rewind, ns: a sample that arrives while one runs
/// waits at most this long plus one step (about 0.35 µs for `ins`).
pub const SLICE_NS: u64 = 2_000;
/// Under a backlog that leaves no idle turn, a slice of a pending rewind still
/// runs this often, ns, so that a correction lands within a few milliseconds.
pub const SLICE_GAP_NS: u64 = 1_000_000;

/// How the daemon waits for samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitMode {
    /// Busy-poll the source: lowest latency, one core fully used.
    Spin,
    /// Sleep on the source's wake-up between samples: no CPU while idle.
    Event,
}

/// What the loop reports besides snapshots, from its own thread.
pub trait LoopObserver {
    /// The summary of an interval (at most every `summary_interval`).
    fn summary(&mut self, summary: Summary);
    /// The loop is turning: called at every housekeeping (every
    /// [`HOUSEKEEPING_NS`] while the loop is healthy, never while it is stuck),
    /// with the time and the loop's counts so far.
    fn alive(&mut self, _now_ns: u64, _report: RunReport) {}
}

/// Where samples come from.
pub trait SampleSource {
    /// The next waiting sample, if any (never blocks). `newest` is the
    /// `(t_ns, rank)` of the newest sample processed: a source that holds
    /// several samples may hand out one that comes after it (in order, one
    /// step) before one that does not (late: its snapshot is provisional
    /// anyway, and the in-order sample's need not wait for it).
    fn next(&mut self, newest: Option<(u64, u8)>) -> Option<Sample>;
    /// Sleeps until a sample may be waiting, at most `timeout`.
    fn wait(&mut self, timeout: Duration);
    /// Housekeeping (every [`HOUSEKEEPING_NS`]): look for new or gone senders.
    fn refresh(&mut self) {}
    /// The end of a turn: give back what the turn held of the senders' buffers.
    fn end_turn(&mut self) {}
    /// State readers that reported being refused a slot so far.
    fn readers_refused(&self) -> u64 {
        0
    }
}

/// Where snapshots go.
pub trait SnapshotSink {
    /// Lends a snapshot (a default one, or one this sink lent before) to `fill`,
    /// then sends it. Returns whether it was sent; failures are the sink's to count.
    fn publish(&mut self, fill: impl FnOnce(&mut StateSnapshot)) -> bool;
    /// After a turn that published: wake the readers, prepare the next snapshot.
    fn flush(&mut self);
    /// Housekeeping: let readers that connected since the last send get the latest.
    fn refresh(&mut self);
    /// Spin mode, while idle: touch the next snapshot's memory.
    fn warm(&mut self);
}

/// What a run did, for the caller (and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunReport {
    /// Samples taken from the source.
    pub received: u64,
    /// Snapshots published.
    pub snapshots: u64,
}

/// The live state of the daemon besides its transport.
pub struct LiveCore<M: Steps> {
    engine: Engine<M>,
    health: HealthMonitor,
    health_now: HealthNow,
    published_health: HealthNow,
    latency: Histogram<u64>,
    report: RunReport,
    summary_ns: u64,
    next_housekeeping: u64,
    /// Start of the summary interval, and the counters, snapshot count and
    /// refusals by reason then.
    last_summary: (u64, [Counters; SampleKind::COUNT], u64, Rejections),
    /// Refused readers, as last read from the source and as last published.
    readers_refused: (u64, u64),
    /// Re-initialisations of the filter already logged.
    reinitialisations_logged: u64,
    /// Samples refused in validation: so far, and in the last published snapshot.
    refused: (u64, u64),
    /// When a snapshot was last published for refusals alone.
    refusal_published_ns: u64,
    /// The sensors and reasons whose refusals were logged.
    refusal_warnings: RefusalWarnings,
    model_refusals: ModelRefusalWarnings,
    /// [`ImuConfig::instant_wait_ns`](crate::frames::ImuConfig::instant_wait_ns)
    /// (0: a snapshot after every sample).
    instant_wait_ns: u64,
    /// The snapshot of an open IMU instant, held back until its last sample.
    held: Option<HeldInstant>,
}

impl<M: Steps> LiveCore<M> {
    /// A core around `engine`, with a summary every `summary_interval` from `now_ns`.
    pub fn new(engine: Engine<M>, health: HealthConfig, summary_interval: Duration, now_ns: u64) -> Self {
        let initialising = HealthNow::INITIALISING;
        let monitor = HealthMonitor::new(health);
        let monitor = if M::NEEDS_POSITION { monitor } else { monitor.without_position() };
        let instant_wait_ns = engine.model().frames().imus().config.instant_wait_ns;
        Self {
            health: monitor.with_frames(engine.model().frames()),
            engine,
            health_now: initialising,
            published_health: initialising,
            // 1 ns to 10 s at 3 significant digits: allocated once, here. The
            // bounds are constants this crate checks in a test.
            latency: Histogram::new_with_bounds(1, 10_000_000_000, 3).expect("valid histogram bounds"),
            report: RunReport::default(),
            summary_ns: summary_interval.as_nanos().clamp(1, u64::MAX as u128) as u64,
            next_housekeeping: now_ns,
            last_summary: (now_ns, [Counters::default(); SampleKind::COUNT], 0, [0; rejection::MAX]),
            readers_refused: (0, 0),
            reinitialisations_logged: 0,
            refused: (0, 0),
            refusal_published_ns: 0,
            refusal_warnings: RefusalWarnings::default(),
            model_refusals: ModelRefusalWarnings::default(),
            instant_wait_ns,
            held: None,
        }
    }

    /// The engine.
    pub fn engine(&self) -> &Engine<M> {
        &self.engine
    }

    /// What the run did so far.
    pub fn report(&self) -> RunReport {
        self.report
    }

    /// Health state, reasons and stale sensors as last evaluated.
    pub fn health(&self) -> HealthNow {
        self.health_now
    }

    fn initialised(&self) -> bool {
        self.engine.latest().is_some_and(|e| M::initialised(&e.state))
    }

    /// Re-evaluates the health at `now`, and logs a re-initialisation of the
    /// filter the first time it is seen (a rare event, never per sample).
    fn evaluate_health(&mut self, now: u64) {
        let reinitialisations = self.engine.latest().map_or(0, |e| M::diagnostics(&e.state).reinitialisations);
        if reinitialisations > self.reinitialisations_logged {
            let (t_ns, kind) = self.engine.latest().map_or((0, SampleKind::Imu), |e| (e.key.t_ns, e.key.kind));
            if measurement::lockout_rule(kind) == crate::model::lockout::LockoutRule::Resets {
                tracing::warn!(
                    reinitialisations,
                    t_ns,
                    kind = kind.name(),
                    "filter reset from a {} sample: every one was gated for the lock-out time ([gating] \
                     lockout_ns); what it observes now comes from it",
                    kind.name()
                );
            } else {
                tracing::warn!(
                    reinitialisations,
                    t_ns,
                    "filter re-initialised from the position fixes: every fix was gated for the lock-out time \
                     ([gating] lockout_ns); position and velocity now come from the fixes"
                );
            }
        }
        self.reinitialisations_logged = reinitialisations;
        let initialised = self.initialised();
        self.health_now = self.health.evaluate(self.engine.sensors(), now, initialised, reinitialisations);
    }

    /// Feeds one sample to the engine and publishes the resulting snapshot,
    /// unless the sample leaves its IMU instant open: then the snapshot waits
    /// for the sample that completes the instant, for another sample, or for
    /// the instant's due time ([`publish_due`](Self::publish_due)).
    pub fn handle(&mut self, sample: Sample, sink: &mut impl SnapshotSink) {
        self.report.received += 1;
        let received_ns = now_ns();
        let replayed = match self.engine.insert_deferred(&sample, Some(received_ns), &mut |_| {}) {
            Insert::Processed { replayed, outcome } => {
                if let Some(slot) = self.engine.slot_of(sample.kind(), sample.sensor()) {
                    self.health.record(slot, &outcome, measurement::exact(&sample));
                }
                if outcome == StepOutcome::Refused {
                    self.model_refusals.warn(self.engine.model(), &sample);
                }
                replayed
            }
            // Late: its outcome comes with the rewind (`record_first_outcomes`).
            Insert::Placed { replayed } => replayed,
            Insert::Rejected(why) => {
                // Counted by the engine; the counts reach readers with the next
                // snapshot (or a housekeeping one while nothing else is published).
                self.refused.0 += 1;
                self.refusal_warnings.warn(&sample, why, received_ns);
                return;
            }
            _ => return,
        };
        // Late samples the insert had to process at once (leaving the history).
        self.record_first_outcomes();
        if replayed == 0 && self.opens_instant(&sample) {
            // The wait is bounded from the instant's first sample held.
            let due_ns = self.held.map_or(received_ns.saturating_add(self.instant_wait_ns), |h| h.due_ns);
            self.held = Some(HeldInstant { sample, received_ns, due_ns });
            return;
        }
        // This snapshot carries an instant held before it, if any.
        self.held = None;
        self.publish_sample(sink, &sample, received_ns, replayed, received_ns);
    }

    /// Publishes the snapshot of `sample` (processed, `replayed` later samples
    /// re-processed) with the health evaluated at `now`, and records its latency.
    fn publish_sample(
        &mut self,
        sink: &mut impl SnapshotSink,
        sample: &Sample,
        received_ns: u64,
        replayed: usize,
        now: u64,
    ) {
        self.evaluate_health(now);
        let input = Input { sample, received_ns, replayed };
        if let Some(published_ns) = self.publish(sink, Some(input))
            && replayed == 0
            && sample.sent_ns() > 0
        {
            // Out-of-range values (clock skew between processes) are not recorded.
            let _ = self.latency.record(published_ns.saturating_sub(sample.sent_ns()));
        }
    }

    /// Fills the sink's snapshot (the estimate, `input` and the current health),
    /// stamps it; returns the publish time if it was sent.
    ///
    /// [`snapshot::fill`] writes every field that can change, so filling a
    /// snapshot that holds a default (or an older) one gives what filling one
    /// snapshot over and over would (`snapshot` tests).
    fn publish(&mut self, sink: &mut impl SnapshotSink, input: Option<Input<'_>>) -> Option<u64> {
        let mut publish_ns = 0;
        let (engine, health, seq) = (&self.engine, self.health_now, self.report.snapshots);
        let (readers_refused, refused) = (self.readers_refused.0, self.refused.0);
        let sent = sink.publish(|snap| {
            snapshot::fill(snap, engine, input, health);
            snap.readers_refused = readers_refused;
            snap.seq = seq;
            publish_ns = now_ns();
            snap.publish_ns = publish_ns;
        });
        sent.then(|| {
            self.report.snapshots += 1;
            self.readers_refused.1 = readers_refused;
            self.refused.1 = refused;
            publish_ns
        })
    }

    /// Takes up to [`BATCH`] waiting samples from `source` and publishes their
    /// snapshots, then flushes the sink once. Returns the samples taken.
    pub fn turn(&mut self, source: &mut impl SampleSource, sink: &mut impl SnapshotSink) -> usize {
        let snapshots_before = self.report.snapshots;
        let mut taken = 0;
        while taken < BATCH {
            let newest = self.engine.latest().map(|e| (e.key.t_ns, e.key.rank));
            let Some(sample) = source.next(newest) else { break };
            self.handle(sample, sink);
            taken += 1;
        }
        if self.held.is_some() {
            self.publish_due(now_ns(), sink);
        }
        if self.report.snapshots > snapshots_before {
            self.published_health = self.health_now;
            sink.flush();
        }
        source.end_turn();
        taken
    }

    /// Runs the housekeeping if it is due at `now`: re-evaluates the health and
    /// publishes a health-only snapshot if it changed, refreshes the sink, and
    /// returns the summary of the interval when one is due.
    pub fn housekeeping(
        &mut self,
        now: u64,
        source: &mut impl SampleSource,
        sink: &mut impl SnapshotSink,
    ) -> Option<Summary> {
        if now < self.next_housekeeping {
            return None;
        }
        self.next_housekeeping = now + HOUSEKEEPING_NS;
        self.evaluate_health(now);
        self.readers_refused.0 = source.readers_refused();
        let changed = (self.health_now != self.published_health || self.readers_refused.0 != self.readers_refused.1)
            && self.engine.latest().is_some();
        // Refused samples publish nothing themselves: while they are all there
        // is (no estimate yet, say), their counts go out at a low rate.
        let refusals = self.refused.0 != self.refused.1 && now >= self.refusal_published_ns + REFUSAL_SNAPSHOT_NS;
        if (changed || refusals) && self.publish(sink, None).is_some() {
            // Nothing was published but the health changed (a stream went
            // stale), a reader was refused, or samples were: say so.
            self.published_health = self.health_now;
            if refusals {
                self.refusal_published_ns = now;
            }
            sink.flush();
        }
        sink.refresh();
        source.refresh();
        if now.saturating_sub(self.last_summary.0) < self.summary_ns {
            return None;
        }
        let mut kinds = [Counters::default(); SampleKind::COUNT];
        for (total, &kind) in kinds.iter_mut().zip(SampleKind::ALL) {
            *total = self.engine.totals(Some(kind));
        }
        let h = &self.latency;
        let latency_ns = (!h.is_empty()).then(|| (h.value_at_quantile(0.5), h.value_at_quantile(0.99), h.max()));
        let (since, before, snapshots, rejections_before) = &self.last_summary;
        let rejections_now = self.engine.stats().rejections;
        let mut rejections = [0; rejection::MAX];
        for ((d, n), b) in rejections.iter_mut().zip(rejections_now).zip(rejections_before) {
            *d = n.saturating_sub(*b);
        }
        let mut interval = [Counters::default(); SampleKind::COUNT];
        for ((d, now_c), then_c) in interval.iter_mut().zip(&kinds).zip(before) {
            *d = now_c.since(then_c);
        }
        let summary = Summary {
            interval_s: (now - since) as f64 * 1e-9,
            kinds: interval,
            snapshots: self.report.snapshots - snapshots,
            latency_ns,
            health: self.health_now.pair(),
            standing: self
                .engine
                .latest()
                .map(|e| M::diagnostics(&e.state))
                .map(|d| (d.standing, d.standstill_updates)),
            rejections,
        };
        self.latency.reset();
        self.last_summary = (now, kinds, self.report.snapshots, rejections_now);
        Some(summary)
    }

    /// Whether a late sample's correction has not yet reached the estimate.
    pub fn correction_pending(&self) -> bool {
        self.engine.correction().is_some()
    }

    /// Works a pending correction in for at most [`SLICE_NS`] (at least one
    /// step). When it lands, publishes the settled estimate (a snapshot without
    /// input) and wakes the readers. Returns whether work remains.
    pub fn settle_slice(&mut self, sink: &mut impl SnapshotSink) -> bool {
        let start = now_ns();
        let mut more = true;
        while more {
            more = self.engine.settle_step();
            self.record_first_outcomes();
            if now_ns().saturating_sub(start) >= SLICE_NS {
                break;
            }
        }
        if !more {
            self.landed(sink);
        }
        more
    }

    /// Publishes an open instant's snapshot, then settles a pending correction
    /// whole and publishes the settled estimate (at shutdown).
    pub fn settle_all(&mut self, sink: &mut impl SnapshotSink) {
        self.publish_open(sink);
        if self.correction_pending() {
            while self.engine.settle_step() {
                self.record_first_outcomes();
            }
            self.record_first_outcomes();
            self.landed(sink);
        }
    }

    /// Hands the outcomes of late samples processed for the first time to the
    /// health (their NIS), as an in-order sample's is at once.
    fn record_first_outcomes(&mut self) {
        let health = &mut self.health;
        self.engine.take_first_outcomes(|slot, outcome, exact| health.record(slot, outcome, exact));
    }

    /// A correction landed: the health of the settled estimate, and a snapshot of it.
    fn landed(&mut self, sink: &mut impl SnapshotSink) {
        self.evaluate_health(now_ns());
        if self.publish(sink, None).is_some() {
            self.published_health = self.health_now;
            sink.flush();
        }
    }

    /// When the next housekeeping is due, ns.
    pub fn next_housekeeping(&self) -> u64 {
        self.next_housekeeping
    }

    /// While idle: propagates the estimate to the next IMU instant ahead of
    /// its sample ([`Engine::step_ahead`]), so that the sample's step on the
    /// latency path is its fusion alone. Not while an instant is open: its last
    /// sample is due any moment and would discard the state. Returns whether it
    /// propagated.
    pub fn step_ahead(&mut self) -> bool {
        self.held.is_none() && self.engine.step_ahead()
    }

    /// Spin mode, while idle: brings what the next in-order sample touches into
    /// the cache ([`Engine::warm`]).
    pub fn warm(&self) {
        self.engine.warm();
    }
}

/// Runs `core` on `source` and `sink` until `shutdown` becomes true, telling
/// `observer` that it turns and handing it each interval's summary.
pub fn run<M: Steps>(
    core: &mut LiveCore<M>,
    source: &mut impl SampleSource,
    sink: &mut impl SnapshotSink,
    wait: WaitMode,
    shutdown: &AtomicBool,
    observer: &mut impl LoopObserver,
) -> RunReport {
    let mut next_warm = now_ns();
    // When a slice of a pending rewind is due even if samples keep coming.
    let mut slice_due = next_warm + SLICE_GAP_NS;
    while !shutdown.load(Ordering::Relaxed) {
        let taken = core.turn(source, sink);
        let now = now_ns();
        if now >= core.next_housekeeping() {
            if let Some(summary) = core.housekeeping(now, source, sink) {
                observer.summary(summary);
            }
            observer.alive(now, core.report());
        }
        if taken == 0 {
            slice_due = now + SLICE_GAP_NS;
        }
        // While an IMU instant is open, its last sample is due within
        // microseconds: no slice delays it (and a recording's replay finds the
        // idle steps where the live loop did them, `replay::recording`).
        if (taken == 0 || now >= slice_due) && core.correction_pending() && core.instant_due().is_none() {
            // Nothing waits (or a backlog has gone on for SLICE_GAP_NS): a
            // slice of the rewind, then look for samples again.
            core.settle_slice(sink);
            let after = now_ns();
            (slice_due, next_warm) = (after + SLICE_GAP_NS, after + WARM_NS);
            continue;
        }
        if taken > 0 {
            next_warm = now + WARM_NS;
            continue;
        }
        // Idle: the next IMU instant's propagation, before its sample comes.
        if core.step_ahead() {
            continue;
        }
        match wait {
            WaitMode::Spin => {
                if now >= next_warm {
                    sink.warm();
                    core.warm();
                    next_warm = now_ns() + WARM_NS;
                }
                std::hint::spin_loop();
            }
            // Nothing waits and the loop would sleep: an open instant's
            // snapshot goes out first. Its last sample would wait for a
            // wake-up (several µs) anyway, and on a loaded machine the
            // sender of that sample may be the one the sleep lets run.
            WaitMode::Event if core.instant_due().is_some() => core.publish_open(sink),
            WaitMode::Event => {
                let timeout = Duration::from_nanos(core.next_housekeeping().saturating_sub(now_ns()).max(1));
                source.wait(timeout);
            }
        }
    }
    core.settle_all(sink);
    core.report()
}

#[cfg(test)]
mod tests;
