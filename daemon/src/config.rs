//! TOML configuration, validated at start-up.
//!
//! Unknown keys are errors; every validation error names the key and the problem.
//! `fusiond print-config` prints [`DEFAULT_CONFIG`], which is also what an empty
//! file means.

use std::path::Path;

use serde::Deserialize;

use crate::filter::ChiSquareGate;
use crate::health::{HealthConfig, MAX_NIS_WINDOW};

/// The default configuration with comments, as printed by `fusiond print-config`.
pub const DEFAULT_CONFIG: &str = r#"# fusiond configuration. Units are SI; frames: world ENU, body forward-left-up.

[model]
# "linear": constant-velocity model driven by world-frame acceleration with
# gravity removed (IMU accel), fused with 3-D positions.
kind = "linear"
accel_noise_std = 0.3        # sigma_a, m/s^2: white-noise acceleration per IMU interval

[filter]
# linear: [px, py, pz, vx, vy, vz] (m, m/s, ENU)
initial_state = [0, 0, 0, 0, 0, 0]
initial_covariance_diagonal = [100, 100, 100, 10, 10, 10]
# Samples up to this much older than the newest one are fused exactly by rewind
# and replay; older ones are dropped and counted.
history_ns = 1_000_000_000
# Most samples kept for rewinding (bounds memory: 1 s at 1 kHz IMU + positions
# needs ~1010). If it fills before history_ns, the window shrinks, counted.
history_capacity = 4096

[gating]
# Chi-square gate on the NIS: the probability a consistent measurement passes.
# Leave out the [gating] table to fuse every measurement.
probability = 0.999

[health]
# A stream is stale (health "degraded") after this long without a sample.
imu_timeout_ns = 100_000_000
position_timeout_ns = 1_000_000_000
# NIS test over the last nis_window fixes of each position sensor: degraded when
# their sum leaves the two-sided chi-square band at nis_probability.
nis_window = 20
nis_probability = 0.999

[validation]
# Live samples stamped more than this far ahead of the daemon's clock are rejected.
max_future_ns = 50_000_000
# Distinct sensor ids per kind (imu, position) the daemon tracks.
max_sensors = 8
"#;

/// A configuration problem found at start-up.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// Not TOML, an unknown key, or a value of the wrong type (the message names the key).
    #[error("config: {0}")]
    Parse(String),
    /// A value out of its range or inconsistent with another.
    #[error("config: {key}: {problem}")]
    Invalid {
        /// Dotted key, e.g. `filter.initial_state`.
        key: &'static str,
        /// What is wrong.
        problem: String,
    },
}

