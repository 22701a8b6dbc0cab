//! Service names under a namespace, their QoS, and how every side opens them.
//!
//! | service | pattern | payload | who |
//! |---|---|---|---|
//! | `<ns>/<kind>` | publish-subscribe | the kind's wire type | sensors publish, fusiond subscribes |
//! | `<ns>/wake` | event | — | sensors notify after publishing, fusiond waits on it (`--wait event`) |
//! | `<ns>/state` | publish-subscribe, history 1 | [`StateSnapshot`] | fusiond publishes, readers subscribe |
//! | `<ns>/state` | event | — | fusiond notifies after publishing, readers wait on it |
//!
//! `<kind>` is each [`SampleKind`]'s name: `<ns>/imu` ([`crate::ImuSample`]),
//! `<ns>/position` ([`crate::PositionSample`]), `<ns>/velocity` ([`crate::VelocitySample`]).
//!
//! Every side opens the services with the same settings through the functions
//! here, so whichever process comes first creates them and the others open them.

use std::time::Duration;

use iceoryx2::node::NodeState;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::{PublishSubscribeOpenError, PublishSubscribeOpenOrCreateError};
use iceoryx2::service::port_factory::{event, publish_subscribe};

use crate::transport::Ipc;
use crate::{SampleKind, StateSnapshot, WireSample};

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
/// Samples a subscriber may hold of one publisher at once. The daemon holds what
/// it took of each publisher in a turn, up to this many, so that `receive` moves
/// on to the next publisher: every publisher gets its share of each turn.
pub const MAX_BORROWED_PER_PUBLISHER: usize = 8;
/// Most subscribers per sample service (the daemon, recorders).
pub const MAX_SAMPLE_SUBSCRIBERS: usize = 4;
/// Largest buffer a state reader may ask for: 0.5 s of snapshots at 1 kHz.
pub const STATE_BUFFER: usize = 512;
/// Most state readers at once, by default (`fusiond`'s `[ipc] max_readers`).
pub const MAX_STATE_SUBSCRIBERS: usize = 8;
/// Most processes attached to one service.
pub const MAX_NODES: usize = 32;
/// Most notifiers/listeners per event service.
pub const MAX_EVENT_PORTS: usize = 32;
/// Event id on `<ns>/wake` of a reader that was refused a reader slot (every
/// slot taken): fusiond counts it (`StateSnapshot::readers_refused`). Sensors
/// notify with the default id 0.
pub const READER_REFUSED_EVENT: usize = 1;

/// A namespace that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidNamespace(pub String);

impl std::fmt::Display for InvalidNamespace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "invalid namespace {:?}: use 1 to {MAX_NAMESPACE_LEN} characters of A-Z a-z 0-9 _ - ., starting with a \
             letter, digit or _ and without \"..\" (a namespace is part of file names)",
            self.0
        )
    }
}

impl std::error::Error for InvalidNamespace {}

/// The service names of one namespace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    /// The namespace.
    pub namespace: String,
    /// `<ns>/wake`.
    pub wake: String,
    /// `<ns>/state`.
    pub state: String,
    /// `<ns>/config`: the configuration fusiond runs with.
    pub config: String,
}

impl ServiceNames {
    /// The names under `namespace`, which must be 1–64 characters of
    /// `A-Z a-z 0-9 _ - .`, start with a letter, digit or `_`, and hold no `..`:
    /// nothing path-like (`.`, `..`, `../x`, `.hidden`, `-option`).
    pub fn new(namespace: &str) -> Result<Self, InvalidNamespace> {
        namespace_arg(namespace)?;
        Ok(Self {
            namespace: namespace.to_string(),
            wake: format!("{namespace}/wake"),
            state: format!("{namespace}/state"),
            config: format!("{namespace}/config"),
        })
    }
}

