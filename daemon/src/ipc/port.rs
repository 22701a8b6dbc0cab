//! One sample subscriber of `fusiond run` and the samples it holds back for
//! the merge ([`super::merge`]): fair draining between publishers, and a late
//! head's slot.

use fusion_shared::service;
use fusion_shared::transport::Ipc;
use fusion_shared::{Sample, WireSample};
use iceoryx2::port::ReceiveError;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe;

use super::merge::{Heads, Key};
use crate::measurement;

/// One sample subscriber and the sample it holds back for the merge.
///
/// Fair draining: iceoryx2's `receive` always serves the first publisher that
/// has data, so a publisher that sends without pause would starve the ones that
/// connected after it. The port therefore keeps every sample it took in a turn
/// (up to [`service::MAX_BORROWED_PER_PUBLISHER`] per publisher, the limit set on
/// the service), and `receive` passes over a publisher at that limit to the
/// next: in each turn every publisher gets the same share. The samples are given
/// back at the end of the turn.
///
/// A port whose publishers have all given their share while they have more is
/// *blocked* for the rest of the turn: its next samples are unseen, so the merge
/// ([`super::merge::pick`]) hands out no sample of another port that could come
/// after them, and the turn ends; under a backlog the kinds are drained in
/// timestamp order, not one kind's share ahead of another's.
pub(super) struct KindPort<T: WireSample> {
    subscriber: Subscriber<Ipc, T, ()>,
    service: publish_subscribe::PortFactory<Ipc, T, ()>,
    /// Samples taken this turn, still borrowed (capacity for every publisher's
    /// share: pushing never allocates).
    held: Vec<iceoryx2::sample::Sample<Ipc, T, ()>>,
    pending: Option<T>,
    /// A late sample (older than the newest processed) taken out of the way of
    /// the samples queued behind it: they are merged in time order while it
    /// waits its turn (a retransmitted or late head must not hold back a whole
    /// queue of in-order samples until they are late too).
    late: Option<T>,
    /// The oldest in-order `(t_ns, rank)` received this turn: every
    /// publisher's next sample is at or after its last one, so at or after this.
    /// (A late sample says nothing of what comes after it.)
    turn_oldest: Option<(u64, u8)>,
    /// Every publisher with samples waiting has given its share this turn.
    blocked: bool,
    /// A publisher is connected or samples are waiting (as of the last
    /// [`Port::refresh`]). An empty poll costs about 65 ns, and each one more in a
    /// turn of the spin loop delays the sample that arrives meanwhile: the
    /// subscriber of a kind that no process publishes is not polled.
    active: bool,
}

/// A [`KindPort`] of any wire type.
pub(super) trait Port {
    /// Receives into the pending slot if it is empty. A pending sample older
    /// than `newest` (late) moves to the late slot if that is free, and the
    /// next one is received behind it.
    fn poll(&mut self, errors: &mut u64, newest: Option<Key>) -> Heads;
    /// Whether the port is polled at all ([`Port::refresh`]).
    fn active(&self) -> bool;
    /// Hands the pending sample over (`late`: the late slot's).
    fn take(&mut self, late: bool) -> Option<Sample>;
    /// Housekeeping: whether this kind has a publisher or waiting samples.
    fn refresh(&mut self);
    /// Gives back the samples taken this turn.
    fn release(&mut self);
}

impl<T: WireSample> KindPort<T> {
    /// The port of `subscriber` to `service`, with room to hold every
    /// publisher's share of a turn.
    pub(super) fn new(subscriber: Subscriber<Ipc, T, ()>, service: publish_subscribe::PortFactory<Ipc, T, ()>) -> Self {
        let held = Vec::with_capacity(service::MAX_SAMPLE_PUBLISHERS * service::MAX_BORROWED_PER_PUBLISHER);
        let mut port = Self {
            subscriber,
            service,
            held,
            pending: None,
            late: None,
            turn_oldest: None,
            blocked: false,
            active: true,
        };
        port.refresh();
        port
    }

    fn key(sample: &T) -> Key {
        (sample.header().t_ns, measurement::rank(T::KIND))
    }

    /// Receives one sample into the (empty) pending slot.
    fn receive(&mut self, errors: &mut u64, newest: Option<Key>) {
        match self.subscriber.receive() {
            // Copied out, and held until the end of the turn (fair draining).
            Ok(Some(sample)) => {
                let key = Self::key(sample.payload());
                if newest.is_none_or(|n| key >= n) {
                    self.turn_oldest = Some(self.turn_oldest.map_or(key, |k| k.min(key)));
                }
                self.pending = Some(*sample);
                if self.held.len() < self.held.capacity() {
                    self.held.push(sample);
                }
            }
            Ok(None) => {}
            // Every publisher with data has given its share of this turn.
            Err(ReceiveError::ExceedsMaxBorrows) => self.blocked = true,
            Err(e) => {
                if *errors == 0 {
                    tracing::warn!("{} receive: {e:?} (further failures are only counted)", T::KIND.name());
                }
                *errors += 1;
            }
        }
    }
}

impl<T: WireSample> Port for KindPort<T> {
    fn poll(&mut self, errors: &mut u64, newest: Option<Key>) -> Heads {
        if self.pending.is_none() && self.active {
            self.receive(errors, newest);
        }
        // A late head steps aside into the late slot, and the sample behind it
        // is received: it is merged in time order, not held back until late.
        if self.late.is_none()
            && let Some(p) = self.pending
            && newest.is_some_and(|n| Self::key(&p) < n)
        {
            self.late = self.pending.take();
            if self.active {
                self.receive(errors, newest);
            }
        }
        Heads {
            pending: self.pending.as_ref().map(Self::key),
            late: self.late.as_ref().map(Self::key),
            // Blocked with nothing taken cannot be (the borrows are this
            // turn's); then nothing of this port bounds the others.
            bound: self.turn_oldest.filter(|_| self.blocked),
        }
    }

    fn active(&self) -> bool {
        self.active
    }

    fn take(&mut self, late: bool) -> Option<Sample> {
        let slot = if late { &mut self.late } else { &mut self.pending };
        slot.take().map(WireSample::into_sample)
    }

    fn refresh(&mut self) {
        self.active =
            self.service.dynamic_config().number_of_publishers() > 0 || self.subscriber.has_samples().unwrap_or(true);
    }

    fn release(&mut self) {
        self.held.clear();
        (self.turn_oldest, self.blocked) = (None, false);
    }
}
