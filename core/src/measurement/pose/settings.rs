//! `[sensor.pose]`: how a pose sensor's map frame relates to the world frame,
//! and which components of its poses are fused.

use serde::Deserialize;

use crate::measurement::components::{ComponentNames, Components};
use crate::setting::{ConfigError, invalid};

/// A pose's components: position in the map, then the attitude as small
/// rotations about the sensor's x, y and z axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PoseNames;
impl ComponentNames for PoseNames {
    const NAMES: [&'static str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];
}

/// `[sensor.pose]`: how a pose sensor's map frame relates to the world frame
/// (optional: without the table the frame is estimated with the defaults).
///
/// A localiser (lidar SLAM, visual-inertial odometry, a map matcher) gives
/// poses in a map frame of its own whose `z` axis is up (gravity-aligned) and
/// whose yaw and origin are arbitrary: `p_w = R_z(ψ) p_m + t`. Either both
/// `frame_yaw_deg` and `frame_origin_m` are given (a map registered to the
/// world: the frame is fixed), or neither: the frame `(ψ, t)` is then four
/// states of the model, set from the first pose and re-set whenever the
/// localiser re-initialises.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseConfig {
    /// The map frame's yaw in the world frame, degrees (counter-clockwise from
    /// east to the map's `x` axis); with `frame_origin_m`.
    #[serde(default)]
    pub frame_yaw_deg: Option<f64>,
    /// The map frame's origin in the world frame (east, north, up), m; with
    /// `frame_yaw_deg`.
    #[serde(default)]
    pub frame_origin_m: Option<[f64; 3]>,
    /// Random-walk density of the estimated frame's yaw, degrees/√s (default
    /// 0.01: 0.6° in an hour of localiser drift).
    #[serde(default = "PoseConfig::default_yaw_random_walk")]
    pub frame_yaw_random_walk_deg: f64,
    /// Random-walk density of the estimated frame's origin, m/√s (default
    /// 0.01: 0.6 m in an hour).
    #[serde(default = "PoseConfig::default_origin_random_walk")]
    pub frame_origin_random_walk_m: f64,
    /// Consecutive gated poses after which the localiser is taken to have
    /// re-initialised without saying so, and the frame is set again (default
    /// 5; 0: never).
    #[serde(default = "PoseConfig::default_realign_after_gated")]
    pub realign_after_gated: u32,
    /// Fuse only the change between consecutive poses (as a body twist), for
    /// localisers that drift like odometry (default false).
    #[serde(default)]
    pub relative: bool,
    /// The components fused (`["x", "y", "yaw"]`; default all six). In
    /// relative mode they select the twist's (x: the velocity along x, yaw: the
    /// rate about z).
    #[serde(default)]
    pub fuse: Components<PoseNames>,
}

impl PoseConfig {
    fn default_yaw_random_walk() -> f64 {
        0.01
    }
    fn default_origin_random_walk() -> f64 {
        0.01
    }
    fn default_realign_after_gated() -> u32 {
        5
    }

    /// The fixed map frame `(ψ rad, t m)`, if configured.
    pub fn configured_frame(&self) -> Option<(f64, [f64; 3])> {
        Some((self.frame_yaw_deg?.to_radians(), self.frame_origin_m?))
    }

    /// Whether the map frame is estimated as states (not configured, and the
    /// poses fused absolutely).
    pub fn estimated(&self) -> bool {
        !self.relative && self.configured_frame().is_none()
    }

    /// The checked settings: a configured frame whole (yaw and origin, finite,
    /// yaw within ±360°), random walks finite and ≥ 0.
    pub fn check(&self, key: impl Fn(&str) -> String) -> Result<Self, ConfigError> {
        match (self.frame_yaw_deg, self.frame_origin_m) {
            (Some(_), None) => return Err(invalid(key("frame_origin_m"), "a configured frame needs its origin too")),
            (None, Some(_)) => return Err(invalid(key("frame_yaw_deg"), "a configured frame needs its yaw too")),
            (Some(y), Some(o)) => {
                if !(y.is_finite() && y.abs() <= 360.0) {
                    return Err(invalid(key("frame_yaw_deg"), format!("must be finite, within ±360°, got {y}")));
                }
                if !o.iter().all(|v| v.is_finite()) {
                    return Err(invalid(key("frame_origin_m"), "must be finite"));
                }
            }
            (None, None) => {}
        }
        for (name, v) in [
            ("frame_yaw_random_walk_deg", self.frame_yaw_random_walk_deg),
            ("frame_origin_random_walk_m", self.frame_origin_random_walk_m),
        ] {
            if !(v.is_finite() && (0.0..10.0).contains(&v)) {
                return Err(invalid(key(name), format!("must be in [0, 10) per square root of a second, got {v}")));
            }
        }
        Ok(*self)
    }
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            frame_yaw_deg: None,
            frame_origin_m: None,
            frame_yaw_random_walk_deg: Self::default_yaw_random_walk(),
            frame_origin_random_walk_m: Self::default_origin_random_walk(),
            realign_after_gated: Self::default_realign_after_gated(),
            relative: false,
            fuse: Components::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_configured_whole_or_estimated() {
        let key = |f: &str| f.to_string();
        let estimated = PoseConfig::default().check(key).unwrap();
        assert!(estimated.estimated());
        let fixed = PoseConfig { frame_yaw_deg: Some(90.0), frame_origin_m: Some([1.0, 2.0, 3.0]), ..estimated };
        let (yaw, origin) = fixed.check(key).unwrap().configured_frame().unwrap();
        assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-15 && origin == [1.0, 2.0, 3.0]);
        assert!(!fixed.estimated());
        let err = |c: PoseConfig| c.check(key).unwrap_err().to_string();
        assert!(err(PoseConfig { frame_yaw_deg: Some(1.0), ..estimated }).contains("frame_origin_m"));
        assert!(err(PoseConfig { frame_origin_m: Some([0.0; 3]), ..estimated }).contains("frame_yaw_deg"));
        assert!(err(PoseConfig { frame_yaw_random_walk_deg: f64::NAN, ..estimated }).contains("random_walk"));
        assert!(!PoseConfig { relative: true, ..estimated }.estimated());
    }
}
