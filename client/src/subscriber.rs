//! The snapshot subscriber: any process's view of the fused state.

use std::time::{Duration, Instant};

use fusion_shared::StateSnapshot;
use fusion_shared::transport::Ipc;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::subscriber::{Subscriber, SubscriberCreateError};
use iceoryx2::sample::Sample;
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::event::PortFactory;

use crate::ClientError;

/// Longest single sleep while waiting: a reader that connected after the last
/// snapshot receives the service's history (the latest snapshot) within the
/// daemon's 10 ms housekeeping tick, which sends no event, so waits re-check at
/// least this often.
const WAIT_SLICE: Duration = Duration::from_millis(5);

/// Reads [`StateSnapshot`]s from `<ns>/state`, zero-copy: the returned reference
/// points into shared memory and stays valid until the next call.
///
/// ```no_run
/// # fn main() -> Result<(), fusion_client::ClientError> {
/// use std::time::Duration;
/// use fusion_client::Client;
/// let client = Client::connect("fusion")?;
/// let mut state = client.state_subscriber()?;
/// if let Some(s) = state.wait_next(Duration::from_secs(1))? {
///     println!("position {:?} at t = {} ns, health {}", &s.state()[..3], s.t_ns,
///              fusion_shared::snapshot::health::name(s.health));
/// }
/// # Ok(())
/// # }
/// ```
pub struct StateSubscriber {
    service: String,
    /// `<ns>/state` itself: whether fusiond still publishes there.
    state: iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, StateSnapshot, ()>,
    subscriber: Subscriber<Ipc, StateSnapshot, ()>,
    event: PortFactory<Ipc>,
    /// Created by the first [`wait_next`](Self::wait_next): a reader that only
    /// polls has none, so fusiond's notify after every snapshot does not write to
    /// it (about 1 µs of the daemon's time per listener).
    listener: Option<Listener<Ipc>>,
    held: Option<Sample<Ipc, StateSnapshot, ()>>,
}

/// Tells fusiond that a reader was refused a slot, so it counts it
/// ([`StateSnapshot::readers_refused`]): an event with
/// [`READER_REFUSED_EVENT`](fusion_shared::service::READER_REFUSED_EVENT) on
/// `<ns>/wake`. Best effort: the refusal itself is the error the caller gets.
fn report_refused(client: &crate::Client) {
    let Ok(wake) = fusion_shared::service::event_service(client.node(), &client.names().wake) else { return };
    if let Ok(notifier) = wake.notifier_builder().create() {
        let _ = notifier
            .notify_with_custom_event_id(iceoryx2::prelude::EventId::new(fusion_shared::service::READER_REFUSED_EVENT));
    }
}

impl StateSubscriber {
    pub(crate) fn new(client: &crate::Client, buffer: usize) -> Result<Self, ClientError> {
        let names = client.names();
        let service = match fusion_shared::service::state_service(client.node(), names, None) {
            Ok(s) => s,
            Err(fusion_shared::service::ServiceError::DoesNotExist { .. }) => {
                return Err(ClientError::DaemonNotRunning { namespace: names.namespace.clone() });
            }
            Err(e) => return Err(e.into()),
        };
        let port = |detail: String| ClientError::Port { service: names.state.clone(), detail };
        let subscriber = service
            .subscriber_builder()
            .buffer_size(buffer.clamp(1, fusion_shared::service::STATE_BUFFER))
            .create()
            .map_err(|e| match e {
                SubscriberCreateError::ExceedsMaxSupportedSubscribers => {
                    report_refused(client);
                    ClientError::ReadersFull {
                        service: names.state.clone(),
                        max: service.static_config().max_subscribers(),
                    }
                }
                e => port(format!("{e:?}")),
            })?;
        let event = fusion_shared::service::event_service(client.node(), &names.state)?;
        Ok(Self { service: names.state.clone(), state: service, subscriber, event, listener: None, held: None })
    }

    /// Whether a fusiond publishes on `<ns>/state` now. The service outlives
    /// the daemon while readers hold it (a `fusionctl top`, this one): a
    /// reader opened after fusiond stopped still finds it, and the last
    /// snapshot in it, but no publisher.
    pub fn fusiond_publishes(&self) -> bool {
        self.state.dynamic_config().number_of_publishers() > 0
    }

    /// The listener on `<ns>/state`, created on first use.
    fn listener(&mut self) -> Result<&Listener<Ipc>, ClientError> {
        let listener = match self.listener.take() {
            Some(l) => l,
            None => self
                .event
                .listener_builder()
                .create()
                .map_err(|e| ClientError::Port { service: self.service.clone(), detail: format!("{e:?}") })?,
        };
        Ok(self.listener.insert(listener))
    }

    fn receive(&mut self) -> Result<bool, ClientError> {
        match self.subscriber.receive() {
            Ok(Some(sample)) => {
                self.held = Some(sample);
                Ok(true)
            }
            Ok(None) => Ok(false),
            Err(e) => Err(ClientError::Receive { service: self.service.clone(), detail: format!("{e:?}") }),
        }
    }

    /// The newest snapshot, skipping any older unread ones; the last one returned
    /// if nothing new arrived; `None` if none ever did. Never blocks.
    pub fn latest(&mut self) -> Result<Option<&StateSnapshot>, ClientError> {
        while self.receive()? {}
        Ok(self.held.as_deref())
    }

