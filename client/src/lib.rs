//! fusion-client: what other processes link to talk to fusiond.
//!
//! This is the API reference. The [user guide](../../book/index.html) (getting
//! started, frames and time, configuration, sensor kinds, the C and Python
//! clients, tools, deployment) is the book in the repository's `docs/`;
//! `mdbook build docs` writes it to `target/book/`, beside these pages.
//!
//! - [`Client`]: this process's connection to one namespace (one iceoryx2 node).
//! - [`SamplePublisher`] (from [`Client::publisher`], for any kind; aliases
//!   [`ImuPublisher`], [`PositionPublisher`]): publish samples of one sensor zero-copy
//!   and wake the daemon; [`SensorPublishers`] publishes a [`Sample`] of any kind.
//! - [`StateSubscriber`]: read the fused state: [`latest`](StateSubscriber::latest),
//!   [`wait_next`](StateSubscriber::wait_next) (blocking on an event) and
//!   [`spin_next`](StateSubscriber::spin_next) (busy-polling, lowest latency).
//! - `sim` (feature `sim`): a simulated sensor of every kind on a ground-truth
//!   trajectory, for tests, demos and benchmarks.
//! - [`capi`]: the same as a C library (`libfusion_client.so`/`.a`, header
//!   `client/include/fusion_client.h`).
//!
//! Reading a snapshot: [`StateSnapshot`] has typed accessors
//! ([`position`](StateSnapshot::position), [`velocity`](StateSnapshot::velocity),
//! [`attitude`](StateSnapshot::attitude), [`roll_pitch_yaw`](StateSnapshot::roll_pitch_yaw),
//! the biases, their standard deviations, [`health`](StateSnapshot::health) as a
//! [`Health`] with its [`HealthReason`]s, the [`Model`]); its documentation has the
//! state layout of each model.
//!
//! The wire contract comes from the `fusion-shared` crate and is re-exported here
//! whole, so these docs show it: [`snapshot`] (the snapshot and the codes of its
//! `u32` fields), [`sample`] (the sample kinds), [`service`] (service names, buffer
//! sizes, iceoryx2 settings), [`geodesy`] and [`time`]. The library pulls no
//! command-line or logging-backend crates; the binaries (`fusion-sim`,
//! `fusionctl`, `fusion-demo`) are behind the `cli` feature.

pub mod capi;
mod error;
mod publisher;
#[cfg(feature = "sim")]
pub mod sim;
mod subscriber;

pub use error::ClientError;
pub use fusion_shared;
// Every kind's wire type, whatever the kinds are.
pub use fusion_shared::sample::*;
pub use fusion_shared::snapshot::{Health, HealthReason, Model, Outcome};
pub use fusion_shared::{StateSnapshot, now_ns};
// The wire contract's modules, documented with the client.
pub use fusion_shared::{
    config_record, for_each_model, for_each_sample_kind, geodesy, permissions, sample, service, snapshot, time,
    transport,
};
pub use publisher::{DEFAULT_LINGER, ImuPublisher, PositionPublisher, SamplePublisher, SensorPublishers};
pub use subscriber::{SampleSubscriber, StateSubscriber};

use fusion_shared::service::ServiceNames;
use fusion_shared::transport::Ipc;
use iceoryx2::prelude::*;

/// This process's connection to fusiond's services in one namespace.
///
/// Creating one makes an iceoryx2 node (iceoryx2 ports are not `Send`: create the
/// client and its ports on the thread that uses them).
pub struct Client {
    names: ServiceNames,
    /// Always `Some` until dropped.
    node: Option<Node<Ipc>>,
    config: iceoryx2::config::Config,
}

impl Drop for Client {
    fn drop(&mut self) {
        // Ports still alive keep the node alive; then the domain is not empty and
        // nothing is removed.
        self.node.take();
        service::remove_domain_counter_if_last(&self.config);
    }
}

impl Client {
    /// Connects to `namespace` (`"fusion"` unless the daemon was given another)
    /// in the iceoryx2 domain named by `FUSION_ICEORYX_DOMAIN`, or the default one.
    /// Works whether or not fusiond runs: publishers may start first.
    pub fn connect(namespace: &str) -> Result<Self, ClientError> {
        Self::connect_in_domain(namespace, None)
    }

