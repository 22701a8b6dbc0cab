//! The engine: validation, reorder, model and filter, bounded history.
//!
//! Deterministic and IPC-free: the live daemon and `fusiond replay` run this same
//! code, and anything that depends on wall time (the clock for the future-timestamp
//! check) comes in as an argument.
//!
//! Samples arrive in any order and are processed in [`SampleKey`] order. The engine
//! keeps, for every processed sample inside the history window, the sample and the
//! filter state after it, plus the state before the oldest one. A late sample is
//! fused exactly: the engine restores the state before its place, processes it,
//! and re-processes every later sample, so the result equals processing the sorted
//! stream. All buffers are allocated at construction; nothing allocates per sample.

use fusion_shared::SampleKind;

mod history;
mod stats;

pub use stats::{EngineStats, SensorStats};

use crate::model::{Model, StepOutcome};
use crate::reorder::{Placement, Sample, SampleKey, Seen, SeqWindow, key_of, place};
use crate::validate::{Limits, Rejection};
use history::History;

/// Engine limits (from the `[filter]` and `[validation]` config tables).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineConfig {
    /// Rewind window: samples older than the newest by more than this are too late.
    pub history_ns: u64,
    /// Most entries kept in the history.
    pub history_capacity: usize,
    /// Distinct sensor ids tracked per kind.
    pub max_sensors: usize,
    /// Largest accepted lead of a timestamp over `now` (when `now` is given).
    pub max_future_ns: u64,
    /// Value limits of the payload checks.
    pub limits: Limits,
}

impl EngineConfig {
    /// The limits of a validated config.
    pub fn from_config(c: &crate::config::Config) -> Self {
        Self {
            history_ns: c.filter.history_ns,
            history_capacity: c.filter.history_capacity,
            max_sensors: c.validation.max_sensors,
            max_future_ns: c.validation.max_future_ns,
            limits: c.validation.limits(),
        }
    }
}

/// What became of an inserted sample. Every outcome is counted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Insert {
    /// Processed. `replayed` later samples were re-processed after it (0: in order).
    Processed {
        /// Number of later samples re-processed because this one came late.
        replayed: usize,
        /// What processing the sample itself did.
        outcome: StepOutcome,
    },
    /// Refused by validation.
    Rejected(Rejection),
    /// The same sensor and sequence number was processed already.
    Duplicate,
    /// Older than the history can restore.
    TooLate,
}

/// One sensor's identity, counters and duplicate window.
#[derive(Debug, Clone)]
pub struct SensorSlot {
    /// Kind of the sensor.
    pub kind: SampleKind,
    /// Sensor id.
    pub sensor: u32,
    /// Counters.
    pub stats: SensorStats,
    /// NIS of the measurement of this sensor processed last (in order or late).
    pub last_nis: Option<f64>,
    /// Largest timestamp received.
    pub last_t_ns: Option<u64>,
    /// When the latest sample arrived (the `now_ns` given to `insert`).
    pub last_arrival_ns: Option<u64>,
    highest_seq: Option<u64>,
    seen: SeqWindow,
}

/// A processed sample and the filter state after it.
#[derive(Debug, Clone, Copy)]
pub struct Entry<S> {
    /// Processing-order key.
    pub key: SampleKey,
    /// The sample.
    pub sample: Sample,
    /// Filter state after processing it.
    pub state: S,
    /// What processing did.
    pub outcome: StepOutcome,
    slot: u16,
}

/// The estimation engine for model `M`.
pub struct Engine<M: Model> {
    model: M,
    config: EngineConfig,
    history: History<Entry<M::State>>,
    /// The model's initial state: the state before `history[0]` until an entry
    /// has left the history (then it is that entry's, [`History::base`]).
    initial: M::State,
    newest_t: Option<u64>,
    sensors: Vec<SensorSlot>,
    stats: EngineStats,
}

