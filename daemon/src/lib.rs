//! fusion-daemon: the estimation core and the `fusiond` binary.
//!
//! - [`filter`]: Kalman filter math (predict, Joseph update, gating, RTS smoother).

pub mod filter;
