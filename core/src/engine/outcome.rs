//! What the engine hands out: each insert's outcome, the history's entries, a
//! correction still on its way to the newest estimate.

#[cfg(doc)]
use super::Engine;
use crate::model::StepOutcome;
use crate::reorder::{Sample, SampleKey};
use crate::validate::Rejection;

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
    /// Late, and placed by [`Engine::insert_deferred`]: it is processed, and the
    /// `replayed` later samples re-processed, when the rewind reaches it
    /// ([`Engine::settle_step`]); its outcome then comes from
    /// [`Engine::take_first_outcomes`]. Counted as processed and late at once.
    Placed {
        /// Number of later samples to re-process because this one came late.
        replayed: usize,
    },
    /// Refused by validation.
    Rejected(Rejection),
    /// The same sensor and sequence number was processed already.
    Duplicate,
    /// Older than the history can restore.
    TooLate,
    /// The sensor sends faster than `max_rate_hz` allows: dropped.
    RateLimited,
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
    pub(super) slot: u16,
    /// Placed late and not yet processed (its state and outcome mean nothing yet).
    pub(super) fresh: bool,
}

/// Late samples' first outcomes the engine keeps until the caller takes them
/// ([`Engine::take_first_outcomes`]); more are not kept.
pub const FIRST_OUTCOMES: usize = 64;

/// A correction that has not yet reached the newest estimate: late samples were
/// inserted, and entries after them still hold states computed without them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Correction {
    /// History entries still to re-step ([`Engine::settle_step`] takes one).
    pub steps: usize,
    /// Time of validity of the oldest sample whose effect has not yet reached
    /// the newest estimate, ns.
    pub since_t_ns: u64,
}
