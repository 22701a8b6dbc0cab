//! Simulated sensors for tests, demos and benchmarks.
//!
//! - [`trajectory`]: closed-form car-like ground truth.
//! - [`sensors`]: IMU, position and velocity sensor models (rates, noise, delay, jitter,
//!   dropouts, outliers) and [`Scenario`], a whole drive in arrival order.
//! - [`player`]: publishing them live, paced by the clock.

pub mod player;
pub mod sensors;
pub mod trajectory;

pub use sensors::{
    Arrival, ImuConfig, ImuOutput, ImuSim, PositionConfig, PositionSim, Scenario, ScenarioConfig, VelocityConfig,
    VelocitySim,
};
pub use trajectory::{CarTrajectory, TruthState};
