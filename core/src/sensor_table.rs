//! The sensor table: a row per sensor (kind and id) with its counters, and the
//! admission of each sample to the engine.
//!
//! [`SensorTable::admit`] decides, for a valid sample, everything that depends
//! on its sensor alone: a row for it (the table is bounded), a restart of its
//! sequence numbers, a duplicate, and the rate limit; it counts the outcome.
//! What depends on the history (placement, a sample too late) is the engine's;
//! the engine reports it back ([`SensorTable::accept`], [`SensorRow::stats`]).
//! The health reads the rows ([`SensorTable::rows`]).
//!
//! Bounded: the rows are allocated at construction ([`MAX_SENSORS`]), and
//! nothing here allocates per sample.

use fusion_shared::SampleKind;
use fusion_shared::snapshot::MAX_SENSORS;

use crate::reorder::{SampleKey, Seen, SeqWindow};

/// Counters of one sensor (or of several, added up): [`fusion_shared::Counters`],
/// the one counters type of engine, snapshot and replay summary.
pub type SensorStats = fusion_shared::Counters;

/// One sensor's identity, counters and duplicate window.
#[derive(Debug, Clone)]
pub struct SensorRow {
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
    /// When the latest sample arrived (the clock reading given with it).
    pub last_arrival_ns: Option<u64>,
    /// Bit `c`: a sample was refused in validation with rejection code `c`
    /// ([`fusion_shared::snapshot::rejection`]).
    pub rejection_reasons: u32,
    /// The rejection code of the latest refused sample (0: none).
    pub last_rejection: u32,
    highest_seq: Option<u64>,
    seen: SeqWindow,
    /// Token bucket of the rate limit: tokens left, and the timestamp they were
    /// counted at.
    tokens: f64,
    tokens_t_ns: Option<u64>,
}

impl SensorRow {
    fn new(kind: SampleKind, sensor: u32) -> Self {
        Self {
            kind,
            sensor,
            stats: SensorStats::default(),
            last_nis: None,
            last_t_ns: None,
            last_arrival_ns: None,
            rejection_reasons: 0,
            last_rejection: 0,
            highest_seq: None,
            seen: SeqWindow::default(),
            tokens: 0.0,
            tokens_t_ns: None,
        }
    }

    /// Whether the sensor's sequence started again with `key`: a sequence number
    /// at or below the highest seen, on a sample newer than any seen. A duplicate
    /// or a late sample is never newer; a restarted driver counts from 0 again
    /// while its clock goes on. A number not seen yet, less than
    /// [`REORDER_SPAN`] below the highest, is a reordered one (a driver that
    /// numbers two samples out of turn): it fills its gap, it is no restart.
    fn restarted(&self, key: &SampleKey) -> bool {
        let Some(h) = self.highest_seq.filter(|&h| key.seq <= h) else { return false };
        let reordered = h - key.seq < REORDER_SPAN && self.seen.seen(key.seq) == Seen::No;
        self.last_t_ns.is_some_and(|t| key.t_ns > t) && !reordered
    }

    /// Counts the gap a newly arrived sequence number opens (or fills: a number
    /// below the highest takes one back).
    fn track_seq(&mut self, seq: u64) {
        match self.highest_seq {
            Some(h) if seq > h => {
                self.stats.lost = self.stats.lost.saturating_add(seq - h - 1);
                self.highest_seq = Some(seq);
            }
            Some(_) => self.stats.lost = self.stats.lost.saturating_sub(1),
            None => self.highest_seq = Some(seq),
        }
    }

    /// Takes a token of the rate limit for a sample stamped `t_ns`; false when
    /// none is left. Tokens accrue at `rate_hz` on the sample timestamps (a late
    /// sample adds none) up to `burst`: deterministic, so replay decides as live did.
    fn take_token(&mut self, t_ns: u64, rate_hz: f64, burst: u32) -> bool {
        let burst = f64::from(burst);
        let accrued = self.tokens_t_ns.map_or(burst, |t0| t_ns.saturating_sub(t0) as f64 * rate_hz / 1e9);
        self.tokens = (self.tokens + accrued).min(burst);
        self.tokens_t_ns = Some(self.tokens_t_ns.map_or(t_ns, |t0| t0.max(t_ns)));
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// How far below the highest sequence number a number not seen yet, on a
/// newer sample, is taken as reordered rather than as a restart.
pub const REORDER_SPAN: u64 = 64;

/// Why [`SensorTable::admit`] turned a valid sample away. Each is counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// The sensor has no row and the table (or its kind's share) is full;
    /// counted by the caller, as there is no row to count it in.
    NoRow,
    /// The same sensor and sequence number was processed already.
    Duplicate,
    /// The sensor sends faster than the rate limit allows.
    RateLimited,
}

/// The limits of the table (from the `[validation]` config table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableLimits {
    /// Distinct sensor ids tracked per kind.
    pub max_sensors: usize,
    /// Largest sustained rate of one sensor, Hz, on sample timestamps.
    pub max_rate_hz: f64,
    /// Samples one sensor may send at once beyond `max_rate_hz`.
    pub max_burst: u32,
}

/// The rows of every sensor seen, in order of first arrival.
#[derive(Debug, Clone)]
pub struct SensorTable {
    rows: Vec<SensorRow>,
    limits: TableLimits,
}

