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

/// Without a clock (a recording, a bag), this many samples in a row further
/// from the newest than `[validation] max_jump_ns` (ahead of it, or back
/// behind it) are refused; the next one shows that the recording's clock was
/// set (a robot's wall clock stepped by NTP, a bag's clock started again) or
/// that the recording has a real gap, and starts a new timeline. fusiond's
/// replay and `fusion-sim run --input` keep the same rule ([`JumpRun`],
/// [`TimeJumps`]).
pub const JUMP_CONFIRMATION: u32 = 100;

/// The default of `[validation] max_jump_ns`.
pub const DEFAULT_MAX_JUMP_NS: u64 = 600_000_000_000;

/// Which way a stamp is far from the newest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// More than `max_jump_ns` ahead of the newest.
    Ahead,
    /// More than `max_jump_ns` back behind the newest.
    Back,
}

/// What [`JumpRun::judge`] makes of a stamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Jump {
    /// Within `max_jump_ns` of the newest (or the first stamp): taken.
    Near,
    /// Far from the newest, and not yet confirmed by a run: refused.
    Refused(Direction),
    /// The [`JUMP_CONFIRMATION`]-plus-first stamp in a row far from the newest
    /// the same way: taken, and a new timeline begins with it. `step_ns` is how
    /// far it is from the newest (negative: the clock went back).
    NewTimeline {
        /// How far the clock was set: the run's first stamp less the newest
        /// before it, ns (negative: back).
        step_ns: i128,
        /// The first stamp of the run that confirmed it (refused), ns.
        run_start_ns: u64,
    },
}

/// The run of stamps far from the newest, the same way, so far: the rule of
/// [`JUMP_CONFIRMATION`] for a caller that keeps its own newest stamp (the
/// engine's is the newest processed).
#[derive(Debug, Clone, Copy)]
pub struct JumpRun {
    max_jump_ns: u64,
    /// The run's direction, length and first stamp.
    run: Option<(Direction, u32, u64)>,
}

impl JumpRun {
    /// The rule with `max_jump_ns`.
    pub fn new(max_jump_ns: u64) -> Self {
        Self { max_jump_ns, run: None }
    }

    /// Judges a stamp `t_ns` against `newest` (`None`: nothing before it).
    /// A stamp near the newest ends any run; a run that changes direction
    /// starts again.
    pub fn judge(&mut self, newest: Option<u64>, t_ns: u64) -> Jump {
        let direction = match newest {
            Some(n) if t_ns > n.saturating_add(self.max_jump_ns) => Direction::Ahead,
            Some(n) if t_ns < n.saturating_sub(self.max_jump_ns) => Direction::Back,
            _ => {
                self.run = None;
                return Jump::Near;
            }
        };
        let (count, run_start_ns) = match self.run {
            Some((d, n, start)) if d == direction => (n + 1, start),
            _ => (1, t_ns),
        };
        if count > JUMP_CONFIRMATION {
            self.run = None;
            let step_ns = i128::from(run_start_ns) - i128::from(newest.unwrap_or(run_start_ns));
            return Jump::NewTimeline { step_ns, run_start_ns };
        }
        self.run = Some((direction, count, run_start_ns));
        Jump::Refused(direction)
    }
}

/// A recording's stamps checked as fusiond's replay checks them ([`JumpRun`]
/// with the newest stamp taken so far; a new timeline's first stamp is the
/// newest from then on).
#[derive(Debug, Clone, Copy)]
pub struct TimeJumps {
    run: JumpRun,
    newest: Option<u64>,
}

impl TimeJumps {
    /// The rule with `max_jump_ns`.
    pub fn new(max_jump_ns: u64) -> Self {
        Self { run: JumpRun::new(max_jump_ns), newest: None }
    }

    /// Judges a stamp `t_ns`; a stamp taken counts as the newest.
    pub fn admit(&mut self, t_ns: u64) -> Jump {
        let jump = self.run.judge(self.newest, t_ns);
        match jump {
            Jump::Near => self.newest = Some(self.newest.map_or(t_ns, |n| n.max(t_ns))),
            Jump::NewTimeline { .. } => self.newest = Some(t_ns),
            Jump::Refused(_) => {}
        }
        jump
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamp_far_ahead_is_refused_until_a_run_of_them_shows_a_gap() {
        let mut jumps = TimeJumps::new(10);
        assert!(jumps.admit(100) == Jump::Near && jumps.admit(105) == Jump::Near);
        assert_eq!(jumps.admit(1_000_000), Jump::Refused(Direction::Ahead), "one stamp far ahead");
        assert_eq!(jumps.admit(106), Jump::Near, "the stream goes on");
        let refused = (0..JUMP_CONFIRMATION as u64).filter(|k| jumps.admit(5_000 + k) != Jump::Near).count();
        assert_eq!(refused, JUMP_CONFIRMATION as usize);
        let new = Jump::NewTimeline { step_ns: 5_000 - 106, run_start_ns: 5_000 };
        assert_eq!(jumps.admit(6_000), new, "a real gap: time moved on");
        assert_eq!(jumps.admit(6_001), Jump::Near);
    }

    #[test]
    fn a_clock_set_back_starts_a_new_timeline_after_a_run_of_stamps_behind() {
        let mut jumps = TimeJumps::new(10);
        assert_eq!(jumps.admit(10_000), Jump::Near);
        assert_eq!(jumps.admit(9_995), Jump::Near, "a late stamp within the bound");
        for k in 0..JUMP_CONFIRMATION as u64 {
            assert_eq!(jumps.admit(100 + k), Jump::Refused(Direction::Back), "{k}");
        }
        assert_eq!(jumps.admit(300), Jump::NewTimeline { step_ns: 100 - 10_000, run_start_ns: 100 });
        assert_eq!(jumps.admit(301), Jump::Near, "the new timeline goes on");
    }

    #[test]
    fn a_run_that_changes_direction_or_meets_a_near_stamp_starts_again() {
        let mut jumps = TimeJumps::new(10);
        jumps.admit(1_000);
        for k in 0..2 * JUMP_CONFIRMATION as u64 {
            // Garbage both ways, alternately: never a timeline.
            let t = if k % 2 == 0 { 1_000_000 + k } else { k };
            assert!(matches!(jumps.admit(t), Jump::Refused(_)), "{k}");
        }
        for k in 0..2 * JUMP_CONFIRMATION as u64 {
            // Ahead, with the stream between: never a timeline.
            let t = if k % 2 == 0 { 1_000_000 + k } else { 1_000 + k };
            assert!(!matches!(jumps.admit(t), Jump::NewTimeline { .. }), "{k}");
        }
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
