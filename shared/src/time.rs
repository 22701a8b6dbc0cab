//! The one clock of the system: CLOCK_MONOTONIC in nanoseconds.
//!
//! Sample timestamps are the time of validity of the measurement on this clock,
//! stamped by the sensor process. Wall-clock time is never used for samples.
//! CLOCK_MONOTONIC is shared by all processes of the machine, so a timestamp
//! stamped in one process can be compared with `now_ns()` in another.

use rustix::time::{ClockId, clock_gettime};

/// Nanoseconds of CLOCK_MONOTONIC (vDSO `clock_gettime`, ~20 ns).
pub fn now_ns() -> u64 {
    let ts = clock_gettime(ClockId::Monotonic);
    // CLOCK_MONOTONIC is never negative; `as` would only matter after 584 years of uptime.
    (ts.tv_sec as u64).saturating_mul(1_000_000_000).saturating_add(ts.tv_nsec as u64)
}

/// How far the wall clock (CLOCK_REALTIME, ns since the Unix epoch) is ahead
/// of [`now_ns`], read now: add it to a CLOCK_MONOTONIC time to show it as a
/// date (recordings, Foxglove). The two clocks are read back to back (the
/// smaller of three tries' gaps), so the offset is good to about a microsecond,
/// and it changes when the wall clock is set.
pub fn wall_minus_monotonic_ns() -> u64 {
    (0..3)
        .map(|_| {
            let before = now_ns();
            let wall = clock_gettime(ClockId::Realtime);
            let after = now_ns();
            let wall = (wall.tv_sec as u64).saturating_mul(1_000_000_000).saturating_add(wall.tv_nsec as u64);
            (after - before, wall.saturating_sub(before + (after - before) / 2))
        })
        .min_by_key(|(gap, _)| *gap)
        .map_or(0, |(_, offset)| offset)
}

/// Without a clock (a recording, a bag), this many samples in a row ahead of
/// the newest by more than `[validation] max_jump_ns` are refused; the next
/// one is taken as a real gap in the recording, and time moves on. fusiond's
/// replay and `fusion-sim run --input` keep the same rule ([`TimeJumps`]).
pub const JUMP_CONFIRMATION: u32 = 100;

/// The default of `[validation] max_jump_ns`.
pub const DEFAULT_MAX_JUMP_NS: u64 = 600_000_000_000;

/// A recording's stamps checked as fusiond's replay checks them: a stamp more
/// than `max_jump_ns` ahead of every one before it is refused, unless
/// [`JUMP_CONFIRMATION`] such stamps in a row show a real gap.
#[derive(Debug, Clone, Copy)]
pub struct TimeJumps {
    max_jump_ns: u64,
    newest: Option<u64>,
    in_a_row: u32,
}

impl TimeJumps {
    /// The rule with `max_jump_ns`.
    pub fn new(max_jump_ns: u64) -> Self {
        Self { max_jump_ns, newest: None, in_a_row: 0 }
    }

    /// Whether a sample stamped `t_ns` is taken (and then counts as the newest).
    pub fn admit(&mut self, t_ns: u64) -> bool {
        if let Some(newest) = self.newest
            && t_ns > newest.saturating_add(self.max_jump_ns)
        {
            self.in_a_row += 1;
            if self.in_a_row <= JUMP_CONFIRMATION {
                return false;
            }
        }
        self.in_a_row = 0;
        self.newest = Some(self.newest.map_or(t_ns, |n| n.max(t_ns)));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamp_far_ahead_is_refused_until_a_run_of_them_shows_a_gap() {
        let mut jumps = TimeJumps::new(10);
        assert!(jumps.admit(100) && jumps.admit(105));
        assert!(!jumps.admit(1_000_000), "one stamp far ahead");
        assert!(jumps.admit(106), "the stream goes on");
        let refused = (0..JUMP_CONFIRMATION as u64).filter(|k| !jumps.admit(5_000 + k)).count();
        assert_eq!(refused, JUMP_CONFIRMATION as usize);
        assert!(jumps.admit(6_000) && jumps.admit(6_001), "a real gap: time moved on");
    }

    #[test]
    fn now_ns_is_the_clock_behind_instant() {
        // Bracketing by Instant (CLOCK_MONOTONIC on Linux) holds only if both read the
        // same clock: an interval measured inside must not exceed the one outside.
        let outer_start = std::time::Instant::now();
        let a = now_ns();
        std::thread::sleep(std::time::Duration::from_millis(2));
        let b = now_ns();
        let outer = outer_start.elapsed().as_nanos() as u64;
        assert!(b - a >= 2_000_000, "slept 2 ms but the clock moved {} ns", b - a);
        assert!(b - a <= outer, "inner {} ns > outer {} ns", b - a, outer);
    }
}
