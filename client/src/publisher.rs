//! Sample publishers: a sensor process's side of fusiond.

use fusion_shared::transport::Ipc;
use fusion_shared::{ImuSample, KindVisitor, PositionSample, Sample, SampleHeader, SampleKind, WireSample, now_ns};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;

use crate::ClientError;

/// Publishes samples of one kind (wire type `T`) for one sensor on `<ns>/<kind>`,
/// zero-copy, and wakes the daemon. Every kind has one, from
/// [`Client::publisher`](crate::Client::publisher); the IMU and position ones have
/// aliases with a `publish` taking the payload's fields.
///
/// ```
/// # fn main() -> Result<(), fusion_client::ClientError> {
/// use fusion_client::Client;
/// let client = Client::connect("doc-imu-publisher")?;
/// let mut imu = client.imu_publisher(0)?;
/// // Time of validity now, world acceleration 0.1 m/s² east, no rotation.
/// let reached = imu.publish(fusion_shared::now_ns(), [0.1, 0.0, 0.0], [0.0; 3])?;
/// assert_eq!(reached, 0); // no fusiond in this namespace
/// # Ok(())
/// # }
/// ```
///
/// Dropping a publisher that reached a reader (fusiond) within the last
/// [`DEFAULT_LINGER`] waits for the rest of it ([`SamplePublisher::set_linger`]):
/// iceoryx2 hands a reader the samples of a publisher only once the reader
/// has connected to it, which it does on its next look (fusiond: after the
/// wake-up, at the latest at its 10 ms housekeeping), and a publisher gone
/// before that takes its samples with it. A program that publishes once and
/// exits at once lost about one sample in seven this way.
pub struct SamplePublisher<T: WireSample> {
    service: String,
    publisher: Publisher<Ipc, T, ()>,
    wake: Option<Notifier<Ipc>>,
    sensor: u32,
    next_seq: u64,
    /// When a sample last reached a reader (CLOCK_MONOTONIC ns).
    last_delivered_ns: Option<u64>,
    linger: std::time::Duration,
}

/// How long a dropped publisher keeps its samples available after the last
/// one that reached a reader, for that reader to connect and take them: far
/// beyond fusiond's wake-up (tens of µs) and its housekeeping period (10 ms).
pub const DEFAULT_LINGER: std::time::Duration = std::time::Duration::from_millis(100);

impl<T: WireSample> Drop for SamplePublisher<T> {
    fn drop(&mut self) {
        let Some(last) = self.last_delivered_ns else { return };
        let until = last.saturating_add(self.linger.as_nanos().min(u128::from(u64::MAX)) as u64);
        let now = now_ns();
        if until > now {
            if let Some(wake) = &self.wake {
                let _ = wake.notify();
            }
            std::thread::sleep(std::time::Duration::from_nanos(until - now));
        }
    }
}

/// Publishes IMU samples on `<ns>/imu`.
pub type ImuPublisher = SamplePublisher<ImuSample>;
/// Publishes position fixes on `<ns>/position`.
///
/// ```no_run
/// # fn main() -> Result<(), fusion_client::ClientError> {
/// use fusion_client::Client;
/// let client = Client::connect("fusion")?;
/// let mut gnss = client.position_publisher(1)?;
/// let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64]; // m², row-major
/// gnss.publish(fusion_shared::now_ns(), [12.0, -3.5, 0.8], cov)?;
/// # Ok(())
/// # }
/// ```
pub type PositionPublisher = SamplePublisher<PositionSample>;
impl<T: WireSample> SamplePublisher<T> {
    pub(crate) fn new(client: &crate::Client, sensor: u32) -> Result<Self, ClientError> {
        let names = client.names();
        let service = fusion_shared::service::sample_service::<T>(client.node(), names)?;
        let service_name = names.samples(T::KIND);
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(|e| ClientError::Port { service: service_name.clone(), detail: format!("{e:?}") })?;
        let wake = fusion_shared::service::event_service(client.node(), &names.wake)?;
        let wake = wake
            .notifier_builder()
            .create()
            .map_err(|e| ClientError::Port { service: names.wake.clone(), detail: format!("{e:?}") })?;
        Ok(Self {
            service: service_name,
            publisher,
            wake: Some(wake),
            sensor,
            next_seq: 0,
            last_delivered_ns: None,
            linger: DEFAULT_LINGER,
        })
    }

    /// How long dropping this publisher waits after its last sample that
    /// reached a reader (default [`DEFAULT_LINGER`]; `Duration::ZERO`: not at
    /// all, when samples may be lost at the end).
    pub fn set_linger(&mut self, linger: std::time::Duration) {
        self.linger = linger;
    }

    /// Whether to notify `<ns>/wake` after each sample (default on). A daemon
    /// in `--wait event` mode needs it; one in `spin` mode does not, and
    /// leaving it off saves ~1 µs per sample.
    pub fn set_wake(&mut self, on: bool) {
        if !on {
            self.wake = None;
        }
    }

    /// The sensor id this publisher stamps.
    pub fn sensor(&self) -> u32 {
        self.sensor
    }