fn invalid(key: &'static str, problem: impl Into<String>) -> ConfigError {
    ConfigError::Invalid { key, problem: problem.into() }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    model: RawModel,
    filter: RawFilter,
    gating: Option<RawGating>,
    #[serde(default)]
    health: RawHealth,
    #[serde(default)]
    validation: RawValidation,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawHealth {
    imu_timeout_ns: u64,
    position_timeout_ns: u64,
    nis_window: usize,
    nis_probability: f64,
}

impl Default for RawHealth {
    fn default() -> Self {
        let d = HealthConfig::default();
        Self {
            imu_timeout_ns: d.imu_timeout_ns,
            position_timeout_ns: d.position_timeout_ns,
            nis_window: d.nis_window,
            nis_probability: d.nis_probability,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    kind: String,
    accel_noise_std: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFilter {
    initial_state: Vec<f64>,
    initial_covariance_diagonal: Vec<f64>,
    #[serde(default = "default_history_ns")]
    history_ns: u64,
    #[serde(default = "default_history_capacity")]
    history_capacity: usize,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGating {
    probability: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawValidation {
    #[serde(default = "default_max_future_ns")]
    max_future_ns: u64,
    #[serde(default = "default_max_sensors")]
    max_sensors: usize,
}

impl Default for RawValidation {
    fn default() -> Self {
        Self { max_future_ns: default_max_future_ns(), max_sensors: default_max_sensors() }
    }
}

fn default_history_ns() -> u64 {
    1_000_000_000
}
fn default_history_capacity() -> usize {
    4096
}
fn default_max_future_ns() -> u64 {
    50_000_000
}
fn default_max_sensors() -> usize {
    8
}

/// Which process and measurement model the filter runs, with its parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelConfig {
    /// Constant velocity driven by world-frame acceleration ([`crate::model::linear`]).
    Linear {
        /// σₐ, m/s².
        accel_noise_std: f64,
    },
}

impl ModelConfig {
    /// The model's name as in the config and snapshots.
    pub fn kind(&self) -> &'static str {
        match self {
            ModelConfig::Linear { .. } => "linear",
        }
    }

    /// Length of the state vector `x` and of the covariance side.
    pub fn dims(&self) -> (usize, usize) {
        match self {
            ModelConfig::Linear { .. } => (6, 6),
        }
    }
}

/// Filter start and history settings.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterConfig {
    /// x₀.
    pub initial_state: Vec<f64>,
    /// diag(P₀).
    pub initial_covariance_diagonal: Vec<f64>,
    /// Rewind window, ns.
    pub history_ns: u64,
    /// Most entries in the rewind history.
    pub history_capacity: usize,
}

/// Input validation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationConfig {
    /// Largest accepted lead of a sample timestamp over the daemon's clock, ns.
    pub max_future_ns: u64,
    /// Distinct sensor ids tracked per kind.
    pub max_sensors: usize,
}

/// A validated configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// The model.
    pub model: ModelConfig,
    /// Filter start and history.
    pub filter: FilterConfig,
    /// The gate, if gating is on.
    pub gating: Option<ChiSquareGate>,
    /// Health monitoring.
    pub health: HealthConfig,
    /// Input validation.
    pub validation: ValidationConfig,
}

impl Config {
    /// Reads and validates a config file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| ConfigError::Io { path: path.display().to_string(), source })?;
        Self::parse(&text)
    }

    /// The default configuration ([`DEFAULT_CONFIG`]).
    pub fn default_config() -> Self {
        // DEFAULT_CONFIG is a constant checked by the test `default_config_is_valid`.
        Self::parse(DEFAULT_CONFIG).expect("DEFAULT_CONFIG is valid")
    }

    /// Parses and validates TOML text.
    pub fn parse(text: &str) -> Result<Self, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        let model = match raw.model.kind.as_str() {
            "linear" => {
                let s = raw
                    .model
                    .accel_noise_std
                    .ok_or_else(|| invalid("model.accel_noise_std", "required for kind \"linear\""))?;
                if !(s.is_finite() && s > 0.0) {
                    return Err(invalid("model.accel_noise_std", format!("must be finite and > 0, got {s}")));
                }
                ModelConfig::Linear { accel_noise_std: s }
            }
            other => return Err(invalid("model.kind", format!("unknown model {other:?}; known: \"linear\""))),
        };
        let (n, n_cov) = model.dims();
        let f = raw.filter;
        if f.initial_state.len() != n {
            return Err(invalid(
                "filter.initial_state",
                format!("model {:?} needs {n} values, got {}", model.kind(), f.initial_state.len()),
            ));
        }
        if let Some(v) = f.initial_state.iter().find(|v| !v.is_finite()) {
            return Err(invalid("filter.initial_state", format!("non-finite value {v}")));
        }
        if f.initial_covariance_diagonal.len() != n_cov {
            return Err(invalid(
                "filter.initial_covariance_diagonal",
                format!("model {:?} needs {n_cov} values, got {}", model.kind(), f.initial_covariance_diagonal.len()),
            ));
        }
        if let Some(v) = f.initial_covariance_diagonal.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(invalid(
                "filter.initial_covariance_diagonal",
                format!("variances must be finite and > 0, got {v}"),
            ));
        }
        if f.history_ns == 0 {
            return Err(invalid("filter.history_ns", "must be > 0"));
        }
        if !(2..=1 << 20).contains(&f.history_capacity) {
            return Err(invalid(
                "filter.history_capacity",
                format!("must be in 2..=1048576, got {}", f.history_capacity),
            ));
        }
        let gating = match raw.gating {
            None => None,
            Some(g) => {
                Some(ChiSquareGate::new(g.probability).map_err(|e| invalid("gating.probability", e.to_string()))?)
            }
        };
        let h = raw.health;
        if h.imu_timeout_ns == 0 || h.position_timeout_ns == 0 {
            return Err(invalid("health", "timeouts must be > 0"));
        }
        if !(1..=MAX_NIS_WINDOW).contains(&h.nis_window) {
            return Err(invalid("health.nis_window", format!("must be in 1..={MAX_NIS_WINDOW}, got {}", h.nis_window)));
        }
        if !(h.nis_probability > 0.0 && h.nis_probability < 1.0) {
            return Err(invalid("health.nis_probability", format!("must be in (0, 1), got {}", h.nis_probability)));
        }
        let health = HealthConfig {
            imu_timeout_ns: h.imu_timeout_ns,
            position_timeout_ns: h.position_timeout_ns,
            nis_window: h.nis_window,
            nis_probability: h.nis_probability,
        };
        let v = raw.validation;
        if !(1..=256).contains(&v.max_sensors) {
            return Err(invalid("validation.max_sensors", format!("must be in 1..=256, got {}", v.max_sensors)));
        }
        Ok(Self {
            model,
            filter: FilterConfig {
                initial_state: f.initial_state,
                initial_covariance_diagonal: f.initial_covariance_diagonal,
                history_ns: f.history_ns,
                history_capacity: f.history_capacity,
            },
            gating,
            health,
            validation: ValidationConfig { max_future_ns: v.max_future_ns, max_sensors: v.max_sensors },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_is_valid() {
        let c = Config::parse(DEFAULT_CONFIG).unwrap();
        assert_eq!(c.model, ModelConfig::Linear { accel_noise_std: 0.3 });
        assert_eq!(c.filter.history_ns, 1_000_000_000);
        assert!((c.gating.unwrap().probability() - 0.999).abs() < 1e-15);
    }

    fn err(text: &str) -> String {
        Config::parse(text).unwrap_err().to_string()
    }

    const MIN: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\ninitial_covariance_diagonal = [1,1,1,1,1,1]\n";

    #[test]
    fn gating_is_off_without_its_table_and_defaults_apply() {
        let c = Config::parse(MIN).unwrap();
        assert!(c.gating.is_none());
        assert_eq!(c.filter.history_capacity, 4096);
        assert_eq!(c.validation.max_sensors, 8);
    }

    #[test]
    fn errors_name_the_key() {
        assert!(err(&format!("{MIN}bogus = 1\n")).contains("bogus"));
        assert!(err(&MIN.replace("accel_noise_std = 0.3", "accel_noise_sd = 0.3")).contains("accel_noise_sd"));
        assert!(err(&MIN.replace("0.3", "-1")).contains("model.accel_noise_std"));
        assert!(err(&MIN.replace("\"linear\"", "\"kalman\"")).contains("model.kind"));
        assert!(err(&MIN.replace("[0,0,0,0,0,0]", "[0,0,0]")).contains("filter.initial_state"));
        assert!(err(&MIN.replace("[1,1,1,1,1,1]", "[1,1,1,1,1,0]")).contains("filter.initial_covariance_diagonal"));
        assert!(err(&format!("{MIN}[gating]\nprobability = 1.5\n")).contains("gating.probability"));
        assert!(err(&format!("{MIN}history_ns = 0\n")).contains("filter.history_ns"));
        assert!(err(&format!("{MIN}[validation]\nmax_sensors = 0\n")).contains("validation.max_sensors"));
        assert!(err(&format!("{MIN}[health]\nnis_window = 0\n")).contains("health.nis_window"));
        assert!(err(&format!("{MIN}[health]\nimu_timeout = 5\n")).contains("imu_timeout"));
        assert!(err("[model]\nkind = \"linear\"\n").contains("filter"));
    }
}