/// `namespace` if it is one [`ServiceNames::new`] takes: the value parser of
/// every binary's `--namespace`, so a bad one is a usage error before anything starts.
pub fn namespace_arg(namespace: &str) -> Result<String, InvalidNamespace> {
    let first_ok = namespace.bytes().next().is_some_and(|b| b.is_ascii_alphanumeric() || b == b'_');
    let ok = first_ok
        && namespace.len() <= MAX_NAMESPACE_LEN
        && !namespace.contains("..")
        && namespace.bytes().all(|b| b.is_ascii_alphanumeric() || b"_-.".contains(&b));
    if ok { Ok(namespace.to_string()) } else { Err(InvalidNamespace(namespace.to_string())) }
}

impl ServiceNames {
    /// `<ns>/<kind>`: the service of the samples of `kind`.
    pub fn samples(&self, kind: SampleKind) -> String {
        format!("{}/{}", self.namespace, kind.name())
    }
}

/// Environment variable naming an iceoryx2 domain: processes see each other only
/// within one domain. Unset, the default domain is used. Tests set it to isolate
/// themselves completely (their files in `/dev/shm` then carry its prefix).
pub const DOMAIN_ENV: &str = "FUSION_ICEORYX_DOMAIN";

/// The iceoryx2 configuration every fusiond process uses: the library defaults,
/// passed explicitly (a node without one warns that no config file was loaded),
/// with the file prefix `iox2_<domain>_` for `domain`, or when it is `None` for
/// the domain named by [`DOMAIN_ENV`]. A domain is 1–32 characters of
/// `A-Z a-z 0-9 _ -`; an unusable one is an error.
pub fn iceoryx_config(domain: Option<&str>) -> Result<Config, String> {
    let mut config = Config::default();
    let from_env = std::env::var(DOMAIN_ENV).ok().filter(|d| !d.is_empty());
    if let Some(domain) = domain.map(str::to_string).or(from_env) {
        let prefix = domain_prefix(&domain)
            .ok_or_else(|| format!("invalid iceoryx2 domain {domain:?}: use 1 to 32 characters of A-Z a-z 0-9 _ -"))?;
        config.global.prefix = FileName::new(prefix.as_bytes()).map_err(|e| format!("domain {domain:?}: {e:?}"))?;
    }
    Ok(config)
}

/// The file prefix of a domain, if the domain name is usable.
pub fn domain_prefix(domain: &str) -> Option<String> {
    let ok =
        (1..=32).contains(&domain.len()) && domain.bytes().all(|b| b.is_ascii_alphanumeric() || b"_-".contains(&b));
    ok.then(|| format!("iox2_{domain}_"))
}

/// Creates a node named `name` for this process in `config`'s domain, with
/// iceoryx2's own signal handling off (the binaries handle SIGINT/SIGTERM).
///
/// Only this user may touch the domain's files ([`crate::permissions`]): the
/// iceoryx2 directory and the node-id counter must be this user's and closed
/// to others, or this fails at once, saying which file and whose it is.
pub fn create_node(name: &str, config: &Config) -> Result<Node<Ipc>, String> {
    let node_name: NodeName = name.try_into().map_err(|e| format!("node name {name:?}: {e:?}"))?;
    crate::permissions::check_root_directory(config)?;
    NodeBuilder::new()
        .name(&node_name)
        .config(config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Ipc>()
        .map_err(|e| match crate::permissions::take_refusal() {
            Some(reason) => format!("cannot create iceoryx2 node: {reason}"),
            None => format!("cannot create iceoryx2 node: {e:?}"),
        })
}

/// Why a service could not be opened.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ServiceError {
    /// The service exists with another payload type: a process built against
    /// another wire version of fusion-shared created it.
    #[error("service {service} carries another wire version of its payload type")]
    IncompatibleTypes {
        /// Service name.
        service: String,
    },
    /// The service exists with settings these ones cannot work with (another
    /// fusiond version, or another program using the name).
    #[error("service {service} exists with incompatible settings: {detail}")]
    IncompatibleSettings {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        detail: String,
    },
    /// The service does not exist (open-only).
    #[error("service {service} does not exist")]
    DoesNotExist {
        /// Service name.
        service: String,
    },
    /// Anything else iceoryx2 refused (permissions, resources, a bad name...).
    #[error("service {service}: {detail}")]
    Other {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        detail: String,
    },
}

