//! fusion-daemon: the estimation core and the `fusiond` binary.
//!
//! - [`filter`]: Kalman filter math (predict, Joseph update, gating, RTS smoother).
//! - [`model`]: process and measurement models ([`model::linear`]).
//! - [`reorder`]: processing-order key, late-sample placement, duplicate window.
//! - [`validate`]: input checks with counted rejection reasons.
//! - [`engine`]: reorder + model + filter + bounded history, deterministic, IPC-free.
//! - [`snapshot`]: fills a `StateSnapshot` from the engine.
//! - [`health`]: health of the live estimate (stale streams, NIS out of bounds, losses).
//! - [`ipc`]: `fusiond run`, the live daemon over iceoryx2 (the only file that touches it).
//! - [`summary`]: the low-rate summary log line, formatted off the fusion thread.
//! - [`config`]: TOML configuration, validated at start-up.
//! - [`replay`]: `fusiond replay`, JSON lines through the engine.

pub mod config;
pub mod engine;
pub mod filter;
pub mod health;
pub mod ipc;
pub mod model;
pub mod reorder;
pub mod replay;
pub mod snapshot;
pub mod summary;
pub mod validate;
