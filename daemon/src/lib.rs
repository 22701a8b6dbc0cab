//! fusion-daemon: the `fusiond` binary and what it adds to the estimator
//! ([`fusion_core`], re-exported here under its module names): the transport,
//! replay, the summary log and systemd.
//!
//! This is the API reference. The [user guide](../../book/index.html) (concepts,
//! configuration, sensor kinds, tools, deployment, and the architecture with
//! the rule its layers keep) is the book in the repository's `docs/`; `mdbook
//! build docs` writes it to `target/book/`, beside these pages.
//!
//! - [`live`]: the transport-free live core: engine, health, snapshots, housekeeping, summary.
//! - [`ipc`]: `fusiond run` over iceoryx2: N subscribers
//!   merged by timestamp, the snapshot publisher.
//! - [`summary`]: the low-rate summary log line, formatted off the fusion thread.
//! - [`systemd`]: READY, WATCHDOG and STOPPING to the service manager.
//! - [`replay`]: `fusiond replay`: JSON lines, recordings and ROS bags through the engine.
//!
//! The estimator's modules, from [`fusion_core`]: [`filter`], [`model`],
//! [`measurement`], [`engine`], [`frames`], [`health`], [`snapshot`],
//! [`config`] and their helpers.

pub use fusion_core::{
    config, engine, filter, frames, health, measurement, model, reorder, sensor_table, setting, snapshot, validate,
};

pub mod ipc;
pub mod live;
pub mod replay;
pub mod summary;
pub mod systemd;