    /// The next unread snapshot in publication order, or `None` right away if
    /// there is none. Reading with this keeps every snapshot while the reader keeps
    /// up (the buffer holds [`Client::state_subscriber_with_buffer`] snapshots).
    ///
    /// [`Client::state_subscriber_with_buffer`]: crate::Client::state_subscriber_with_buffer
    pub fn try_next(&mut self) -> Result<Option<&StateSnapshot>, ClientError> {
        Ok(if self.receive()? { self.held.as_deref() } else { None })
    }

    /// The next unread snapshot, sleeping on the `<ns>/state` event until one
    /// arrives or `timeout` passes (`None`). Uses no CPU while waiting.
    pub fn wait_next(&mut self, timeout: Duration) -> Result<Option<&StateSnapshot>, ClientError> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.receive()? {
                return Ok(self.held.as_deref());
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            match self.listener()?.timed_wait(|_| {}, fusion_shared::service::listener_timeout(left.min(WAIT_SLICE))) {
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                Err(e) => {
                    return Err(ClientError::Receive { service: self.service.clone(), detail: format!("{e:?}") });
                }
            }
        }
    }

    /// The next unread snapshot, busy-polling until one arrives or `timeout`
    /// passes: the lowest latency, at the cost of a core while waiting.
    pub fn spin_next(&mut self, timeout: Duration) -> Result<Option<&StateSnapshot>, ClientError> {
        let deadline = Instant::now() + timeout;
        let mut spins = 0u32;
        loop {
            if self.receive()? {
                return Ok(self.held.as_deref());
            }
            spins = spins.wrapping_add(1);
            // Reading the clock costs ~20 ns; every 256th turn is often enough.
            if spins.is_multiple_of(256) && Instant::now() >= deadline {
                return Ok(None);
            }
            std::hint::spin_loop();
        }
    }
}

/// Reads the samples sent on every `<ns>/<kind>` service, as fusiond does (a
/// recorder's view of the input): each kind's subscriber holds
/// [`SAMPLE_BUFFER`](fusion_shared::service::SAMPLE_BUFFER) samples, so a reader
/// that polls at least every second keeps up with a 1 kHz IMU. It takes one of
/// the [`MAX_SAMPLE_SUBSCRIBERS`](fusion_shared::service::MAX_SAMPLE_SUBSCRIBERS)
/// subscriber slots of each service.
pub struct SampleSubscriber {
    kinds: Vec<Box<dyn KindSubscriber>>,
    next: usize,
}

/// One kind's subscriber, its wire type erased.
trait KindSubscriber {
    fn receive(&mut self) -> Result<Option<fusion_shared::Sample>, ClientError>;
}

struct Typed<T: fusion_shared::WireSample> {
    service: String,
    subscriber: Subscriber<Ipc, T, ()>,
}

impl<T: fusion_shared::WireSample> KindSubscriber for Typed<T> {
    fn receive(&mut self) -> Result<Option<fusion_shared::Sample>, ClientError> {
        match self.subscriber.receive() {
            // Copied out at once: the slot goes back to the publisher.
            Ok(Some(s)) => Ok(Some((*s).into_sample())),
            Ok(None) => Ok(None),
            Err(e) => Err(ClientError::Receive { service: self.service.clone(), detail: format!("{e:?}") }),
        }
    }
}

impl SampleSubscriber {
    pub(crate) fn new(client: &crate::Client) -> Result<Self, ClientError> {
        struct Open<'a> {
            client: &'a crate::Client,
            kinds: Vec<Box<dyn KindSubscriber>>,
            error: Option<ClientError>,
        }
        impl fusion_shared::KindVisitor for Open<'_> {
            fn visit<T: fusion_shared::WireSample>(&mut self) {
                if self.error.is_some() {
                    return;
                }
                let names = self.client.names();
                let service = names.samples(T::KIND);
                let opened = fusion_shared::service::sample_service::<T>(self.client.node(), names)
                    .map_err(ClientError::from)
                    .and_then(|s| {
                        s.subscriber_builder()
                            .buffer_size(fusion_shared::service::SAMPLE_BUFFER)
                            .create()
                            .map_err(|e| ClientError::Port { service: service.clone(), detail: format!("{e:?}") })
                    });
                match opened {
                    Ok(subscriber) => self.kinds.push(Box::new(Typed::<T> { service, subscriber })),
                    Err(e) => self.error = Some(e),
                }
            }
        }
        let mut open = Open { client, kinds: Vec::new(), error: None };
        fusion_shared::SampleKind::visit_all(&mut open);
        match open.error {
            Some(e) => Err(e),
            None => Ok(Self { kinds: open.kinds, next: 0 }),
        }
    }

    /// The next waiting sample of any kind, or `None` when none waits. The
    /// kinds take turns, so a flood of one kind does not hold up the others.
    pub fn try_next(&mut self) -> Result<Option<fusion_shared::Sample>, ClientError> {
        for _ in 0..self.kinds.len() {
            let i = self.next;
            self.next = (self.next + 1) % self.kinds.len();
            if let Some(s) = self.kinds[i].receive()? {
                return Ok(Some(s));
            }
        }
        Ok(None)
    }
}
