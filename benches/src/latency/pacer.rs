//! The pace of a sender: ticks at a fixed rate, without bursts after a stall.

use std::time::Duration;

use fusion_shared::now_ns;

/// Sends at a fixed rate: [`wait`](Self::wait) returns at the next tick, sleeping
/// while more than 200 µs remain and spinning the rest, so the sender is awake and
/// on time. Raw and end-to-end rows pace alike, so that they compare like with like
/// (an idle gap between messages costs both sides cache and wake-up state).
pub struct Pacer {
    period_ns: u64,
    next: u64,
}

impl Pacer {
    /// Ticks at `rate_hz`, the first 10 ms from now.
    pub fn new(rate_hz: f64) -> Self {
        Self { period_ns: ((1e9 / rate_hz) as u64).max(1), next: now_ns() + 10_000_000 }
    }

    /// Ticks at `rate_hz`, `behind` late already: what a sender that was
    /// descheduled that long finds when it runs again.
    pub fn behind(rate_hz: f64, behind: Duration) -> Self {
        let behind_ns = u64::try_from(behind.as_nanos()).unwrap_or(u64::MAX);
        Self { period_ns: ((1e9 / rate_hz) as u64).max(1), next: now_ns().saturating_sub(behind_ns) }
    }

    /// Waits for the next tick and returns its time: what an IMU on its own
    /// clock stamps the sample of that tick with (the ticks are a period apart,
    /// on one grid).
    ///
    /// A sender that fell behind (descheduled under CPU load) skips the ticks
    /// it missed instead of sending them back to back: samples stamped `now`
    /// a few µs apart look like a sensor far above its rate, and fusiond's rate
    /// limit (10 kHz, bursts of 100) rightly dropped them, so that their
    /// snapshots never came ("no snapshot for IMU sample N" under load). The
    /// ticks after a stall stay on the grid, as a sensor's clock does.
    pub fn wait(&mut self) -> u64 {
        self.next = next_tick(self.next, self.period_ns, now_ns());
        while now_ns() < self.next {
            if self.next.saturating_sub(now_ns()) > 200_000 {
                std::thread::sleep(Duration::from_micros(100));
            } else {
                std::hint::spin_loop();
            }
        }
        let tick = self.next;
        self.next += self.period_ns;
        tick
    }
}

/// The tick to wait for: `next`, or the last tick of its grid at or before
/// `now` when `now` is more than a period past it (the ticks missed are
/// skipped). Ticks are never closer than a period.
fn next_tick(next: u64, period_ns: u64, now: u64) -> u64 {
    if now > next.saturating_add(period_ns) { next + (now - next) / period_ns * period_ns } else { next }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After a stall of 150 periods the ticks go on a period apart from the
    /// end of the stall: no burst of the missed ones.
    #[test]
    fn a_stalled_pacer_skips_the_ticks_it_missed() {
        let period = 1_000_000;
        let mut next = 10 * period;
        let mut now = next + 150 * period + 1234;
        let mut ticks = Vec::new();
        for _ in 0..20 {
            next = next_tick(next, period, now);
            assert_eq!(next % period, 0, "on the grid");
            now = now.max(next) + 30_000; // the round trip after the tick
            ticks.push(next);
            next += period;
        }
        assert!(ticks.windows(2).all(|w| w[1] - w[0] >= period), "{ticks:?}");
        assert_eq!(ticks[0], 160 * period);
    }
}
