//! `[sensor.barometer]`: the settings of a barometer's bias state (the state
//! is the `ins` model's auxiliary state, the measurement the barometer's
//! module).

use serde::Deserialize;

use crate::setting::{ConfigError, invalid};

/// `[sensor.barometer]`: the barometer's bias state (optional: the defaults
/// apply without the table).
///
/// The barometer's pressure altitude differs from the height by a bias that
/// the weather moves (1 hPa, about 8 m, in a few hours) and that the airflow
/// of the vehicle shifts; the bias is a state, set at the first sample so that
/// the first sample agrees with the height estimate, and then a random walk.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarometerConfig {
    /// Random-walk density of the bias, m/√s (default 0.05: 3 m in an hour).
    #[serde(default = "BarometerConfig::default_random_walk")]
    pub bias_random_walk_m: f64,
}

impl BarometerConfig {
    fn default_random_walk() -> f64 {
        0.05
    }

    /// The checked settings: the random walk finite and in [0, 10) m/√s.
    pub fn check(&self, key: impl Fn(&str) -> String) -> Result<Self, ConfigError> {
        let rw = self.bias_random_walk_m;
        if !(rw.is_finite() && (0.0..10.0).contains(&rw)) {
            return Err(invalid(key("bias_random_walk_m"), format!("must be in [0, 10) m/√s, got {rw}")));
        }
        Ok(*self)
    }
}

impl Default for BarometerConfig {
    fn default() -> Self {
        Self { bias_random_walk_m: Self::default_random_walk() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_random_walk_is_checked() {
        let baro = BarometerConfig { bias_random_walk_m: -1.0 };
        assert!(baro.check(|f: &str| f.to_string()).unwrap_err().to_string().contains("bias_random_walk_m"));
        assert_eq!(BarometerConfig::default().check(|f: &str| f.to_string()).ok(), Some(BarometerConfig::default()));
    }
}
