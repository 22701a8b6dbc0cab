//! Timestamp order and the late-sample policy.
//!
//! Samples are processed in the order of [`SampleKey`] `(t_ns, rank, kind, sensor,
//! seq)`: at equal time by each kind's rank ([`crate::measurement::Measurement::RANK`],
//! the IMU first). The engine keeps a bounded, key-sorted
//! history; [`place`] decides where an arriving sample goes: appended (in order),
//! inserted (late, fused exactly by rewind and replay), or dropped as too late.
//! [`SeqWindow`] finds duplicates without searching the history.

pub use fusion_shared::Sample;
use fusion_shared::SampleKind;

/// The processing-order key. Field order is the comparison order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SampleKey {
    /// Time of validity, ns.
    pub t_ns: u64,
    /// Rank of the kind at equal time ([`crate::measurement::rank`]).
    pub rank: u8,
    /// The kind.
    pub kind: SampleKind,
    /// Sensor id (per kind).
    pub sensor: u32,
    /// Sequence number of the sensor.
    pub seq: u64,
}

/// The processing-order key of a sample.
pub fn key_of(sample: &Sample) -> SampleKey {
    let h = sample.header();
    let kind = sample.kind();
    SampleKey { t_ns: h.t_ns, rank: crate::measurement::rank(kind), kind, sensor: h.sensor, seq: h.seq }
}

/// Where an arriving sample goes in the history.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// After everything processed: no rewind.
    Append,
    /// At this index of the history: rewind to the state before it and replay
    /// the entries from it on.
    Insert(usize),
    /// Before the oldest state the history can restore.
    TooLate,
}

/// Decides where a sample with `key` goes.
///
/// `keys(i)` is the key of history entry `i` (sorted ascending, `len` entries),
/// `newest_t` the largest time processed, `window_ns` the history window and
/// `base_is_initial` whether the state before entry 0 is the filter's initial
/// state (nothing evicted yet), in which case any older sample can still go first.
pub fn place(
    key: &SampleKey,
    len: usize,
    keys: impl Fn(usize) -> SampleKey,
    newest_t: Option<u64>,
    window_ns: u64,
    base_is_initial: bool,
) -> Placement {
    if len == 0 || keys(len - 1) < *key {
        return Placement::Append;
    }
    if let Some(newest) = newest_t
        && key.t_ns < newest.saturating_sub(window_ns)
    {
        return Placement::TooLate;
    }
    // Binary search for the first entry with a larger key.
    let (mut lo, mut hi) = (0, len);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if keys(mid) < *key { lo = mid + 1 } else { hi = mid }
    }
    if lo == 0 && !base_is_initial { Placement::TooLate } else { Placement::Insert(lo) }
}

/// Sequence numbers of one sensor seen recently, for duplicate detection.
///
/// A ring bitmap over the last [`SeqWindow::SPAN`] sequence numbers below the
/// highest one seen (like the anti-replay window of IPsec, RFC 4303 §3.4.3).
/// Older numbers are outside the window: the caller decides by other means.
#[derive(Debug, Clone)]
pub struct SeqWindow {
    max: Option<u64>,
    bits: [u64; Self::WORDS],
}

/// Whether a sequence number was seen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seen {
    /// Seen before: a duplicate.
    Yes,
    /// Not seen.
    No,
    /// Older than the window: unknown.
    Unknown,
}

impl Default for SeqWindow {
    fn default() -> Self {
        Self { max: None, bits: [0; Self::WORDS] }
    }
}

impl SeqWindow {
    const WORDS: usize = 64;
    /// Sequence numbers covered below the highest seen (4096: 1 s at 4 kHz).
    pub const SPAN: u64 = (Self::WORDS * 64) as u64;

    fn bit(seq: u64) -> (usize, u64) {
        let i = (seq % Self::SPAN) as usize;
        (i / 64, 1u64 << (i % 64))
    }

