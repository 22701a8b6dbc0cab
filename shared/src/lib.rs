//! fusion-shared: the wire contract of fusiond and nothing else.
//!
//! - [`sample`]: [`ImuSample`] and [`PositionSample`], what sensor processes publish.
//! - [`time`]: [`now_ns`], the one clock of the system (CLOCK_MONOTONIC, ns).
//!
//! Every type here is `#[repr(C)]` with fixed-width fields only, units in the field
//! names, SI units, world frame ENU and body frame forward-left-up (REP-103).

pub mod sample;
pub mod time;

pub use sample::{ImuSample, PositionSample, Sample, SampleKind};
pub use time::now_ns;