    /// Publishes `sample` exactly as given (sensor id and sequence number
    /// included), stamping only `sent_ns` with the current time. Returns the
    /// number of subscribers it reached (0: fusiond is not running).
    pub fn publish_sample(&mut self, mut sample: T) -> Result<usize, ClientError> {
        sample.header_mut().sent_ns = now_ns();
        let err = |detail: String| ClientError::Send { service: self.service.clone(), detail };
        let loaned = self.publisher.loan_uninit().map_err(|e| err(format!("{e:?}")))?;
        let delivered = loaned.write_payload(sample).send().map_err(|e| err(format!("{e:?}")))?;
        if delivered > 0 {
            self.last_delivered_ns = Some(now_ns());
        }
        if let Some(wake) = &self.wake {
            // A failed wake-up only delays a daemon in event mode until its next
            // housekeeping tick; the sample itself was delivered.
            let _ = wake.notify();
        }
        Ok(delivered)
    }

    /// Publishes `sample` as this sensor's next sample: stamps its header with this
    /// publisher's sensor id and next sequence number (and `sent_ns`); the time
    /// of validity and the payload are the caller's. Returns the subscribers reached.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), fusion_client::ClientError> {
    /// use fusion_client::{Client, VelocitySample};
    /// let client = Client::connect("fusion")?;
    /// let mut doppler = client.publisher::<VelocitySample>(2)?;
    /// let cov = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04]; // m²/s², row-major
    /// let t_ns = fusion_shared::now_ns();
    /// doppler.publish_next(VelocitySample::new(t_ns, 0, 0, [13.9, -3.6, 0.0], cov))?;
    /// # Ok(())
    /// # }
    /// ```
    pub fn publish_next(&mut self, mut sample: T) -> Result<usize, ClientError> {
        let t_ns = sample.header().t_ns;
        *sample.header_mut() = self.next_header(t_ns);
        self.publish_sample(sample)
    }

    /// The header of this sensor's next sample at `t_ns` (taking its sequence number).
    fn next_header(&mut self, t_ns: u64) -> SampleHeader {
        let header = SampleHeader::new(T::KIND, t_ns, self.sensor, self.next_seq);
        self.next_seq += 1;
        header
    }
}

impl ImuPublisher {
    /// Publishes a sample of this sensor with the next sequence number: time of
    /// validity `t_ns` (CLOCK_MONOTONIC, [`now_ns`]), acceleration or specific
    /// force (m/s²) and angular rate (rad/s). Returns the subscribers reached.
    pub fn publish(&mut self, t_ns: u64, accel_mps2: [f64; 3], gyro_radps: [f64; 3]) -> Result<usize, ClientError> {
        let header = self.next_header(t_ns);
        self.publish_sample(ImuSample { header, accel_mps2, gyro_radps })
    }
}

impl PositionPublisher {
    /// Publishes a fix of this sensor with the next sequence number: time of
    /// validity `t_ns`, position (m, ENU) and its covariance (m², row-major 3×3,
    /// symmetric positive definite). Returns the subscribers reached.
    pub fn publish(&mut self, t_ns: u64, pos_m: [f64; 3], cov_m2: [f64; 9]) -> Result<usize, ClientError> {
        let header = self.next_header(t_ns);
        self.publish_sample(PositionSample { header, pos_m, cov_m2 })
    }
}

/// A [`SamplePublisher`] of any kind, behind [`SensorPublishers`].
trait AnyPublisher {
    /// Publishes `sample` as given; `None` if it is not of this publisher's kind.
    fn publish_any(&mut self, sample: &Sample) -> Option<Result<usize, ClientError>>;
}

impl<T: WireSample> AnyPublisher for SamplePublisher<T> {
    fn publish_any(&mut self, sample: &Sample) -> Option<Result<usize, ClientError>> {
        T::from_sample(sample).map(|s| self.publish_sample(s))
    }
}

/// At most one publisher per sample kind: publishes a [`Sample`] of any kind on
/// its kind's publisher (a replay file, a simulated drive).
#[derive(Default)]
pub struct SensorPublishers {
    by_kind: [Option<Box<dyn AnyPublisher>>; SampleKind::COUNT],
}

impl SensorPublishers {
    /// A publisher for every kind, for samples that carry their own sensor ids
    /// and sequence numbers (a replay file).
    pub fn all(client: &crate::Client) -> Result<Self, ClientError> {
        let mut publishers = Self::default();
        for &kind in SampleKind::ALL {
            publishers.open(client, kind, 0)?;
        }
        Ok(publishers)
    }

    /// Opens (or replaces) the publisher of `kind` for sensor id `sensor`.
    pub fn open(&mut self, client: &crate::Client, kind: SampleKind, sensor: u32) -> Result<(), ClientError> {
        struct Open<'a> {
            client: &'a crate::Client,
            kind: SampleKind,
            sensor: u32,
            opened: Option<Result<Box<dyn AnyPublisher>, ClientError>>,
        }
        impl KindVisitor for Open<'_> {
            fn visit<T: WireSample>(&mut self) {
                if T::KIND == self.kind {
                    let publisher = SamplePublisher::<T>::new(self.client, self.sensor);
                    self.opened = Some(publisher.map(|p| Box::new(p) as Box<dyn AnyPublisher>));
                }
            }
        }
        let mut open = Open { client, kind, sensor, opened: None };
        SampleKind::visit_all(&mut open);
        // `visit_all` visits every kind, this one included.
        let publisher = open.opened.expect("every kind is visited")?;
        self.by_kind[kind.index()] = Some(publisher);
        Ok(())
    }

    /// Publishes `sample` as given (see [`SamplePublisher::publish_sample`]) on
    /// the publisher of its kind. `Ok(None)`: there is none for that kind.
    pub fn publish(&mut self, sample: Sample) -> Result<Option<usize>, ClientError> {
        let publisher = self.by_kind[sample.kind().index()].as_mut();
        publisher.and_then(|p| p.publish_any(&sample)).transpose()
    }
}
