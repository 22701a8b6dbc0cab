//! Telling systemd (or any supervisor speaking its notify protocol) how the
//! daemon is: READY once the services are open, WATCHDOG while the fusion loop
//! turns, STOPPING on shutdown (`sd_notify(3)`, with the `sd-notify` crate).
//!
//! Without `NOTIFY_SOCKET` in the environment (not started by systemd with
//! `Type=notify`) every call here does nothing. The watchdog period comes from
//! `WATCHDOG_USEC` (`WatchdogSec=` in the unit); the loop pets it at half the
//! period, as `sd_watchdog_enabled(3)` advises, from the loop's own thread: a
//! loop that stops turning stops the messages, and systemd restarts the service.
//! A failed notification is logged once and never stops the daemon.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use sd_notify::NotifyState;

use crate::live::RunReport;

/// Sends `states` to the service manager; logs the first failure of each kind
/// of message.
fn notify(states: &[NotifyState], warned: &mut bool) {
    if let Err(e) = sd_notify::notify(states)
        && !std::mem::replace(warned, true)
    {
        tracing::warn!(error = %e, "cannot notify the service manager (NOTIFY_SOCKET)");
    }
}

/// READY=1 with a status line: the services are open, samples are fused.
pub fn ready(status: &str) {
    notify(&[NotifyState::Ready, NotifyState::Status(status)], &mut false);
}

/// STOPPING=1: the daemon is shutting down.
pub fn stopping() {
    notify(&[NotifyState::Stopping, NotifyState::Status("stopping")], &mut false);
}

/// The watchdog of the fusion loop: [`pet`](Self::pet) from the loop, at any
/// rate; it sends WATCHDOG=1 at most every half period.
#[derive(Debug)]
pub struct Watchdog {
    /// Half the configured period, ns; `None` when no watchdog is configured.
    interval_ns: Option<u64>,
    next_ns: u64,
    warned: bool,
}

impl Watchdog {
    /// The watchdog `WATCHDOG_USEC` asks for (none when it is unset, or when
    /// `WATCHDOG_PID` names another process).
    pub fn from_env() -> Self {
        Self::with_period(sd_notify::watchdog_enabled())
    }

    /// A watchdog of `period` (none: never sends).
    pub fn with_period(period: Option<Duration>) -> Self {
        let interval_ns = period.map(|p| (p.as_nanos() / 2).clamp(1, u64::MAX as u128) as u64);
        Self { interval_ns, next_ns: 0, warned: false }
    }

    /// The configured period, if any.
    pub fn period(&self) -> Option<Duration> {
        self.interval_ns.map(|i| Duration::from_nanos(i.saturating_mul(2)))
    }

    /// The loop turns at `now_ns`: sends WATCHDOG=1 if half a period passed
    /// since the last one. Returns whether it sent.
    pub fn pet(&mut self, now_ns: u64) -> bool {
        match self.interval_ns {
            Some(interval) if now_ns >= self.next_ns => {
                self.next_ns = now_ns.saturating_add(interval);
                notify(&[NotifyState::Watchdog], &mut self.warned);
                true
            }
            _ => false,
        }
    }
}

/// Fault injection for checking a supervisor: after `after_samples` samples
/// the fusion loop stops turning (it sleeps, looking only at `shutdown`) while
/// the process stays up, as a loop stuck in a bug would. `fusiond run
/// --fault-stall-after N`.
#[derive(Debug, Clone, Copy)]
pub struct StallFault {
    /// Samples taken before the loop stalls.
    pub after_samples: u64,
}

impl StallFault {
    /// Stalls the calling thread (the loop) until `shutdown` if the loop has
    /// taken its samples.
    pub fn check(&self, report: RunReport, shutdown: &AtomicBool) {
        if report.received < self.after_samples {
            return;
        }
        tracing::warn!(samples = report.received, "fault injection: the fusion loop stalls until shutdown");
        while !shutdown.load(std::sync::atomic::Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_watchdog_sends_at_half_its_period() {
        let mut w = Watchdog::with_period(Some(Duration::from_millis(100)));
        assert_eq!(w.period(), Some(Duration::from_millis(100)));
        let t0 = 1_000_000_000;
        assert!(w.pet(t0));
        assert!(!w.pet(t0 + 49_999_999));
        assert!(w.pet(t0 + 50_000_000));
        assert!(!w.pet(t0 + 60_000_000));
        let mut none = Watchdog::with_period(None);
        assert!(!none.pet(t0));
        assert_eq!(none.period(), None);
    }
}
