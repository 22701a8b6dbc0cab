//! Errors of the client crate.

use fusion_shared::service::{InvalidNamespace, ServiceError};

/// Why a client operation failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The namespace cannot be part of a service name.
    #[error(transparent)]
    InvalidNamespace(#[from] InvalidNamespace),
    /// No fusiond has published state in this namespace (start `fusiond run`).
    #[error("fusiond is not running in namespace {namespace:?}")]
    DaemonNotRunning {
        /// The namespace.
        namespace: String,
    },
    /// The service was created by a process with another wire version.
    #[error("incompatible wire version on {service}: rebuild against the same fusion-shared as fusiond")]
    IncompatibleVersion {
        /// The service.
        service: String,
    },
    /// Any other refusal to open a service.
    #[error(transparent)]
    Service(ServiceError),
    /// iceoryx2 could not create this process's node.
    #[error("iceoryx2 node: {0}")]
    Node(String),
    /// Every reader slot of the state service is taken.
    #[error(
        "all {max} reader slots of {service} are taken: stop a reader, or raise `[ipc] max_readers` in fusiond's config"
    )]
    ReadersFull {
        /// The service.
        service: String,
        /// The readers fusiond allows.
        max: usize,
    },
    /// iceoryx2 refused a port (e.g. more publishers than the service allows).
    #[error("iceoryx2 port on {service}: {detail}")]
    Port {
        /// The service.
        service: String,
        /// iceoryx2's reason.
        detail: String,
    },
    /// Sending failed.
    #[error("send on {service}: {detail}")]
    Send {
        /// The service.
        service: String,
        /// iceoryx2's reason.
        detail: String,
    },
    /// Receiving failed.
    #[error("receive on {service}: {detail}")]
    Receive {
        /// The service.
        service: String,
        /// iceoryx2's reason.
        detail: String,
    },
}

impl From<ServiceError> for ClientError {
    fn from(e: ServiceError) -> Self {
        match e {
            ServiceError::IncompatibleTypes { service } => ClientError::IncompatibleVersion { service },
            other => ClientError::Service(other),
        }
    }
}
