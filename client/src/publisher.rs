//! Sample publishers: a sensor process's side of fusiond.

use fusion_shared::transport::Ipc;
use fusion_shared::{ImuSample, PositionSample, now_ns};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;

use crate::ClientError;

/// Publishes one kind of sample zero-copy and wakes the daemon.
struct SamplePublisher<T: std::fmt::Debug + ZeroCopySend + 'static> {
    service: String,
    publisher: Publisher<Ipc, T, ()>,
    wake: Option<Notifier<Ipc>>,
}

impl<T: std::fmt::Debug + ZeroCopySend + Copy + 'static> SamplePublisher<T> {
    fn send(&self, sample: T) -> Result<usize, ClientError> {
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
}

macro_rules! publisher_type {
    ($(#[$doc:meta])* $name:ident, $sample:ty, $service:ident, $field:ident) => {
        $(#[$doc])*
        pub struct $name {
            inner: SamplePublisher<$sample>,
            sensor: u32,
            next_seq: u64,
        }

        impl $name {
            pub(crate) fn new(client: &crate::Client, sensor: u32) -> Result<Self, ClientError> {
                let names = client.names();
                let service = fusion_shared::service::$service(client.node(), names)?;
                let service_name = names.$field.clone();
                let publisher = service.publisher_builder().create().map_err(|e| ClientError::Port {
                    service: service_name.clone(),
                    detail: format!("{e:?}"),
                })?;
                let wake = fusion_shared::service::event_service(client.node(), &names.wake)?;
                let wake = wake.notifier_builder().create().map_err(|e| ClientError::Port {
                    service: names.wake.clone(),
                    detail: format!("{e:?}"),
                })?;
                Ok(Self {
                    inner: SamplePublisher { service: service_name, publisher, wake: Some(wake) },
                    sensor,
                    next_seq: 0,
                })
            }

            /// Whether to notify `<ns>/wake` after each sample (default on). A daemon
            /// in `--wait event` mode needs it; one in `spin` mode does not, and
            /// leaving it off saves ~1 µs per sample.
            pub fn set_wake(&mut self, on: bool) {
                if !on {
                    self.inner.wake = None;
                }
            }

            /// The sensor id this publisher stamps.
            pub fn sensor(&self) -> u32 {
                self.sensor
            }

            /// Publishes `sample` exactly as given (sensor id and sequence number
            /// included), stamping only `sent_ns` with the current time. Returns the
            /// number of subscribers it reached (0: fusiond is not running).
            pub fn publish_sample(&mut self, mut sample: $sample) -> Result<usize, ClientError> {
                sample.sent_ns = now_ns();
                self.inner.send(sample)
            }
        }
    };
}

publisher_type!(
    /// Publishes IMU samples on `<ns>/imu`.
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
    ImuPublisher, ImuSample, imu_service, imu
);

publisher_type!(
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
    PositionPublisher, PositionSample, position_service, position
);

impl ImuPublisher {
    /// Publishes a sample of this sensor with the next sequence number: time of
    /// validity `t_ns` (CLOCK_MONOTONIC, [`now_ns`]), acceleration or specific
    /// force (m/s²) and angular rate (rad/s). Returns the subscribers reached.
    pub fn publish(&mut self, t_ns: u64, accel_mps2: [f64; 3], gyro_radps: [f64; 3]) -> Result<usize, ClientError> {
        let sample = ImuSample {
            t_ns,
            sent_ns: 0,
            seq: self.next_seq,
            sensor: self.sensor,
            _reserved: 0,
            accel_mps2,
            gyro_radps,
        };
        self.next_seq += 1;
        self.publish_sample(sample)
    }
}

impl PositionPublisher {
    /// Publishes a fix of this sensor with the next sequence number: time of
    /// validity `t_ns`, position (m, ENU) and its covariance (m², row-major 3×3,
    /// symmetric positive definite). Returns the subscribers reached.
    pub fn publish(&mut self, t_ns: u64, pos_m: [f64; 3], cov_m2: [f64; 9]) -> Result<usize, ClientError> {
        let sample =
            PositionSample { t_ns, sent_ns: 0, seq: self.next_seq, sensor: self.sensor, _reserved: 0, pos_m, cov_m2 };
        self.next_seq += 1;
        self.publish_sample(sample)
    }
}
