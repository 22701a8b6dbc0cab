//! Publishing simulated sensors live, paced by the clock.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fusion_shared::now_ns;

use super::{Arrival, ImuSim};
use crate::{ClientError, SensorPublishers};

/// A stream whose samples arrive at or after their timestamps, in timestamp order.
type Delayed = std::iter::Peekable<Box<dyn Iterator<Item = Arrival> + Send>>;

/// Merges an IMU stream (arrivals in order) and delayed streams (positions,
/// velocities: each in timestamp order, arriving out of order after random
/// delays) into one stream in arrival order.
///
/// A delayed sample with timestamp `t` arrives at or after `t`, so every one that
/// can arrive before time `b` has been pulled once each delayed iterator has
/// passed timestamp `b`.
pub struct ArrivalMerge {
    imu: Option<std::iter::Peekable<ImuSim>>,
    delayed: Vec<Delayed>,
    pending: BinaryHeap<Reverse<(u64, u64, usize)>>,
    slots: Vec<Option<Arrival>>,
}

impl ArrivalMerge {
    /// Merges the given streams (the IMU may be absent, `delayed` empty).
    pub fn new(imu: Option<ImuSim>, delayed: Vec<Box<dyn Iterator<Item = Arrival> + Send>>) -> Self {
        Self {
            imu: imu.map(Iterator::peekable),
            delayed: delayed.into_iter().map(Iterator::peekable).collect(),
            pending: BinaryHeap::new(),
            slots: Vec::new(),
        }
    }
}

impl Iterator for ArrivalMerge {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        let imu_next = self.imu.as_mut().and_then(|i| i.peek().map(|a| a.arrival_ns));
        let pending_min = |heap: &BinaryHeap<Reverse<(u64, u64, usize)>>| heap.peek().map(|Reverse(k)| k.0);
        for stream in &mut self.delayed {
            loop {
                let bound = match (imu_next, pending_min(&self.pending)) {
                    (Some(a), Some(b)) => a.min(b),
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => u64::MAX,
                };
                match stream.peek() {
                    Some(p) if p.sample.t_ns() <= bound => {
                        // The simulators are endless: `next` follows a successful `peek`.
                        let Some(p) = stream.next() else { break };
                        let slot = self.slots.iter().position(Option::is_none).unwrap_or_else(|| {
                            self.slots.push(None);
                            self.slots.len() - 1
                        });
                        self.slots[slot] = Some(p);
                        self.pending.push(Reverse((p.arrival_ns, p.sample.t_ns(), slot)));
                    }
                    _ => break,
                }
            }
        }
        let take_delayed = match (imu_next, pending_min(&self.pending)) {
            (Some(a), Some(b)) => b < a,
            (None, Some(_)) => true,
            (_, None) => false,
        };
        if take_delayed {
            let Reverse((_, _, slot)) = self.pending.pop()?;
            self.slots[slot].take()
        } else {
            self.imu.as_mut()?.next()
        }
    }
}

/// Sleeps until CLOCK_MONOTONIC reaches `t_ns` (or `stop` is set).
pub fn sleep_until(t_ns: u64, stop: &AtomicBool) {
    loop {
        let now = now_ns();
        if now >= t_ns || stop.load(Ordering::Relaxed) {
            return;
        }
        // Short slices keep a stop request prompt.
        std::thread::sleep(Duration::from_nanos((t_ns - now).min(50_000_000)));
    }
}

/// What [`play`] published.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Played {
    /// Samples published of each kind (index [`fusion_shared::SampleKind::index`]).
    pub published: [u64; fusion_shared::SampleKind::COUNT],
    /// Samples that reached at least one reader (fusiond, a recorder): none when
    /// no fusiond ran in the namespace.
    pub delivered: u64,
}

/// Publishes `arrivals` at their arrival times until they end, `end_ns` passes
/// or `stop` is set. Samples of a kind without a publisher are skipped.
pub fn play(
    arrivals: impl Iterator<Item = Arrival>,
    publishers: &mut SensorPublishers,
    end_ns: u64,
    stop: &AtomicBool,
) -> Result<Played, ClientError> {
    let mut played = Played::default();
    for a in arrivals {
        if a.arrival_ns > end_ns || stop.load(Ordering::Relaxed) {
            break;
        }
        sleep_until(a.arrival_ns, stop);
        if let Some(readers) = publishers.publish(a.sample)? {
            played.published[a.sample.kind().index()] += 1;
            played.delivered += u64::from(readers > 0);
        }
    }
    Ok(played)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{CarTrajectory, ImuConfig, ImuOutput, PositionConfig, PositionSim, VelocityConfig, VelocitySim};
    use fusion_shared::Sample;

    #[test]
    fn merge_is_in_arrival_order_and_complete() {
        let traj = CarTrajectory::new(1);
        let imu = ImuSim::new(traj.clone(), ImuConfig::default(), ImuOutput::WorldAcceleration, 0, 1);
        let pos =
            PositionSim::new(traj.clone(), PositionConfig { delay_max_ns: 300_000_000, ..Default::default() }, 0, 1);
        let vel = VelocitySim::new(traj.clone(), VelocityConfig::default(), 0, 1);
        let merged: Vec<Arrival> =
            ArrivalMerge::new(Some(imu), vec![Box::new(pos), Box::new(vel)]).take(5000).collect();
        let velocities = merged.iter().filter(|a| matches!(a.sample, Sample::Velocity(_))).count();
        assert!(velocities > 100, "{velocities}");
        assert!(merged.windows(2).all(|w| w[0].arrival_ns <= w[1].arrival_ns));
        let positions: Vec<u64> =
            merged.iter().filter(|a| matches!(a.sample, Sample::Position(_))).map(|a| a.sample.seq()).collect();
        // 5000 arrivals ≈ 12 s: every fix 0..k arrived, none skipped.
        let mut sorted = positions.clone();
        sorted.sort();
        assert_eq!(sorted, (0..positions.len() as u64).collect::<Vec<_>>());
        assert!(positions.len() > 100);
        assert_ne!(positions, sorted, "delays reorder the fixes");
    }
}
