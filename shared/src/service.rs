//! Service names under a namespace, their QoS, and how every side opens them.
//!
//! | service | pattern | payload | who |
//! |---|---|---|---|
//! | `<ns>/imu` | publish-subscribe | [`ImuSample`] | sensors publish, fusiond subscribes |
//! | `<ns>/position` | publish-subscribe | [`PositionSample`] | sensors publish, fusiond subscribes |
//! | `<ns>/wake` | event | — | sensors notify after publishing, fusiond waits on it (`--wait event`) |
//! | `<ns>/state` | publish-subscribe, history 1 | [`StateSnapshot`] | fusiond publishes, readers subscribe |
//! | `<ns>/state` | event | — | fusiond notifies after publishing, readers wait on it |
//!
//! Every side opens the services with the same settings through the functions
//! here, so whichever process comes first creates them and the others open them.

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use crate::{ImuSample, PositionSample, StateSnapshot};

/// The namespace when none is given.
pub const DEFAULT_NAMESPACE: &str = "fusion";

/// Longest namespace accepted.
pub const MAX_NAMESPACE_LEN: usize = 64;

/// Buffer of the daemon's sample subscribers: 4 s of a 1 kHz IMU. Publishers
/// overwrite the oldest sample when it is full (safe overflow); the daemon counts
/// such losses from sequence-number gaps.
pub const SAMPLE_BUFFER: usize = 4096;
/// Most publishers per sample service (sensors, simulators, replays).
pub const MAX_SAMPLE_PUBLISHERS: usize = 16;
/// Most subscribers per sample service (the daemon, recorders).
pub const MAX_SAMPLE_SUBSCRIBERS: usize = 4;
/// Largest buffer a state reader may ask for: 0.5 s of snapshots at 1 kHz.
pub const STATE_BUFFER: usize = 512;
/// Most state readers at once.
pub const MAX_STATE_SUBSCRIBERS: usize = 8;
/// Most processes attached to one service.
pub const MAX_NODES: usize = 32;
/// Most notifiers/listeners per event service.
pub const MAX_EVENT_PORTS: usize = 32;

/// A namespace that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidNamespace(pub String);

impl std::fmt::Display for InvalidNamespace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid namespace {:?}: use 1 to {MAX_NAMESPACE_LEN} characters of A-Z a-z 0-9 _ - .", self.0)
    }
}

impl std::error::Error for InvalidNamespace {}

/// The service names of one namespace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    /// The namespace.
    pub namespace: String,
    /// `<ns>/imu`.
    pub imu: String,
    /// `<ns>/position`.
    pub position: String,
    /// `<ns>/wake`.
    pub wake: String,
    /// `<ns>/state`.
    pub state: String,
}

impl ServiceNames {
    /// The names under `namespace`, which must be 1–64 characters of
    /// `A-Z a-z 0-9 _ - .`.
    pub fn new(namespace: &str) -> Result<Self, InvalidNamespace> {
        let ok = !namespace.is_empty()
            && namespace.len() <= MAX_NAMESPACE_LEN
            && namespace.bytes().all(|b| b.is_ascii_alphanumeric() || b"_-.".contains(&b));
        if !ok {
            return Err(InvalidNamespace(namespace.to_string()));
        }
        Ok(Self {
            namespace: namespace.to_string(),
            imu: format!("{namespace}/imu"),
            position: format!("{namespace}/position"),
            wake: format!("{namespace}/wake"),
            state: format!("{namespace}/state"),
        })
    }
}

/// The iceoryx2 configuration every fusiond process uses: the library defaults,
/// passed explicitly (a node without one warns that no config file was loaded).
pub fn iceoryx_config() -> Config {
    Config::default()
}

/// Creates a node named `name` for this process, with iceoryx2's own signal
/// handling off (the binaries handle SIGINT/SIGTERM themselves).
pub fn create_node(name: &str) -> Result<Node<ipc::Service>, String> {
    let node_name: NodeName = name.try_into().map_err(|e| format!("node name {name:?}: {e:?}"))?;
    NodeBuilder::new()
        .name(&node_name)
        .config(&iceoryx_config())
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| format!("cannot create iceoryx2 node: {e:?}"))
}

fn service_name(name: &str) -> Result<ServiceName, String> {
    name.try_into().map_err(|e| format!("service name {name:?}: {e:?}"))
}

/// Opens (or creates) a sample service.
fn samples<T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<ipc::Service>,
    name: &str,
) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>, String> {
    node.service_builder(&service_name(name)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(SAMPLE_BUFFER)
        .history_size(0)
        .max_publishers(MAX_SAMPLE_PUBLISHERS)
        .max_subscribers(MAX_SAMPLE_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| format!("cannot open service {name}: {e:?}"))
}

/// Opens (or creates) `<ns>/imu`.
pub fn imu_service(
    node: &Node<ipc::Service>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<ipc::Service, ImuSample, ()>, String> {
    samples(node, &names.imu)
}

/// Opens (or creates) `<ns>/position`.
pub fn position_service(
    node: &Node<ipc::Service>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<ipc::Service, PositionSample, ()>, String> {
    samples(node, &names.position)
}

/// Opens (or creates) `<ns>/state` (publish-subscribe, history 1).
pub fn state_service(
    node: &Node<ipc::Service>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<ipc::Service, StateSnapshot, ()>, String> {
    node.service_builder(&service_name(&names.state)?)
        .publish_subscribe::<StateSnapshot>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(STATE_BUFFER)
        .history_size(1)
        .max_publishers(1)
        .max_subscribers(MAX_STATE_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| format!("cannot open service {}: {e:?}", names.state))
}

/// Opens (or creates) an event service (`<ns>/wake` or `<ns>/state`).
pub fn event_service(node: &Node<ipc::Service>, name: &str) -> Result<event::PortFactory<ipc::Service>, String> {
    node.service_builder(&service_name(name)?)
        .event()
        .max_notifiers(MAX_EVENT_PORTS)
        .max_listeners(MAX_EVENT_PORTS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| format!("cannot open event service {name}: {e:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces_are_checked() {
        assert_eq!(ServiceNames::new("fusion").unwrap().state, "fusion/state");
        assert!(ServiceNames::new("test-1.a_b").is_ok());
        for bad in ["", "a/b", "with space", "ü", &"x".repeat(65)] {
            assert!(ServiceNames::new(bad).is_err(), "{bad:?}");
        }
    }
}