impl<M: Model> Engine<M> {
    /// An engine running `model` within `config`'s limits.
    pub fn new(model: M, config: EngineConfig) -> Self {
        let initial = model.initial_state();
        // Every slot is written now (see `History`): without that, the first
        // `history_capacity` samples would each pay page faults (tens of µs at p99)
        // on the live path.
        let filler = Entry {
            key: key_of(&Sample::Imu(Default::default())),
            sample: Sample::Imu(Default::default()),
            state: initial,
            outcome: StepOutcome::Propagated,
            slot: 0,
        };
        let history = History::new(config.history_capacity, filler);
        Self {
            model,
            config,
            history,
            initial,
            newest_t: None,
            sensors: Vec::with_capacity(SampleKind::ALL.len() * config.max_sensors),
            stats: EngineStats::default(),
        }
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// Per-sensor slots in order of first arrival.
    pub fn sensors(&self) -> &[SensorSlot] {
        &self.sensors
    }

    /// The counters of every sensor of `kind` (all sensors for `None`) added up.
    pub fn totals(&self, kind: Option<SampleKind>) -> SensorStats {
        let mut total = SensorStats::default();
        for s in self.sensors.iter().filter(|s| kind.is_none_or(|k| k == s.kind)) {
            total.add(&s.stats);
        }
        total
    }

    /// Engine-wide counters.
    pub fn stats(&self) -> &EngineStats {
        &self.stats
    }

    /// The newest processed entry: the current estimate.
    pub fn latest(&self) -> Option<&Entry<M::State>> {
        self.history.back()
    }

    /// Entries still in the history (may still change through a rewind), oldest first.
    pub fn pending(&self) -> impl Iterator<Item = &Entry<M::State>> {
        self.history.iter()
    }

    /// Inserts a sample arriving now. `now_ns` (the daemon's clock) enables the
    /// future-timestamp check; replay passes `None`. Entries that leave the history
    /// are final and are handed to `on_final`, in processing order.
    pub fn insert(
        &mut self,
        sample: &Sample,
        now_ns: Option<u64>,
        on_final: &mut impl FnMut(&Entry<M::State>),
    ) -> Insert {
        let key = key_of(sample);
        let Some(slot) = self.slot(key.kind, key.sensor) else {
            self.stats.unknown_sensor += 1;
            return Insert::Rejected(Rejection::TooManySensors);
        };
        let sensor = &mut self.sensors[slot];
        sensor.stats.received += 1;
        if now_ns.is_some() {
            sensor.last_arrival_ns = now_ns;
        }
        let seen = match self.sensors[slot].seen.seen(key.seq) {
            Seen::Yes => true,
            Seen::No => false,
            Seen::Unknown => self
                .history
                .iter()
                .any(|e| e.key.kind == key.kind && e.key.sensor == key.sensor && e.key.seq == key.seq),
        };
        if seen {
            self.sensors[slot].stats.duplicate += 1;
            return Insert::Duplicate;
        }

        let sensor = &mut self.sensors[slot];
        match sensor.highest_seq {
            Some(h) if key.seq > h => {
                sensor.stats.lost += key.seq - h - 1;
                sensor.highest_seq = Some(key.seq);
            }
            Some(_) => sensor.stats.lost = sensor.stats.lost.saturating_sub(1),
            None => sensor.highest_seq = Some(key.seq),
        }
        let stats = &mut sensor.stats;

        let valid = crate::measurement::validate(sample, &self.config.limits).and_then(|()| match now_ns {
            Some(now) if key.t_ns > now.saturating_add(self.config.max_future_ns) => Err(Rejection::FutureTimestamp),
            _ => Ok(()),
        });
        if let Err(r) = valid {
            stats.invalid += 1;
            return Insert::Rejected(r);
        }

        let placement = place(
            &key,
            self.history.len(),
            |i| self.history[i].key,
            self.newest_t,
            self.config.history_ns,
            self.history.base().is_none(),
        );
        let mut index = match placement {
            Placement::Append => self.history.len(),
            Placement::Insert(i) => i,
            Placement::TooLate => {
                self.sensors[slot].stats.too_late += 1;
                return Insert::TooLate;
            }
        };
        if self.history.len() == self.config.history_capacity {
            // Full before the window passed: the oldest entry becomes final. A sample
            // that would go before it can no longer be placed.
            if index == 0 {
                self.sensors[slot].stats.too_late += 1;
                return Insert::TooLate;
            }
            self.stats.evicted_by_capacity += 1;
            self.evict_front(on_final);
            index -= 1;
        }

        let sensor = &mut self.sensors[slot];
        sensor.seen.mark(key.seq);
        sensor.last_t_ns = Some(sensor.last_t_ns.map_or(key.t_ns, |t| t.max(key.t_ns)));
        sensor.stats.processed += 1;

        // The new entry is stepped in its own slot from the entry before it (or
        // the initial state): one copy of the state, no moves.
        let replayed = self.history.len() - index;
        let (model, initial) = (&self.model, &self.initial);
        let mut outcome = StepOutcome::Propagated;
        let inserted = self.history.insert_with(index, |before, entry| {
            entry.state = match before {
                Some(b) => b.state,
                None => *initial,
            };
            outcome = model.step(&mut entry.state, sample);
            (entry.key, entry.sample, entry.outcome, entry.slot) = (key, *sample, outcome, slot as u16);
        });
        // Room was made above; the history moves slot indices, not entries, and
        // never allocates.
        debug_assert!(inserted, "the history had room");
        count_outcome(&mut self.sensors[slot].stats, &outcome, 1);
        self.sensors[slot].last_nis = outcome.nis().or(self.sensors[slot].last_nis);
        if replayed > 0 {
            self.sensors[slot].stats.late += 1;
            self.stats.rewinds += 1;
            self.stats.replayed += replayed as u64;
        }
        for j in (index + 1)..self.history.len() {
            let Some((before, entry)) = self.history.pair_mut(j) else { break };
            entry.state = before.state;
            let old = entry.outcome;
            let outcome = self.model.step(&mut entry.state, &entry.sample);
            entry.outcome = outcome;
            if old != outcome {
                let entry_slot = entry.slot as usize;
                count_outcome(&mut self.sensors[entry_slot].stats, &old, -1);
                count_outcome(&mut self.sensors[entry_slot].stats, &outcome, 1);
            }
        }

        let newest = self.newest_t.map_or(key.t_ns, |t| t.max(key.t_ns));
        self.newest_t = Some(newest);
        let horizon = newest.saturating_sub(self.config.history_ns);
        while self.history.front().is_some_and(|e| e.key.t_ns < horizon) {
            self.evict_front(on_final);
        }
        Insert::Processed { replayed, outcome }
    }

    /// Brings what the next in-order insert reads and writes into the cache (the
    /// history entries it touches, the state before the history, the sensor
    /// table) without changing anything. For a live loop that busy-waits: a
    /// sample that arrives after an idle gap then does not wait on memory.
    pub fn warm(&self) {
        self.history.warm();
        if self.history.base().is_none() {
            std::hint::black_box(self.initial);
        }
        std::hint::black_box(&self.sensors[..]).iter().for_each(|s| {
            std::hint::black_box(s.stats);
        });
    }

    /// Hands every entry still in the history to `on_final` (end of input).
    pub fn flush(&mut self, on_final: &mut impl FnMut(&Entry<M::State>)) {
        while !self.history.is_empty() {
            self.evict_front(on_final);
        }
    }

    fn evict_front(&mut self, on_final: &mut impl FnMut(&Entry<M::State>)) {
        // The entry stays in its slot as the history's base.
        if let Some(e) = self.history.pop_front() {
            on_final(e);
        }
    }

    /// The index of a sensor's slot in [`sensors`](Self::sensors), if it has one.
    pub fn slot_of(&self, kind: SampleKind, sensor: u32) -> Option<usize> {
        self.sensors.iter().position(|s| s.kind == kind && s.sensor == sensor)
    }

    /// The slot of a sensor, created on first sight; `None` when the table is full.
    fn slot(&mut self, kind: SampleKind, sensor: u32) -> Option<usize> {
        if let Some(i) = self.slot_of(kind, sensor) {
            return Some(i);
        }
        let of_kind = self.sensors.iter().filter(|s| s.kind == kind).count();
        if of_kind >= self.config.max_sensors {
            return None;
        }
        // Within the capacity reserved in `new` (kinds × max_sensors): no reallocation.
        self.sensors.push(SensorSlot {
            kind,
            sensor,
            stats: SensorStats::default(),
            last_nis: None,
            last_t_ns: None,
            last_arrival_ns: None,
            highest_seq: None,
            seen: SeqWindow::default(),
        });
        Some(self.sensors.len() - 1)
    }
}

fn count_outcome(stats: &mut SensorStats, outcome: &StepOutcome, delta: i64) {
    let counter = match outcome {
        StepOutcome::Propagated => return,
        StepOutcome::Fused { .. } => &mut stats.fused,
        StepOutcome::Gated { .. } => &mut stats.gated,
        StepOutcome::Refused => &mut stats.refused,
    };
    *counter = counter.wrapping_add_signed(delta);
}

#[cfg(test)]
mod tests {
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
            limits: Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 },
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
        let mut sink = |e: &Entry<_>| {
            out.push((e.key, LinearModel::x(&e.state).to_vec(), LinearModel::covariance(&e.state).to_vec()))
        };
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
        let positions: Vec<usize> =
            (0..shuffled.len()).filter(|i| matches!(shuffled[*i], Sample::Position(_))).collect();
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
        assert!(
            matches!(e.insert(&pos(600, 1, 0.0), None, &mut sink), Insert::Processed { replayed, .. } if replayed > 0)
        );
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
}