    /// Whether `seq` was marked.
    pub fn seen(&self, seq: u64) -> Seen {
        match self.max {
            None => Seen::No,
            Some(max) if seq > max => Seen::No,
            Some(max) if max - seq >= Self::SPAN => Seen::Unknown,
            Some(_) => {
                let (w, b) = Self::bit(seq);
                if self.bits[w] & b != 0 { Seen::Yes } else { Seen::No }
            }
        }
    }

    /// Marks `seq` as seen. Numbers older than the window are ignored.
    pub fn mark(&mut self, seq: u64) {
        match self.max {
            Some(max) if seq > max => {
                if seq - max >= Self::SPAN {
                    self.bits = [0; Self::WORDS];
                } else {
                    for s in (max + 1)..seq {
                        let (w, b) = Self::bit(s);
                        self.bits[w] &= !b;
                    }
                    let (w, b) = Self::bit(seq);
                    self.bits[w] &= !b;
                }
                self.max = Some(seq);
            }
            Some(max) if max - seq >= Self::SPAN => return,
            Some(_) => {}
            None => self.max = Some(seq),
        }
        let (w, b) = Self::bit(seq);
        self.bits[w] |= b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k(t: u64, kind: SampleKind, seq: u64) -> SampleKey {
        SampleKey { t_ns: t, rank: crate::measurement::rank(kind), kind, sensor: 0, seq }
    }

    #[test]
    fn imu_sorts_before_position_at_equal_time() {
        assert!(k(5, SampleKind::Imu, 9) < k(5, SampleKind::Position, 0));
        assert!(k(4, SampleKind::Position, 9) < k(5, SampleKind::Imu, 0));
        assert!(k(5, SampleKind::Position, 9) < k(5, SampleKind::Velocity, 0));
    }

    #[test]
    fn placement_follows_the_window() {
        let keys = [k(100, SampleKind::Imu, 0), k(200, SampleKind::Imu, 1), k(300, SampleKind::Imu, 2)];
        let at = |i: usize| keys[i];
        assert_eq!(place(&k(400, SampleKind::Imu, 3), 3, at, Some(300), 1000, false), Placement::Append);
        assert_eq!(place(&k(250, SampleKind::Position, 0), 3, at, Some(300), 1000, false), Placement::Insert(2));
        assert_eq!(place(&k(200, SampleKind::Position, 0), 3, at, Some(300), 1000, false), Placement::Insert(2));
        assert_eq!(place(&k(150, SampleKind::Position, 0), 3, at, Some(300), 150, false), Placement::Insert(1));
        assert_eq!(place(&k(149, SampleKind::Position, 0), 3, at, Some(300), 150, false), Placement::TooLate);
        assert_eq!(place(&k(50, SampleKind::Position, 0), 3, at, Some(300), 1000, false), Placement::TooLate);
        assert_eq!(place(&k(50, SampleKind::Position, 0), 3, at, Some(300), 1000, true), Placement::Insert(0));
        assert_eq!(place(&k(0, SampleKind::Imu, 0), 0, at, None, 1000, true), Placement::Append);
    }

    #[test]
    fn seq_window_finds_duplicates() {
        let mut w = SeqWindow::default();
        assert_eq!(w.seen(7), Seen::No);
        w.mark(7);
        assert_eq!(w.seen(7), Seen::Yes);
        w.mark(10);
        assert_eq!((w.seen(8), w.seen(9), w.seen(10)), (Seen::No, Seen::No, Seen::Yes));
        w.mark(8);
        assert_eq!(w.seen(8), Seen::Yes);
        // The window moves on: old bits are cleared when the ring wraps.
        w.mark(10 + SeqWindow::SPAN - 1);
        assert_eq!(w.seen(10), Seen::Yes);
        assert_eq!(w.seen(9), Seen::Unknown);
        w.mark(10 + SeqWindow::SPAN + 7);
        assert_eq!(w.seen(10 + SeqWindow::SPAN + 7), Seen::Yes);
        assert_eq!(w.seen(10 + SeqWindow::SPAN + 6), Seen::No);
        // A large jump clears everything.
        w.mark(1 << 40);
        assert_eq!(w.seen((1 << 40) - 1), Seen::No);
    }
}
