//! One snapshot per IMU instant: the snapshot of an instant that an IMU
//! sample leaves open is held back until the instant's last sample, another
//! sample, the loop's sleep (event mode) or the instant's due time
//! ([`ImuConfig::instant_wait_ns`](crate::frames::ImuConfig::instant_wait_ns)).

use fusion_shared::{Sample, SampleKind, now_ns};

use super::{LiveCore, SnapshotSink};
use crate::measurement::Steps;
use crate::model::held_imu::Instants;

/// An IMU instant whose snapshot waits for the instant's last sample
/// ([`Instants::instant_open`]).
#[derive(Clone, Copy)]
pub(super) struct HeldInstant {
    /// Its newest sample, which the snapshot names if it goes out at `due_ns`.
    pub(super) sample: Sample,
    pub(super) received_ns: u64,
    /// When the snapshot goes out whatever comes: the bounded wait from the
    /// first sample held.
    pub(super) due_ns: u64,
}

impl<M: Steps> LiveCore<M> {
    /// Whether `sample`, just processed in order, is an IMU sample that leaves
    /// its instant open (another IMU of the instant before has yet to send).
    #[inline]
    pub(super) fn opens_instant(&self, sample: &Sample) -> bool {
        self.instant_wait_ns > 0
            && sample.kind() == SampleKind::Imu
            && self.engine.latest().is_some_and(|e| M::instant_open(&e.state))
    }

    /// When the snapshot of an open IMU instant goes out at the latest, ns.
    pub fn instant_due(&self) -> Option<u64> {
        self.held.map(|h| h.due_ns)
    }

    /// Publishes the snapshot of an open IMU instant whose due time has come
    /// by `now` (an IMU missed the instant). Returns whether it did.
    pub fn publish_due(&mut self, now: u64, sink: &mut impl SnapshotSink) -> bool {
        match self.held {
            Some(h) if now >= h.due_ns => {
                self.held = None;
                self.publish_sample(sink, &h.sample, h.received_ns, 0, now.min(now_ns()));
                true
            }
            _ => false,
        }
    }

    /// Publishes an open IMU instant's snapshot now, and wakes the readers
    /// (event mode, before the loop sleeps).
    pub fn publish_open(&mut self, sink: &mut impl SnapshotSink) {
        if self.publish_due(u64::MAX, sink) {
            self.published_health = self.health_now;
            sink.flush();
        }
    }
}
