//! `[sensor.attitude]`: which of an AHRS's angles are fused.

use serde::Deserialize;

/// `[sensor.attitude]`: which of an AHRS's angles are fused (optional: all
/// three without the table).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeConfig {
    /// Fuse the yaw too (default true); false: roll and pitch only, for an AHRS
    /// whose magnetic yaw is not to be trusted (indoors, near motors and steel).
    #[serde(default = "AttitudeConfig::default_yaw")]
    pub yaw: bool,
}

impl AttitudeConfig {
    fn default_yaw() -> bool {
        true
    }
}

impl Default for AttitudeConfig {
    fn default() -> Self {
        Self { yaw: true }
    }
}
