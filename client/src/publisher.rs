//! Sample publishers: a sensor process's side of fusiond.

use fusion_shared::transport::Ipc;
use fusion_shared::{ImuSample, PositionSample, Sample, SampleHeader, VelocitySample, WireSample, now_ns};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;

use crate::ClientError;

/// Publishes samples of one kind (wire type `T`) for one sensor on `<ns>/<kind>`,
/// zero-copy, and wakes the daemon.
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
pub struct SamplePublisher<T: WireSample> {
    service: String,
    publisher: Publisher<Ipc, T, ()>,
    wake: Option<Notifier<Ipc>>,
    sensor: u32,
    next_seq: u64,
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
/// Publishes velocity measurements (GNSS Doppler) on `<ns>/velocity`.
///
/// ```no_run
/// # fn main() -> Result<(), fusion_client::ClientError> {
/// use fusion_client::Client;
/// let client = Client::connect("fusion")?;
/// let mut doppler = client.velocity_publisher(2)?;
/// let cov = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04]; // m²/s², row-major
/// doppler.publish(fusion_shared::now_ns(), [13.9, -3.6, 0.0], cov)?;
/// # Ok(())
/// # }
/// ```
pub type VelocityPublisher = SamplePublisher<VelocitySample>;

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
        Ok(Self { service: service_name, publisher, wake: Some(wake), sensor, next_seq: 0 })
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
        if let Some(wake) = &self.wake {
            // A failed wake-up only delays a daemon in event mode until its next
            // housekeeping tick; the sample itself was delivered.
            let _ = wake.notify();
        }
        Ok(delivered)
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

impl VelocityPublisher {
    /// Publishes a velocity of this sensor with the next sequence number: time of
    /// validity `t_ns`, velocity (m/s, ENU) and its covariance (m²/s², row-major
    /// 3×3, symmetric positive definite). Returns the subscribers reached.
    pub fn publish(&mut self, t_ns: u64, vel_mps: [f64; 3], cov_m2ps2: [f64; 9]) -> Result<usize, ClientError> {
        let header = self.next_header(t_ns);
        self.publish_sample(VelocitySample { header, vel_mps, cov_m2ps2 })
    }
}

/// One publisher per sample kind (each optional): publishes a [`Sample`] of any
/// kind on its kind's publisher.
#[derive(Default)]
pub struct SensorPublishers {
    /// IMU samples.
    pub imu: Option<ImuPublisher>,
    /// Position fixes.
    pub position: Option<PositionPublisher>,
    /// Velocities.
    pub velocity: Option<VelocityPublisher>,
}

impl SensorPublishers {
    /// Publishers of every kind, for the sensor ids the simulators use (IMU 0,
    /// position 1, velocity 2; the samples keep their own ids).
    pub fn all(client: &crate::Client) -> Result<Self, ClientError> {
        Ok(Self {
            imu: Some(client.imu_publisher(0)?),
            position: Some(client.position_publisher(1)?),
            velocity: Some(client.velocity_publisher(2)?),
        })
    }

    /// Publishes `sample` as given (see [`SamplePublisher::publish_sample`]) on
    /// the publisher of its kind. `Ok(None)`: there is none for that kind.
    pub fn publish(&mut self, sample: Sample) -> Result<Option<usize>, ClientError> {
        match sample {
            Sample::Imu(s) => self.imu.as_mut().map(|p| p.publish_sample(s)),
            Sample::Position(s) => self.position.as_mut().map(|p| p.publish_sample(s)),
            Sample::Velocity(s) => self.velocity.as_mut().map(|p| p.publish_sample(s)),
        }
        .transpose()
    }
}
