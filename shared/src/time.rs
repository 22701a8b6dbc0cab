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

#[cfg(test)]
mod tests {
    use super::*;

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
