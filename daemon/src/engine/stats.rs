//! The engine's counters: per sensor and engine-wide.

/// Counters of one sensor. `fused`, `gated` and `refused` describe the current
/// estimates: a rewind that changes a decision moves the count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SensorStats {
    /// Samples that arrived.
    pub received: u64,
    /// Samples processed (in order or late).
    pub processed: u64,
    /// Measurements fused.
    pub fused: u64,
    /// Measurements refused by the gate.
    pub gated: u64,
    /// Measurements the filter refused (innovation covariance not positive definite).
    pub refused: u64,
    /// Samples processed late, by rewind and replay.
    pub late: u64,
    /// Samples dropped as older than the history.
    pub too_late: u64,
    /// Duplicates dropped.
    pub duplicate: u64,
    /// Samples rejected by validation.
    pub invalid: u64,
    /// Samples that never arrived: gaps in the sequence numbers (a subscriber
    /// buffer overflow, or the sensor skipped them). A gap filled later is taken back.
    pub lost: u64,
}

impl SensorStats {
    /// Adds `other` counter by counter.
    pub fn add(&mut self, other: &SensorStats) {
        self.received += other.received;
        self.processed += other.processed;
        self.fused += other.fused;
        self.gated += other.gated;
        self.refused += other.refused;
        self.late += other.late;
        self.too_late += other.too_late;
        self.duplicate += other.duplicate;
        self.invalid += other.invalid;
        self.lost += other.lost;
    }

    /// What happened since `before`, counter by counter. Counters that describe
    /// current estimates (fused, gated, refused) or take back (lost) may shrink
    /// through a rewind; their difference saturates at 0.
    pub fn since(&self, before: &SensorStats) -> SensorStats {
        SensorStats {
            received: self.received.saturating_sub(before.received),
            processed: self.processed.saturating_sub(before.processed),
            fused: self.fused.saturating_sub(before.fused),
            gated: self.gated.saturating_sub(before.gated),
            refused: self.refused.saturating_sub(before.refused),
            late: self.late.saturating_sub(before.late),
            too_late: self.too_late.saturating_sub(before.too_late),
            duplicate: self.duplicate.saturating_sub(before.duplicate),
            invalid: self.invalid.saturating_sub(before.invalid),
            lost: self.lost.saturating_sub(before.lost),
        }
    }
}

/// Counters of the engine as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EngineStats {
    /// Samples rejected before a sensor slot could be found (table full).
    pub unknown_sensor: u64,
    /// Late insertions (rewinds).
    pub rewinds: u64,
    /// Samples re-processed by rewinds.
    pub replayed: u64,
    /// Entries evicted because the history was full before the window passed.
    pub evicted_by_capacity: u64,
}
