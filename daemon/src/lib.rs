//! fusion-daemon: the estimation core and the `fusiond` binary.
//!
//! - [`filter`]: Kalman filter math (predict, Joseph update, gating, RTS smoother).
//! - [`model`]: process and measurement models ([`model::linear`]).
//! - [`reorder`]: processing-order key, late-sample placement, duplicate window.
//! - [`validate`]: input checks with counted rejection reasons.
//! - [`engine`]: reorder + model + filter + bounded history, deterministic, IPC-free.
//! - [`health`]: health of the live estimate (stale streams, NIS out of bounds, losses).
//! - [`config`]: TOML configuration, validated at start-up.
//! - [`replay`]: `fusiond replay`, JSON lines through the engine.

pub mod config;
pub mod engine;
pub mod filter;
pub mod health;
pub mod model;
pub mod reorder;
pub mod replay;
pub mod validate;
