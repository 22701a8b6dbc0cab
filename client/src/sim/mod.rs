//! Simulated sensors for tests, demos and benchmarks.
//!
//! - [`trajectory`]: closed-form car-like ground truth.
//! - [`arrival`]: a sample with the time it is published, and the draws every
//!   sensor makes (schedule, noise);
//! - one module per sample kind ([`imu`], [`position`], [`velocity`], …, declared from
//!   `fusion_shared::for_each_sample_kind!`): that kind's sensor model (rate, noise,
//!   delay, …), an endless iterator of [`Arrival`]s;
//! - [`scenario`]: [`Scenario`], a whole drive in arrival order;
//! - [`player`]: publishing them live, paced by the clock.

use std::fmt::Debug;

use fusion_shared::SampleKind;

pub mod arrival;
#[cfg(feature = "cli")]
pub mod flags;
pub mod player;
pub mod scenario;
pub mod trajectory;

/// Declares each kind's simulator module (`sim/<module>.rs`) and re-exports it.
macro_rules! kind_modules {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        $(
            pub mod $module;
            pub use $module::*;
        )*
    };
}
fusion_shared::for_each_sample_kind!(kind_modules);

/// Implements [`AidingSim`] for a sensor's settings `$config` (with its
/// `sensor` id) whose simulator `$sim::new(trajectory, config, start_ns, seed)`
/// makes samples of kind `$kind`.
macro_rules! aiding_sim {
    ($config:ident, $sim:ident, $kind:ident) => {
        impl super::AidingSim for $config {
            fn kind(&self) -> fusion_shared::SampleKind {
                fusion_shared::SampleKind::$kind
            }

            fn sensor(&self) -> u32 {
                self.sensor
            }

            fn arrivals(
                &self,
                trajectory: &super::CarTrajectory,
                start_ns: u64,
                seed: u64,
            ) -> Box<dyn Iterator<Item = super::Arrival> + Send> {
                Box::new($sim::new(trajectory.clone(), self.clone(), start_ns, seed))
            }
        }
    };
}
use aiding_sim;

/// Every [`arrival::Sensor`] is an aiding sensor: its samples are its
/// [`arrival::SensorSim`]'s.
impl<C: arrival::Sensor + Debug + Send + Sync + 'static> AidingSim for C
where
    C::Memory: Send,
{
    fn kind(&self) -> SampleKind {
        C::KIND
    }

    fn sensor(&self) -> u32 {
        arrival::Sensor::sensor(self)
    }

    fn arrivals(
        &self,
        trajectory: &CarTrajectory,
        start_ns: u64,
        seed: u64,
    ) -> Box<dyn Iterator<Item = Arrival> + Send> {
        Box::new(arrival::SensorSim::new(trajectory.clone(), self.clone(), start_ns, seed))
    }
}

pub use arrival::Arrival;
pub use scenario::{Outage, Scenario, ScenarioConfig, without_outages};
pub use trajectory::{CarTrajectory, Stop, TruthState};

/// A simulated sensor besides the IMU (whose stream drives time): its settings,
/// from which it makes its stream of [`Arrival`]s on a trajectory. A [`Scenario`]
/// and `fusion-sim` take any number of them.
pub trait AidingSim: Debug + Send + Sync {
    /// The kind of sample it makes.
    fn kind(&self) -> SampleKind;
    /// Its sensor id.
    fn sensor(&self) -> u32;
    /// Its samples on `trajectory`, trajectory time 0 at `start_ns`, noise from
    /// `seed` (each sensor draws from its own stream), in timestamp order.
    fn arrivals(
        &self,
        trajectory: &CarTrajectory,
        start_ns: u64,
        seed: u64,
    ) -> Box<dyn Iterator<Item = Arrival> + Send>;
}
