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
//!
//! The re-processing can wait. [`Engine::insert_deferred`] only places a late
//! sample in the history and marks it and the entries after it *stale* (an
//! O(log n) search and an index move: no filter step on the way); samples that
//! arrive meanwhile are stepped on from the newest (stale) entry at in-order
//! cost, and [`Engine::settle_step`] steps the oldest stale entry, one at a
//! time, where the caller has time (the live loop's idle time, in slices). A
//! late sample's own outcome (fused or gated, its NIS) is known when the rewind
//! reaches it ([`Engine::take_first_outcomes`]).
//! While entries are stale the newest estimate is provisional ([`Engine::correction`]
//! says how far behind it is); once every stale entry is re-stepped the history
//! is bit for bit the one of in-order processing, because every step is a pure
//! function of the state before it and the sample. A stale entry is never handed
//! out as final: one about to leave the history is re-stepped first.
//! [`Engine::insert`] is `insert_deferred` followed by settling everything.
//!
//! The propagation can come early. [`Engine::step_ahead`] propagates the newest
//! state, in the caller's idle time, to where the model expects its next input
//! (the next IMU instant, [`crate::model::held_imu::Instants::next_input_ns`]), in the slot
//! of the next entry. When the next in-order sample comes at that time and
//! nothing else has changed the history since, its step starts from that
//! state and only fuses: the same bits as stepping from the entry before it,
//! since `propagate_to` is a pure function of the state and the time, and an
//! equal time propagates nothing ([`crate::model::advance_time`]). Any other
//! sample discards it.
//! The slot after it is written too (`History::prepare_after_next`): an
//! instant's second IMU sample steps into memory this core holds.

use fusion_shared::SampleKind;

mod history;
mod outcome;
mod stats;

pub use outcome::{Correction, Entry, FIRST_OUTCOMES, Insert};
pub use stats::EngineStats;

use crate::measurement::{self, Steps};
use crate::model::StepOutcome;
use crate::model::held_imu::Instants;
use crate::reorder::{Placement, Sample, SampleKey, key_of, place};
use crate::sensor_table::{Refusal, SensorRow, SensorStats, SensorTable, TableLimits};
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
    /// Largest accepted lag of a timestamp behind `now` (when `now` is given).
    pub max_past_ns: u64,
    /// Without `now` (replay): largest accepted lead of a timestamp over the
    /// newest processed one, and lag behind it (see [`JUMP_CONFIRMATION`]).
    pub max_jump_ns: u64,
    /// Largest sustained rate of one sensor, Hz, on sample timestamps.
    pub max_rate_hz: f64,
    /// Samples one sensor may send at once beyond `max_rate_hz`.
    pub max_burst: u32,
    /// Value limits of the payload checks.
    pub limits: Limits,
}

/// The estimation engine for model `M`.
pub struct Engine<M: Steps> {
    model: M,
    config: EngineConfig,
    history: History<Entry<M::State>, SampleKey>,
    /// The model's initial state: the state before `history[0]` until an entry
    /// has left the history (then it is that entry's, [`History::base`]).
    initial: M::State,
    /// Index of the oldest stale entry: this one and every later one hold states
    /// computed before a late sample was inserted ahead of them (or are late
    /// samples not yet processed). `None`: every entry is exact.
    stale_from: Option<usize>,
    /// Sensor slot and outcome of late samples processed for the first time,
    /// the first `first_len` of them, until the caller takes them.
    first_outcomes: [(u16, StepOutcome, bool); FIRST_OUTCOMES],
    first_len: usize,
    /// While entries are stale: the time of the oldest late sample placed since
    /// the history was last settled.
    pending_since_t: Option<u64>,
    newest_t: Option<u64>,
    /// Changes of the history's states so far: a state stepped ahead is of
    /// the newest state while this has not moved.
    changes: u64,
    /// The newest state propagated to `ahead.0` by [`step_ahead`](Self::step_ahead)
    /// at `ahead.1` changes, in the history's reserved slot (time 0: the model
    /// expected nothing then).
    ahead: Option<(u64, u64)>,
    /// Samples refused in a row as a time jump, ahead or back (see [`JUMP_CONFIRMATION`]).
    jumps: JumpRun,
    sensors: SensorTable,
    stats: EngineStats,
}

pub use fusion_shared::time::JUMP_CONFIRMATION;
use fusion_shared::time::{Direction, Jump, JumpRun};

