//! fusion-core: fusiond's estimator, without IO. What a process needs to run
//! the filter on samples it has: the daemon (`fusion-daemon`: iceoryx2, replay,
//! systemd) is built on it.
//!
//! The [user guide](../../book/index.html) (concepts, configuration, sensor
//! kinds, and the architecture with the rule its layers keep) is the book in
//! the repository's `docs/`.
//!
//! - [`setting`]: the error of a bad setting and its checks.
//! - [`filter`]: Kalman filter math (predict, Joseph and UDU updates, gating, RTS smoother).
//! - [`frames`]: the datum of the world frame (configured or the first geodetic
//!   fix), the sensors' mounts and the IMU set, each sensor's settings.
//! - [`model`]: the process models ([`model::linear`], [`model::ins`]).
//! - [`validate`]: rejection reasons and limits of the input checks.
//! - [`measurement`]: one module per sensor kind: validation, order, settings, health, fusion.
//! - [`reorder`]: processing-order key, late-sample placement, duplicate window.
//! - [`sensor_table`]: a row per sensor (counters, duplicates, restarts, rate limit) and
//!   the admission of each sample.
//! - [`engine`]: sensor table + reorder + model + filter + bounded history,
//!   deterministic.
//! - [`health`]: health of the live estimate (stale streams, NIS out of bounds, losses).
//! - [`snapshot`]: fills a `StateSnapshot` from the engine.
//! - [`config`]: TOML configuration, validated at start-up, and the model it builds.

pub mod config;
pub mod engine;
pub mod filter;
pub mod frames;
pub mod health;
pub mod measurement;
pub mod model;
pub mod reorder;
pub mod sensor_table;
pub mod setting;
pub mod snapshot;
pub mod validate;