    /// Connects to `namespace` in iceoryx2 domain `domain` (see
    /// [`fusion_shared::service::iceoryx_config`]); `None` as in [`connect`](Self::connect).
    pub fn connect_in_domain(namespace: &str, domain: Option<&str>) -> Result<Self, ClientError> {
        let names = ServiceNames::new(namespace)?;
        let config = service::iceoryx_config(domain).map_err(ClientError::Node)?;
        let node = service::create_node(&format!("fusion-client.{namespace}"), &config).map_err(ClientError::Node)?;
        Ok(Self { names, node: Some(node), config })
    }

    /// The service names of the namespace.
    pub fn names(&self) -> &ServiceNames {
        &self.names
    }

    pub(crate) fn node(&self) -> &Node<Ipc> {
        // Only `drop` takes the node out.
        self.node.as_ref().expect("the node lives as long as the client")
    }

    /// A publisher of samples of wire type `T` (any kind) for sensor id `sensor`.
    pub fn publisher<T: WireSample>(&self, sensor: u32) -> Result<SamplePublisher<T>, ClientError> {
        SamplePublisher::new(self, sensor)
    }

    /// A publisher of IMU samples for sensor id `sensor`.
    pub fn imu_publisher(&self, sensor: u32) -> Result<ImuPublisher, ClientError> {
        SamplePublisher::new(self, sensor)
    }

    /// A publisher of position fixes for sensor id `sensor`.
    pub fn position_publisher(&self, sensor: u32) -> Result<PositionPublisher, ClientError> {
        SamplePublisher::new(self, sensor)
    }

    /// A reader of every sample sent in the namespace, of every kind (what a
    /// recorder needs). Works whether or not fusiond runs.
    pub fn sample_subscriber(&self) -> Result<SampleSubscriber, ClientError> {
        SampleSubscriber::new(self)
    }

    /// A state reader that keeps up to 64 unread snapshots. Fails with
    /// [`ClientError::DaemonNotRunning`] if no fusiond ever started in the namespace.
    pub fn state_subscriber(&self) -> Result<StateSubscriber, ClientError> {
        StateSubscriber::new(self, 64)
    }

    /// A state reader that keeps up to `buffer` unread snapshots (at most
    /// [`fusion_shared::service::STATE_BUFFER`]); older ones are overwritten.
    pub fn state_subscriber_with_buffer(&self, buffer: usize) -> Result<StateSubscriber, ClientError> {
        StateSubscriber::new(self, buffer)
    }

    /// The configuration fusiond runs with (the text of its configuration file
    /// and its version, [`config_record::ConfigRecord`]), waiting
    /// up to `timeout` for it; `None` when no fusiond publishes one in the
    /// namespace (none runs, or one of a version without `<ns>/config`).
    pub fn fusiond_config(
        &self,
        timeout: std::time::Duration,
    ) -> Result<Option<Box<fusion_shared::config_record::ConfigRecord>>, ClientError> {
        let service = match service::config_service(self.node(), &self.names, false) {
            Ok(s) => s,
            Err(service::ServiceError::DoesNotExist { .. }) => return Ok(None),
            Err(e) => return Err(ClientError::Service(e)),
        };
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| ClientError::Port { service: self.names.config.clone(), detail: format!("{e:?}") })?;
        let deadline = std::time::Instant::now() + timeout;
        loop {
            // The history sample comes when fusiond next updates its connections
            // (every 10 ms), or is there at once.
            match subscriber.receive() {
                Ok(Some(record)) => return Ok(Some(Box::new(*record))),
                Ok(None) if std::time::Instant::now() < deadline => {
                    std::thread::sleep(std::time::Duration::from_millis(5))
                }
                Ok(None) => return Ok(None),
                Err(e) => {
                    return Err(ClientError::Receive { service: self.names.config.clone(), detail: format!("{e:?}") });
                }
            }
        }
    }
}
