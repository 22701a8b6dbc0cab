//! ROS time and fusiond's clock.
//!
//! fusiond stamps and judges samples on CLOCK_MONOTONIC; a ROS 2 header
//! stamp is ROS time: the wall clock (CLOCK_REALTIME), or under
//! `use_sim_time` the time `/clock` last said. fusion-ros keeps one offset,
//! `ROS time − monotonic`, and moves every stamp by it both ways: a sample
//! stamped `s` goes to fusiond at `s − offset`, and an estimate at `t` goes
//! out stamped `t + offset`. While the offset holds, an odometry message
//! carries exactly the stamp of the sample it is after, as a ROS user
//! expects of a filter.
//!
//! - **Wall**: the offset is read at the start and again every second; a
//!   change of more than [`WALL_STEP_NS`] (NTP set the clock) is taken and
//!   counted, smaller drift is not (it would move stamps for nothing).
//! - **Sim**: the first `/clock` message sets the offset; a later one more
//!   than [`SIM_SLACK_NS`] from it (the bag paused, looped, or played at
//!   another rate) sets it again, and is counted. Until the first `/clock`,
//!   samples are refused ("no /clock yet").

use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU64, Ordering};

use fusion_shared::time::{now_ns, wall_minus_monotonic_ns};

use crate::settings::ClockSource;

/// A wall clock set by more than this is a new offset, ns.
pub const WALL_STEP_NS: i64 = 10_000_000;
/// A `/clock` this far from the offset's time sets it again, ns.
pub const SIM_SLACK_NS: i64 = 1_000_000_000;

/// The offset between ROS time and fusiond's clock (shared by the input and
/// output threads).
#[derive(Debug)]
pub struct RosClock {
    source: ClockSource,
    offset_ns: AtomicI64,
    set: AtomicBool,
    /// Times the offset was taken again (a clock set, a bag looped).
    pub steps: AtomicU64,
}

impl RosClock {
    /// A clock of `source`; wall time has its offset at once.
    pub fn new(source: ClockSource) -> Self {
        let c = Self { source, offset_ns: AtomicI64::new(0), set: AtomicBool::new(false), steps: AtomicU64::new(0) };
        if source == ClockSource::Wall {
            c.offset_ns.store(wall_minus_monotonic_ns() as i64, Ordering::Relaxed);
            c.set.store(true, Ordering::Release);
        }
        c
    }

    /// Where the stamps come from.
    pub fn source(&self) -> ClockSource {
        self.source
    }

    /// `ROS time − monotonic`, ns, once known.
    pub fn offset_ns(&self) -> Option<i64> {
        self.set.load(Ordering::Acquire).then(|| self.offset_ns.load(Ordering::Relaxed))
    }

    /// The monotonic time of ROS time `ros_ns`, or why there is none.
    pub fn to_monotonic(&self, ros_ns: u64) -> Result<u64, &'static str> {
        let offset = self.offset_ns().ok_or("no /clock yet (clock = \"sim\")")?;
        u64::try_from(i128::from(ros_ns) - i128::from(offset)).map_err(|_| "stamped before this host's boot")
    }

    /// The ROS time of monotonic time `mono_ns`.
    pub fn to_ros(&self, mono_ns: u64) -> Option<u64> {
        u64::try_from(i128::from(mono_ns) + i128::from(self.offset_ns()?)).ok()
    }

    /// A `/clock` message saying `sim_ns`, received at monotonic `mono_ns`.
    pub fn on_clock(&self, sim_ns: u64, mono_ns: u64) {
        if self.source != ClockSource::Sim {
            return;
        }
        let offset = (i128::from(sim_ns) - i128::from(mono_ns)).clamp(i64::MIN.into(), i64::MAX.into()) as i64;
        match self.offset_ns() {
            None => {}
            Some(o) if (o - offset).abs() <= SIM_SLACK_NS => return,
            Some(_) => {
                self.steps.fetch_add(1, Ordering::Relaxed);
            }
        }
        self.offset_ns.store(offset, Ordering::Relaxed);
        self.set.store(true, Ordering::Release);
    }

    /// Reads the wall clock's offset again (call about once a second): takes
    /// it, and returns the step, when it moved by more than [`WALL_STEP_NS`].
    pub fn check_wall(&self) -> Option<i64> {
        if self.source != ClockSource::Wall {
            return None;
        }
        let now = wall_minus_monotonic_ns() as i64;
        let step = now - self.offset_ns.load(Ordering::Relaxed);
        if step.abs() <= WALL_STEP_NS {
            return None;
        }
        self.offset_ns.store(now, Ordering::Relaxed);
        self.steps.fetch_add(1, Ordering::Relaxed);
        Some(step)
    }

    /// Now, in ROS time (0 before the sim clock is known).
    pub fn now_ros(&self) -> u64 {
        self.to_ros(now_ns()).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stamp goes to fusiond and comes back unchanged while the offset holds.
    #[test]
    fn stamps_go_both_ways_exactly() {
        let c = RosClock::new(ClockSource::Sim);
        assert!(c.to_monotonic(5).is_err());
        c.on_clock(1_700_000_000_000_000_000, 1_000_000_000);
        let mono = c.to_monotonic(1_700_000_000_500_000_123).unwrap();
        assert_eq!(mono, 1_500_000_123);
        assert_eq!(c.to_ros(mono), Some(1_700_000_000_500_000_123));
        // A /clock at its pace keeps the offset; one 2 s off (a bag looped) takes it again.
        c.on_clock(1_700_000_001_000_000_000, 2_000_300_000);
        assert_eq!(c.to_monotonic(1_700_000_000_500_000_123), Ok(1_500_000_123));
        c.on_clock(1_700_000_000_000_000_000, 3_000_000_000);
        assert_eq!(c.steps.load(Ordering::Relaxed), 1);
        assert_eq!(c.to_monotonic(1_700_000_000_000_000_000), Ok(3_000_000_000));
    }

    #[test]
    fn wall_time_is_the_realtime_clock() {
        let c = RosClock::new(ClockSource::Wall);
        let wall = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos() as u64;
        let mono = c.to_monotonic(wall).unwrap();
        assert!(mono.abs_diff(now_ns()) < 50_000_000, "{mono} vs {}", now_ns());
        assert_eq!(c.check_wall(), None);
    }
}
