//! The engine's engine-wide counters (a sensor's own are in its row of the
//! [`crate::sensor_table`]).

/// Counters of the engine as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EngineStats {
    /// Samples refused in validation, by [`Rejection::code`](crate::validate::Rejection::code)
    /// (every sensor's, those without a slot included).
    pub rejections: [u64; fusion_shared::snapshot::rejection::MAX],
    /// Samples counted against no sensor slot: the table was full, or the sample
    /// was invalid and from a sensor without a slot (it takes none).
    pub unknown_sensor: u64,
    /// Late insertions (rewinds).
    pub rewinds: u64,
    /// Samples re-processed by rewinds.
    pub replayed: u64,
    /// Entries evicted because the history was full before the window passed.
    pub evicted_by_capacity: u64,
    /// Stale entries re-stepped by [`Engine::settle_step`](super::Engine::settle_step):
    /// the part of the rewinds done off the latency path, in the live loop's idle time.
    pub background_steps: u64,
    /// Stale entries re-stepped inline: by [`Engine::insert`](super::Engine::insert)
    /// and [`Engine::settle`](super::Engine::settle), or because they were about to
    /// leave the history.
    pub settled_inline: u64,
    /// Propagations ahead of the next input by [`Engine::step_ahead`](super::Engine::step_ahead).
    pub stepped_ahead: u64,
    /// In-order samples whose step started from a state stepped ahead to their
    /// time (only fused on the latency path).
    pub stepped_from_ahead: u64,
    /// New timelines begun without a clock (replay): runs of samples far ahead
    /// of or back behind the newest ([`crate::engine::JUMP_CONFIRMATION`]).
    pub new_timelines: u64,
    /// The last new timeline's step: the first far sample's time (the first of
    /// the run that confirmed it) less the newest before it, ns (negative: the
    /// clock went back).
    pub last_timeline_step_ns: i128,
}