/// Classifies a publish-subscribe open error by its variant.
fn classify_open(service: &str, e: &PublishSubscribeOpenError) -> ServiceError {
    let service = service.to_string();
    match e {
        PublishSubscribeOpenError::DoesNotExist => ServiceError::DoesNotExist { service },
        PublishSubscribeOpenError::IncompatibleTypes => ServiceError::IncompatibleTypes { service },
        PublishSubscribeOpenError::IncompatibleMessagingPattern
        | PublishSubscribeOpenError::IncompatibleAttributes
        | PublishSubscribeOpenError::DoesNotSupportRequestedMinBufferSize
        | PublishSubscribeOpenError::DoesNotSupportRequestedMinHistorySize
        | PublishSubscribeOpenError::DoesNotSupportRequestedMinSubscriberBorrowedSamples
        | PublishSubscribeOpenError::DoesNotSupportRequestedAmountOfPublishers
        | PublishSubscribeOpenError::DoesNotSupportRequestedAmountOfSubscribers
        | PublishSubscribeOpenError::DoesNotSupportRequestedAmountOfNodes
        | PublishSubscribeOpenError::IncompatibleOverflowBehavior
        | PublishSubscribeOpenError::ExceedsMaxNumberOfNodes => {
            ServiceError::IncompatibleSettings { service, detail: format!("{e:?}") }
        }
        other => ServiceError::Other { service, detail: format!("{other:?}") },
    }
}

/// Classifies a publish-subscribe open-or-create error.
fn classify_open_or_create(service: &str, e: &PublishSubscribeOpenOrCreateError) -> ServiceError {
    match e {
        PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(open) => classify_open(service, open),
        other => ServiceError::Other { service: service.to_string(), detail: format!("{other:?}") },
    }
}

fn service_name(name: &str) -> Result<ServiceName, ServiceError> {
    name.try_into().map_err(|e| ServiceError::Other { service: name.to_string(), detail: format!("{e:?}") })
}

