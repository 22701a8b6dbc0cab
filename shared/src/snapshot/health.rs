//! Health states of [`StateSnapshot::health`](super::StateSnapshot::health) and the reason bits.

use crate::SampleKind;

/// Not yet a usable estimate (waiting for samples of every kind, or aligning).
pub const INITIALISING: u32 = 0;
/// Every stream is fresh and the filter is consistent.
pub const OK: u32 = 1;
/// An estimate exists but something is wrong: see the reason bits.
pub const DEGRADED: u32 = 2;

/// Reason bit: the NIS of recent measurements of a sensor is persistently
/// outside its chi-square band (filter and sensor disagree; measurements may be
/// gated for good).
pub const NIS_OUT_OF_BOUNDS: u32 = 1 << 0;
/// Reason bit: samples were lost (subscriber buffer overflow or sensor gaps).
pub const SAMPLES_LOST: u32 = 1 << 1;
/// Reason bit: the filter re-initialised itself recently after a lock-out:
/// from the position fixes after they had all been gated for `[gating]
/// lockout_ns`, or from another kind's samples after a run of them
/// ([`StateSnapshot::reinitialisations`](super::StateSnapshot::reinitialisations)).
pub const REINITIALISED: u32 = 1 << 2;

/// Reason bit: no sample of `kind` for longer than its configured timeout
/// (bit `8 + code`).
pub const fn stale(kind: SampleKind) -> u32 {
    1 << (8 + kind as u32)
}
/// Reason bit: no IMU sample for longer than the configured timeout.
pub const IMU_STALE: u32 = stale(SampleKind::Imu);
/// Reason bit: no position sample for longer than the configured timeout.
pub const POSITION_STALE: u32 = stale(SampleKind::Position);

/// The name of a health state.
pub const fn name(state: u32) -> &'static str {
    match state {
        INITIALISING => "initialising",
        OK => "ok",
        DEGRADED => "degraded",
        _ => "unknown",
    }
}

/// The reason bits that are not about one kind, with their names.
pub const GENERAL_REASONS: [(u32, &str); 3] = [
    (NIS_OUT_OF_BOUNDS, "nis out of bounds"),
    (SAMPLES_LOST, "samples lost"),
    (REINITIALISED, "re-initialised after a lock-out"),
];

/// Every reason bit set in `reasons`, by name: the general ones, then the
/// stale streams in kind order.
pub fn reason_names(reasons: u32) -> impl Iterator<Item = &'static str> {
    let general = GENERAL_REASONS.into_iter().filter(move |(bit, _)| reasons & bit != 0).map(|(_, n)| n);
    let stale = SampleKind::ALL.iter().filter(move |k| reasons & stale(**k) != 0).map(|k| k.stale_reason());
    general.chain(stale)
}