impl SensorTable {
    /// An empty table with room for [`MAX_SENSORS`] rows.
    pub fn new(limits: TableLimits) -> Self {
        Self { rows: Vec::with_capacity(MAX_SENSORS), limits }
    }

    /// The rows, in order of first arrival.
    pub fn rows(&self) -> &[SensorRow] {
        &self.rows
    }

    /// Row `index`, to count what happened to an admitted sample.
    pub fn row_mut(&mut self, index: usize) -> &mut SensorRow {
        &mut self.rows[index]
    }

    /// The index of a sensor's row, if it has one.
    pub fn find(&self, kind: SampleKind, sensor: u32) -> Option<usize> {
        self.rows.iter().position(|s| s.kind == kind && s.sensor == sensor)
    }

    /// The counters of every sensor of `kind` (all sensors for `None`) added up.
    pub fn totals(&self, kind: Option<SampleKind>) -> SensorStats {
        let mut total = SensorStats::default();
        for s in self.rows.iter().filter(|s| kind.is_none_or(|k| k == s.kind)) {
            total.add(&s.stats);
        }
        total
    }

    /// Counts an invalid sample against its sensor's row; false when the sensor
    /// has none (an invalid sample takes no row). Its rejection `code` is kept
    /// in the row (`rejection_reasons`, `last_rejection`). Its sequence number is no gap,
    /// but only a number just after the highest seen is trusted from it.
    pub fn count_invalid(&mut self, key: &SampleKey, code: u32) -> bool {
        let Some(row) = self.find(key.kind, key.sensor) else { return false };
        let row = &mut self.rows[row];
        row.stats.received += 1;
        row.stats.invalid += 1;
        row.rejection_reasons |= 1u32.checked_shl(code).unwrap_or(0);
        row.last_rejection = code;
        if row.highest_seq.is_some_and(|h| key.seq > h && key.seq - h <= SeqWindow::SPAN) {
            row.track_seq(key.seq);
        }
        true
    }

    /// Admits a valid sample arriving at `now_ns` (`None`: replay): its row
    /// (made on first sight), a restart, a duplicate (`in_history` says whether
    /// that very sample is among the processed ones, asked only when its sequence
    /// number is too old for the window), the rate limit. Counts it as received,
    /// and a refusal by its reason. Returns the row's index.
    pub fn admit(
        &mut self,
        key: &SampleKey,
        now_ns: Option<u64>,
        in_history: impl FnOnce(&SampleKey) -> bool,
    ) -> Result<usize, Refusal> {
        let index = self.row(key.kind, key.sensor).ok_or(Refusal::NoRow)?;
        let limits = self.limits;
        let row = &mut self.rows[index];
        row.stats.received += 1;
        if now_ns.is_some() {
            row.last_arrival_ns = now_ns;
        }
        if row.restarted(key) {
            row.stats.restarts += 1;
            row.seen = SeqWindow::default();
            row.highest_seq = None;
        }
        // A sample no newer than the sensor's newest, with a sequence number
        // older than the window or from before a restart, is a duplicate only if
        // that very sample (same time and sequence number) is in the history.
        let older = row.last_t_ns.is_some_and(|t| key.t_ns <= t);
        let seen = match row.seen.seen(key.seq) {
            Seen::Yes => true,
            Seen::No if !older => false,
            Seen::No | Seen::Unknown => in_history(key),
        };
        if seen {
            row.stats.duplicate += 1;
            return Err(Refusal::Duplicate);
        }
        row.track_seq(key.seq);
        if !row.take_token(key.t_ns, limits.max_rate_hz, limits.max_burst) {
            row.seen.mark(key.seq);
            row.stats.rate_limited += 1;
            return Err(Refusal::RateLimited);
        }
        Ok(index)
    }

    /// Records that the admitted sample `key` of row `index` is processed (in
    /// order, or placed for a rewind).
    pub fn accept(&mut self, index: usize, key: &SampleKey) {
        let row = &mut self.rows[index];
        row.seen.mark(key.seq);
        row.last_t_ns = Some(row.last_t_ns.map_or(key.t_ns, |t| t.max(key.t_ns)));
        row.stats.processed += 1;
    }

    /// A new timeline (`Engine`'s, replay): every row's times, sequence window
    /// and rate limit start again, as for a sensor seen first; its counters stay.
    pub fn new_timeline(&mut self) {
        for row in &mut self.rows {
            (row.last_t_ns, row.highest_seq, row.seen) = (None, None, SeqWindow::default());
            (row.tokens, row.tokens_t_ns) = (0.0, None);
        }
    }

    /// Reads every row's counters without changing anything (see
    /// `Engine::warm`).
    pub fn warm(&self) {
        std::hint::black_box(&self.rows[..]).iter().for_each(|s| {
            std::hint::black_box(s.stats);
        });
    }

    /// The row of a sensor, made on first sight; `None` when the table is full.
    fn row(&mut self, kind: SampleKind, sensor: u32) -> Option<usize> {
        if let Some(i) = self.find(kind, sensor) {
            return Some(i);
        }
        let of_kind = self.rows.iter().filter(|s| s.kind == kind).count();
        if of_kind >= self.limits.max_sensors || self.rows.len() >= MAX_SENSORS {
            return None;
        }
        // Within the capacity reserved in `new`: no reallocation.
        self.rows.push(SensorRow::new(kind, sensor));
        Some(self.rows.len() - 1)
    }
}
