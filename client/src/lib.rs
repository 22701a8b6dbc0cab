//! fusion-client: what other processes link to talk to fusiond.
//!
//! - [`sim`]: simulated IMU and position sensors on a ground-truth trajectory.

pub mod sim;