impl<M: Steps> Engine<M> {
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
            fresh: false,
        };
        let history = History::new(config.history_capacity, filler);
        Self {
            model,
            config,
            history,
            initial,
            stale_from: None,
            first_outcomes: [(0, StepOutcome::Propagated, false); FIRST_OUTCOMES],
            first_len: 0,
            pending_since_t: None,
            newest_t: None,
            changes: 0,
            ahead: None,
            jumps: JumpRun::new(config.max_jump_ns),
            sensors: SensorTable::new(TableLimits {
                max_sensors: config.max_sensors,
                max_rate_hz: config.max_rate_hz,
                max_burst: config.max_burst,
            }),
            stats: EngineStats::default(),
        }
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The rows of the sensor table, in order of first arrival.
    pub fn sensors(&self) -> &[SensorRow] {
        self.sensors.rows()
    }

    /// The counters of every sensor of `kind` (all sensors for `None`) added up.
    pub fn totals(&self, kind: Option<SampleKind>) -> SensorStats {
        self.sensors.totals(kind)
    }

    /// Engine-wide counters.
    pub fn stats(&self) -> &EngineStats {
        &self.stats
    }

    /// The newest processed entry: the current estimate (provisional while a
    /// [`correction`](Self::correction) is pending).
    pub fn latest(&self) -> Option<&Entry<M::State>> {
        self.history.back()
    }

    /// The correction not yet in the newest estimate, if one is pending.
    pub fn correction(&self) -> Option<Correction> {
        let from = self.stale_from?;
        let since_t_ns = self.pending_since_t.unwrap_or(self.history.key(from).t_ns);
        Some(Correction { steps: self.history.len() - from, since_t_ns })
    }

    /// Entries still in the history (may still change through a rewind), oldest first.
    pub fn pending(&self) -> impl Iterator<Item = &Entry<M::State>> {
        self.history.iter()
    }

    /// Inserts a sample arriving now and re-processes every later sample if it
    /// came late: afterwards the newest estimate includes it. `now_ns` (the
    /// daemon's clock) enables the future-timestamp check; replay passes `None`.
    /// Entries that leave the history are final and are handed to `on_final`, in
    /// processing order.
    pub fn insert(
        &mut self,
        sample: &Sample,
        now_ns: Option<u64>,
        on_final: &mut impl FnMut(&Entry<M::State>),
    ) -> Insert {
        // Room for this sample's own first outcome (a caller that mixes in
        // `insert_deferred` and never takes them loses one of its kept ones).
        let kept = self.first_len.min(FIRST_OUTCOMES - 1);
        self.first_len = kept;
        let inserted = self.insert_deferred(sample, now_ns, on_final);
        self.settle();
        // Everything before this sample was settled: the only late sample
        // processed for the first time just now is this one.
        let first = (self.first_len > kept).then(|| self.first_outcomes[self.first_len - 1].1);
        self.first_len = kept;
        match (inserted, first) {
            (Insert::Placed { replayed }, Some(outcome)) => Insert::Processed { replayed, outcome },
            (other, _) => other,
        }
    }

    /// Inserts a sample arriving now, as [`insert`](Self::insert), but leaves a
    /// late one to the rewind: it is placed in the history ([`Insert::Placed`]),
    /// it and every entry after it are stale, and [`settle_step`](Self::settle_step)
    /// processes them. An in-order sample is stepped at once, from the newest
    /// entry (stale or not): one step whatever is pending.
    pub fn insert_deferred(
        &mut self,
        sample: &Sample,
        now_ns: Option<u64>,
        on_final: &mut impl FnMut(&Entry<M::State>),
    ) -> Insert {
        // A sensor whose timestamps are late by a configured offset: its samples
        // are valid that much earlier ([`crate::frames::SensorConfig::time_offset_ns`]).
        let shifted;
        let offset = self.model.time_offset_ns(sample);
        let sample = if offset == 0 {
            sample
        } else {
            let mut s = *sample;
            let h = s.header_mut();
            h.t_ns = h.t_ns.saturating_add_signed(-offset);
            shifted = s;
            &shifted
        };
        let key = key_of(sample);
        // Validation comes before anything a sample can change: an invalid sample
        // takes no sensor row and moves no sequence tracking.
        match self.check(sample, &key, now_ns) {
            Err(r) => {
                self.stats.rejections[r.code() as usize] += 1;
                if !self.sensors.count_invalid(&key, r.code()) {
                    self.stats.unknown_sensor += 1;
                }
                return Insert::Rejected(r);
            }
            Ok(Some(step_ns)) => self.new_timeline(step_ns, on_final),
            Ok(None) => {}
        }
        let history = &self.history;
        let slot = match self.sensors.admit(&key, now_ns, |key| history.keys().any(|k| k == key)) {
            Ok(slot) => slot,
            Err(Refusal::NoRow) => {
                self.stats.unknown_sensor += 1;
                self.stats.rejections[Rejection::TooManySensors.code() as usize] += 1;
                return Insert::Rejected(Rejection::TooManySensors);
            }
            Err(Refusal::Duplicate) => return Insert::Duplicate,
            Err(Refusal::RateLimited) => return Insert::RateLimited,
        };
        let Some(index) = self.make_place(&key, on_final) else {
            self.sensors.row_mut(slot).stats.too_late += 1;
            return Insert::TooLate;
        };
        self.model.admit(sample);
        self.sensors.accept(slot, &key);
        let result = if index == self.history.len() {
            self.step_in_order(sample, &key, slot)
        } else {
            self.place_late(sample, &key, slot, index)
        };
        let newest = self.newest_t.map_or(key.t_ns, |t| t.max(key.t_ns));
        self.newest_t = Some(newest);
        let horizon = newest.saturating_sub(self.config.history_ns);
        while self.history.keys().next().is_some_and(|k| k.t_ns < horizon) {
            self.evict_front(on_final);
        }
        result
    }

    /// The checks of a sample's own content and of its timestamp against the
    /// clock (`now_ns`), or, without one (replay), against the newest processed
    /// time: a sample far ahead of everything processed is refused, or it would
    /// make every later sample too late; one far back behind it is refused too
    /// (it is no late sample but of another clock). Only a run of such samples
    /// ([`JUMP_CONFIRMATION`], the same way) shows that the recording's clock
    /// was set or has a real gap: `Ok(Some(step))`, a new timeline begins with
    /// this sample ([`new_timeline`](Self::new_timeline)).
    fn check(&mut self, sample: &Sample, key: &SampleKey, now_ns: Option<u64>) -> Result<Option<i128>, Rejection> {
        self.model.validate(sample, &self.config.limits)?;
        match now_ns {
            Some(now) if key.t_ns > now.saturating_add(self.config.max_future_ns) => Err(Rejection::FutureTimestamp),
            Some(now) if key.t_ns < now.saturating_sub(self.config.max_past_ns) => Err(Rejection::PastTimestamp),
            Some(_) => Ok(None),
            None => match self.jumps.judge(self.newest_t, key.t_ns) {
                Jump::Near => Ok(None),
                Jump::Refused(Direction::Ahead) => Err(Rejection::TimeJump),
                Jump::Refused(Direction::Back) => Err(Rejection::TimeStepBack),
                Jump::NewTimeline { step_ns, .. } => Ok(Some(step_ns)),
            },
        }
    }

    /// Starts a new timeline (replay only: a recording's clock set, ahead or
    /// back by `step_ns`, or a real gap in it; [`JUMP_CONFIRMATION`]): every
    /// entry becomes final (handed to `on_final`), and the estimate starts
    /// over from the model's initial state, as after a restart. Nothing of
    /// the old timeline's times can be compared with the new one's: a state
    /// propagated across the step would be propagated over a time that never
    /// passed (or back in time), and every later sample would be too late.
    /// The sensors' counters stay; their times, sequence windows and rate
    /// limits start again. Counted in [`EngineStats::new_timelines`].
    fn new_timeline(&mut self, step_ns: i128, on_final: &mut impl FnMut(&Entry<M::State>)) {
        self.flush(on_final);
        self.history.forget_base();
        self.initial = self.model.initial_state();
        (self.newest_t, self.ahead, self.pending_since_t) = (None, None, None);
        self.changes += 1;
        self.sensors.new_timeline();
        self.stats.new_timelines += 1;
        self.stats.last_timeline_step_ns = step_ns;
    }

    /// The index `key` goes to in the history (its length: appended), with room
    /// made for it: a full history hands its oldest entry to `on_final` first.
    /// `None`: older than the history can restore.
    fn make_place(&mut self, key: &SampleKey, on_final: &mut impl FnMut(&Entry<M::State>)) -> Option<usize> {
        let placement = place(
            key,
            self.history.len(),
            |i| self.history.key(i),
            self.newest_t,
            self.config.history_ns,
            self.history.base().is_none(),
        );
        let index = match placement {
            Placement::Append => self.history.len(),
            Placement::Insert(i) => i,
            Placement::TooLate => return None,
        };
        if self.history.len() < self.config.history_capacity {
            return Some(index);
        }
        // Full before the window passed: the oldest entry becomes final. A sample
        // that would go before it can no longer be placed. The eviction may
        // re-step stale entries: `stale_from` is read only after it.
        if index == 0 {
            return None;
        }
        self.stats.evicted_by_capacity += 1;
        self.evict_front(on_final);
        Some(index - 1)
    }

    /// Steps an in-order sample in its own slot at the end of the history from
    /// the entry before it (or the initial state): one copy of the state, no
    /// moves. Exact unless that entry is stale. A state stepped ahead to the
    /// sample's time ([`step_ahead`](Self::step_ahead)) is in the slot already
    /// and stands in for the copy.
    fn step_in_order(&mut self, sample: &Sample, key: &SampleKey, slot: usize) -> Insert {
        let ahead = self.ahead_at(key.t_ns);
        self.stats.stepped_from_ahead += u64::from(ahead);
        let (model, initial, index) = (&self.model, &self.initial, self.history.len());
        let mut outcome = StepOutcome::Propagated;
        let inserted = self.history.insert_with(index, *key, |before, entry| {
            if !ahead {
                entry.state = match before {
                    Some(b) => b.state,
                    None => *initial,
                };
            }
            outcome = model.step(&mut entry.state, sample);
            (entry.key, entry.sample, entry.outcome, entry.slot) = (*key, *sample, outcome, slot as u16);
            entry.fresh = false;
        });
        // Room was made by `make_place`; the history moves slot indices, not
        // entries, and never allocates.
        debug_assert!(inserted, "the history had room");
        self.changes += 1;
        let row = self.sensors.row_mut(slot);
        count_outcome(&mut row.stats, &outcome, 1);
        row.last_nis = outcome.nis().or(row.last_nis);
        Insert::Processed { replayed: 0, outcome }
    }

    /// Places a late sample at `index`, stale with everything after it: its state
    /// is written when the rewind reaches it, and its outcome counts from then.
    fn place_late(&mut self, sample: &Sample, key: &SampleKey, slot: usize, index: usize) -> Insert {
        let replayed = self.history.len() - index;
        let inserted = self.history.insert_with(index, *key, |_, entry| {
            (entry.key, entry.sample, entry.outcome, entry.slot) =
                (*key, *sample, StepOutcome::Propagated, slot as u16);
            entry.fresh = true;
        });
        debug_assert!(inserted, "the history had room");
        self.changes += 1;
        self.sensors.row_mut(slot).stats.late += 1;
        self.stats.rewinds += 1;
        self.stats.replayed += replayed as u64;
        self.stale_from = Some(self.stale_from.map_or(index, |from| from.min(index)));
        self.pending_since_t = Some(self.pending_since_t.map_or(key.t_ns, |t| t.min(key.t_ns)));
        Insert::Placed { replayed }
    }

    /// Hands the sensor slot and outcome of every late sample processed for the
    /// first time since the last call (by [`settle_step`](Self::settle_step), or
    /// because it was about to leave the history) to `f`, in the order they were
    /// processed: what [`Insert::Processed`] says of an in-order sample; and
    /// whether the sample is an exact reading ([`measurement::exact`]). At most
    /// [`FIRST_OUTCOMES`] are kept between calls.
    pub fn take_first_outcomes(&mut self, mut f: impl FnMut(usize, &StepOutcome, bool)) {
        for (slot, outcome, exact) in &self.first_outcomes[..self.first_len] {
            f(usize::from(*slot), outcome, *exact);
        }
        self.first_len = 0;
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
        self.sensors.warm();
    }

    /// Propagates the newest state to where the model expects its next input
    /// ([`crate::model::held_imu::Instants::next_input_ns`]), in the slot of the next entry,
    /// for the next in-order sample at that time to start from (see the
    /// module's doc). For the caller's idle time. Does nothing while a
    /// correction is pending (its re-steps would change the newest state), when
    /// done already for the newest state, or when the model expects nothing
    /// after it. Returns whether it propagated.
    pub fn step_ahead(&mut self) -> bool {
        if self.stale_from.is_some() || self.ahead.is_some_and(|(_, at)| at == self.changes) {
            return false;
        }
        // Written in the slot of the next entry, from the state the next
        // append steps from (`History::reserve_next`).
        let Some((before, next)) = self.history.reserve_next() else { return false };
        let before = before.map_or(&self.initial, |e| &e.state);
        let t = M::next_input_ns(before).filter(|&t| M::time_ns(before).is_some_and(|now| t > now));
        self.ahead = Some((t.unwrap_or(0), self.changes));
        let Some(t) = t else { return false };
        next.state = *before;
        self.model.propagate_to(&mut next.state, t, None);
        self.history.prepare_after_next();
        self.stats.stepped_ahead += 1;
        true
    }

    /// Whether a state stepped ahead is of the newest state and at `t_ns`.
    fn ahead_at(&self, t_ns: u64) -> bool {
        self.ahead.is_some_and(|(t, at)| at == self.changes && t == t_ns && t != 0)
    }

    /// Re-steps the oldest stale entry from the (exact) entry before it, in the
    /// live loop's idle time; counted in [`EngineStats::background_steps`].
    /// Returns whether stale entries remain.
    pub fn settle_step(&mut self) -> bool {
        if self.stale_from.is_some() {
            self.restep_oldest_stale();
            self.stats.background_steps += 1;
        }
        self.stale_from.is_some()
    }

    /// Re-steps every stale entry: the newest estimate then includes every
    /// sample inserted. Counted in [`EngineStats::settled_inline`].
    pub fn settle(&mut self) {
        while self.stale_from.is_some() {
            self.restep_oldest_stale();
            self.stats.settled_inline += 1;
        }
    }

    /// Steps entry `stale_from` again from the entry before it (the base or the
    /// initial state at the front) and moves `stale_from` on. A decision that
    /// changes (fused, gated, refused) moves its sensor's counts; a late
    /// sample's first step counts its outcome and keeps it for
    /// [`take_first_outcomes`](Self::take_first_outcomes).
    fn restep_oldest_stale(&mut self) {
        let Some(j) = self.stale_from else { return };
        let initial = &self.initial;
        let Some((before, entry)) = self.history.before_mut(j) else {
            // `stale_from` always indexes an entry; nothing to re-step otherwise.
            (self.stale_from, self.pending_since_t) = (None, None);
            return;
        };
        entry.state = before.map_or(*initial, |b| b.state);
        self.changes += 1;
        let old = entry.outcome;
        let outcome = self.model.step(&mut entry.state, &entry.sample);
        entry.outcome = outcome;
        let (entry_slot, fresh) = (entry.slot, std::mem::replace(&mut entry.fresh, false));
        let sensor = self.sensors.row_mut(usize::from(entry_slot));
        if fresh {
            // A late sample's first step: what an in-order insert counts at once.
            count_outcome(&mut sensor.stats, &outcome, 1);
            sensor.last_nis = outcome.nis().or(sensor.last_nis);
            if let Some(place) = self.first_outcomes.get_mut(self.first_len) {
                *place = (entry_slot, outcome, measurement::exact(&entry.sample));
                self.first_len += 1;
            }
        } else if old != outcome {
            count_outcome(&mut sensor.stats, &old, -1);
            count_outcome(&mut sensor.stats, &outcome, 1);
        }
        self.stale_from = (j + 1 < self.history.len()).then_some(j + 1);
        if self.stale_from.is_none() {
            self.pending_since_t = None;
        }
    }

    /// Hands every entry still in the history to `on_final` (end of input),
    /// settling a pending correction first.
    pub fn flush(&mut self, on_final: &mut impl FnMut(&Entry<M::State>)) {
        self.settle();
        while !self.history.is_empty() {
            self.evict_front(on_final);
        }
    }

    /// Hands the oldest entry to `on_final`; a stale one is re-stepped first, so
    /// that only exact states become final.
    fn evict_front(&mut self, on_final: &mut impl FnMut(&Entry<M::State>)) {
        if self.stale_from == Some(0) {
            self.restep_oldest_stale();
            self.stats.settled_inline += 1;
        }
        // The entry stays in its slot as the history's base.
        if let Some(e) = self.history.pop_front() {
            on_final(e);
            self.stale_from = self.stale_from.map(|from| from - 1);
        }
    }

    /// The index of a sensor's row in [`sensors`](Self::sensors), if it has one.
    pub fn slot_of(&self, kind: SampleKind, sensor: u32) -> Option<usize> {
        self.sensors.find(kind, sensor)
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
mod tests;
