//! fusion-daemon: the estimation core and the `fusiond` binary.
//!
//! This is the API reference. The [user guide](../../book/index.html) (concepts,
//! configuration, sensor kinds, tools, deployment, and the architecture with
//! the rule its layers keep) is the book in the repository's `docs/`; `mdbook
//! build docs` writes it to `target/book/`, beside these pages.
//!
//! - [`filter`]: Kalman filter math (predict, Joseph update, gating, RTS smoother).
//! - [`model`]: process and measurement models ([`model::linear`]).
//! - [`reorder`]: processing-order key, late-sample placement, duplicate window.
//! - [`measurement`]: one module per sensor kind: validation, order, health, fusion.
//! - [`validate`]: rejection reasons and limits of the input checks.
//! - [`frames`]: the datum of the world frame (configured or the first geodetic fix).
//! - [`sensor_table`]: a row per sensor (counters, duplicates, restarts, rate limit) and
//!   the admission of each sample.
//! - [`engine`]: sensor table + reorder + model + filter + bounded history,
//!   deterministic, IPC-free.
//! - [`snapshot`]: fills a `StateSnapshot` from the engine.
//! - [`health`]: health of the live estimate (stale streams, NIS out of bounds, losses).
//! - [`live`]: the transport-free live core: engine, health, snapshots, housekeeping, summary.
//! - [`ipc`]: `fusiond run` over iceoryx2: N subscribers
//!   merged by timestamp, the snapshot publisher.
//! - [`summary`]: the low-rate summary log line, formatted off the fusion thread.
//! - [`systemd`]: READY, WATCHDOG and STOPPING to the service manager.
//! - [`config`]: TOML configuration, validated at start-up.
//! - [`replay`]: `fusiond replay`, JSON lines through the engine.

pub mod config;
pub mod engine;
pub mod filter;
pub mod frames;
pub mod health;
pub mod ipc;
pub mod live;
pub mod measurement;
pub mod model;
pub mod reorder;
pub mod replay;
pub mod sensor_table;
pub mod setting;
pub mod snapshot;
pub mod summary;
pub mod systemd;
pub mod validate;