/// Opens (or creates) a sample service.
fn samples<T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<Ipc>,
    name: &str,
) -> Result<publish_subscribe::PortFactory<Ipc, T, ()>, ServiceError> {
    node.service_builder(&service_name(name)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(SAMPLE_BUFFER)
        .subscriber_max_borrowed_samples(MAX_BORROWED_PER_PUBLISHER)
        .history_size(0)
        .max_publishers(MAX_SAMPLE_PUBLISHERS)
        .max_subscribers(MAX_SAMPLE_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| classify_open_or_create(name, &e))
}

/// Opens (or creates) `<ns>/<kind>`, the sample service of wire type `T`.
pub fn sample_service<T: WireSample>(
    node: &Node<Ipc>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<Ipc, T, ()>, ServiceError> {
    samples(node, &names.samples(T::KIND))
}

/// Opens `<ns>/state` (publish-subscribe, history 1); creates it too with room
/// for `create = Some(max_readers)` readers (the daemon), else it must exist (a
/// reader, which takes whatever number of readers the daemon allows).
pub fn state_service(
    node: &Node<Ipc>,
    names: &ServiceNames,
    create: Option<usize>,
) -> Result<publish_subscribe::PortFactory<Ipc, StateSnapshot, ()>, ServiceError> {
    let builder = node
        .service_builder(&service_name(&names.state)?)
        .publish_subscribe::<StateSnapshot>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(STATE_BUFFER)
        .history_size(1)
        .max_publishers(1)
        .max_nodes(MAX_NODES);
    match create {
        Some(max_readers) => {
            builder.max_subscribers(max_readers).open_or_create().map_err(|e| classify_open_or_create(&names.state, &e))
        }
        None => builder.open().map_err(|e| classify_open(&names.state, &e)),
    }
}

/// Opens `<ns>/config`, where fusiond publishes its configuration once
/// ([`crate::config_record::ConfigRecord`], history 1); creates it too with
/// `create` (fusiond), else it must exist.
pub fn config_service(
    node: &Node<Ipc>,
    names: &ServiceNames,
    create: bool,
) -> Result<publish_subscribe::PortFactory<Ipc, crate::config_record::ConfigRecord, ()>, ServiceError> {
    let builder = node
        .service_builder(&service_name(&names.config)?)
        .publish_subscribe::<crate::config_record::ConfigRecord>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(1)
        .history_size(1)
        .max_publishers(1)
        .max_subscribers(MAX_STATE_SUBSCRIBERS)
        .max_nodes(MAX_NODES);
    if create {
        builder.open_or_create().map_err(|e| classify_open_or_create(&names.config, &e))
    } else {
        builder.open().map_err(|e| classify_open(&names.config, &e))
    }
}

/// Opens (or creates) an event service (`<ns>/wake` or `<ns>/state`).
pub fn event_service(node: &Node<Ipc>, name: &str) -> Result<event::PortFactory<Ipc>, ServiceError> {
    node.service_builder(&service_name(name)?)
        .event()
        .max_notifiers(MAX_EVENT_PORTS)
        .max_listeners(MAX_EVENT_PORTS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| ServiceError::Other { service: name.to_string(), detail: format!("{e:?}") })
}

/// A listener timeout iceoryx2 0.10 keeps: `timeout` rounded up to a whole
/// microsecond. Its socket-based `Listener::timed_wait` sets `SO_RCVTIMEO` from
/// the timeout in whole microseconds, and a timeout under 1 µs becomes 0, which
/// the kernel takes as "block until an event", however long that is.
pub fn listener_timeout(timeout: Duration) -> Duration {
    Duration::from_micros(timeout.as_nanos().div_ceil(1000).clamp(1, u64::MAX as u128) as u64)
}

/// iceoryx2 keeps one 16-byte node counter per domain in `/dev/shm`. When this
/// process's node was the last iceoryx2 node of the domain (call it after dropping
/// the node), removing it leaves nothing behind. A process starting at the same moment keeps its mapping, and node ids
/// also hold the pid and the creation time, so a counter that starts again at 0
/// cannot collide.
pub fn remove_domain_counter_if_last(config: &Config) {
    let mut others = 0;
    let listed = Node::<Ipc>::list(config, |state| {
        if !matches!(state, NodeState::Dead(_)) {
            others += 1;
        }
        CallbackProgression::Continue
    });
    if listed.is_ok() && others == 0 {
        // SAFETY: no other node of the domain exists (checked just above); see the
        // function docs for a node appearing concurrently.
        // `iceoryx2::testing` is public but doc-hidden; pinned by the 0.10 lock.
        let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<Ipc>(config) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces_are_checked() {
        assert_eq!(ServiceNames::new("fusion").unwrap().state, "fusion/state");
        assert_eq!(ServiceNames::new("fusion").unwrap().samples(SampleKind::Velocity), "fusion/velocity");
        assert!(ServiceNames::new("test-1.a_b").is_ok());
        assert!(ServiceNames::new("_x.y").is_ok());
        for bad in ["", "a/b", "with space", "ü", &"x".repeat(65), ".", "..", ".hidden", "a..b", "-x", "x/../y"] {
            assert!(ServiceNames::new(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn listener_timeouts_are_whole_microseconds_of_at_least_one() {
        assert_eq!(listener_timeout(Duration::from_nanos(1)), Duration::from_micros(1));
        assert_eq!(listener_timeout(Duration::ZERO), Duration::from_micros(1));
        assert_eq!(listener_timeout(Duration::from_nanos(1_001)), Duration::from_micros(2));
        assert_eq!(listener_timeout(Duration::from_millis(5)), Duration::from_millis(5));
    }

    #[test]
    fn domains_set_the_file_prefix() {
        let c = iceoryx_config(Some("test-7")).unwrap();
        assert_eq!(c.global.prefix.as_bytes(), b"iox2_test-7_");
        assert!(iceoryx_config(Some("bad/domain")).is_err());
        assert!(iceoryx_config(Some("")).is_err());
    }
}
