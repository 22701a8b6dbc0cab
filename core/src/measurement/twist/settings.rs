//! `[sensor.twist]`: which components of a twist sensor's samples are fused.

use serde::Deserialize;

use crate::measurement::components::{ComponentNames, Components};

/// A twist's components: linear then angular velocity in the sensor's axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TwistNames;
impl ComponentNames for TwistNames {
    const NAMES: [&'static str; 6] = ["vx", "vy", "vz", "vroll", "vpitch", "vyaw"];
}

/// `[sensor.twist]`: which components of a twist are fused (optional: all six
/// without the table).
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwistConfig {
    /// The components fused (`["vx", "vy", "vyaw"]`; default all six).
    #[serde(default)]
    pub fuse: Components<TwistNames>,
}
