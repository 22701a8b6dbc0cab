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
# needs ~1010). If it fills before history_ns, the window shrinks, counted. All of
# it is allocated and touched at start (about 0.5 KB per entry for linear, 2.4 KB
# for ins), so no page fault ever lands on the live path.
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
# IMU samples beyond the sensor's range are rejected: |accel| (m/s^2), |gyro| (rad/s).
accel_range_mps2 = 160.0     # 16 g
gyro_range_radps = 35.0      # 2000 deg/s

# For the error-state INS (real IMU: body specific force and angular rate), use
#   [model]
#   kind = "ins"
#   accelerometer_noise_density = 0.02     # m/s^2/sqrt(Hz)   (Kalibr names and units)
#   gyroscope_noise_density = 0.001        # rad/s/sqrt(Hz)
#   accelerometer_random_walk = 0.001      # m/s^3/sqrt(Hz)
#   gyroscope_random_walk = 1.0e-5         # rad/s^2/sqrt(Hz)
#   gravity_mps2 = 9.80665
#   [filter]
#   initial_state = [px, py, pz, vx, vy, vz, qw, qx, qy, qz, bax, bay, baz, bgx, bgy, bgz]
#   initial_covariance_diagonal = [15 values: dp(3), dv(3), dtheta(3), dba(3), dbg(3)]
#   [alignment]                            # optional static alignment
#   static_samples = 400                   # roll/pitch from the mean specific force, yaw from initial_state
#   [constraints]                          # optional, land vehicles: no sideways or vertical body velocity
#   nonholonomic_std_mps = 0.1             # how far the vehicle violates it (slip, suspension), 1 sigma
#   nonholonomic_interval_ns = 50_000_000  # applied at most this often
#   nonholonomic_min_speed_mps = 1.0       # and only above this forward speed
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
    alignment: Option<RawAlignment>,
    constraints: Option<RawConstraints>,
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
    accelerometer_noise_density: Option<f64>,
    gyroscope_noise_density: Option<f64>,
    accelerometer_random_walk: Option<f64>,
    gyroscope_random_walk: Option<f64>,
    gravity_mps2: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConstraints {
    nonholonomic_std_mps: f64,
    #[serde(default = "default_nhc_interval_ns")]
    nonholonomic_interval_ns: u64,
    #[serde(default = "default_nhc_min_speed")]
    nonholonomic_min_speed_mps: f64,
}

fn default_nhc_interval_ns() -> u64 {
    50_000_000
}
fn default_nhc_min_speed() -> f64 {
    1.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAlignment {
    static_samples: u32,
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
    #[serde(default = "default_accel_range")]
    accel_range_mps2: f64,
    #[serde(default = "default_gyro_range")]
    gyro_range_radps: f64,
}

impl Default for RawValidation {
    fn default() -> Self {
        Self {
            max_future_ns: default_max_future_ns(),
            max_sensors: default_max_sensors(),
            accel_range_mps2: default_accel_range(),
            gyro_range_radps: default_gyro_range(),
        }
    }
}

fn default_accel_range() -> f64 {
    160.0
}
fn default_gyro_range() -> f64 {
    35.0
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
    /// Error-state INS ([`crate::model::ins`]).
    Ins {
        /// IMU noise (Kalibr names and units).
        noise: crate::model::ins::ImuNoise,
        /// Gravity, m/s².
        gravity_mps2: f64,
        /// IMU samples of the static alignment (0: none).
        alignment_samples: u32,
        /// Land-vehicle motion constraint, if configured.
        nonholonomic: Option<crate::model::ins::Nonholonomic>,
    },
}

impl ModelConfig {
    /// The model's name as in the config and snapshots.
    pub fn kind(&self) -> &'static str {
        match self {
            ModelConfig::Linear { .. } => "linear",
            ModelConfig::Ins { .. } => "ins",
        }
    }

    /// Length of the state vector `x` and of the covariance side.
    pub fn dims(&self) -> (usize, usize) {
        match self {
            ModelConfig::Linear { .. } => (6, 6),
            ModelConfig::Ins { .. } => (16, 15),
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
    /// Largest accepted magnitude of an IMU's acceleration or specific force, m/s².
    pub accel_range_mps2: f64,
    /// Largest accepted magnitude of an IMU's angular rate, rad/s.
    pub gyro_range_radps: f64,
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
        let m = &raw.model;
        let positive = |key: &'static str, v: Option<f64>, kind: &str| -> Result<f64, ConfigError> {
            let v = v.ok_or_else(|| invalid(key, format!("required for kind {kind:?}")))?;
            if v.is_finite() && v > 0.0 { Ok(v) } else { Err(invalid(key, format!("must be finite and > 0, got {v}"))) }
        };
        let reject = |key: &'static str, present: bool, kind: &str| -> Result<(), ConfigError> {
            if present { Err(invalid(key, format!("is not a parameter of kind {kind:?}"))) } else { Ok(()) }
        };
        let model = match m.kind.as_str() {
            "linear" => {
                reject("model.accelerometer_noise_density", m.accelerometer_noise_density.is_some(), "linear")?;
                reject("model.gyroscope_noise_density", m.gyroscope_noise_density.is_some(), "linear")?;
                reject("model.accelerometer_random_walk", m.accelerometer_random_walk.is_some(), "linear")?;
                reject("model.gyroscope_random_walk", m.gyroscope_random_walk.is_some(), "linear")?;
                reject("model.gravity_mps2", m.gravity_mps2.is_some(), "linear")?;
                reject("alignment", raw.alignment.is_some(), "linear")?;
                reject("constraints", raw.constraints.is_some(), "linear")?;
                ModelConfig::Linear { accel_noise_std: positive("model.accel_noise_std", m.accel_noise_std, "linear")? }
            }
            "ins" => {
                reject("model.accel_noise_std", m.accel_noise_std.is_some(), "ins")?;
                let noise = crate::model::ins::ImuNoise {
                    accelerometer_noise_density: positive(
                        "model.accelerometer_noise_density",
                        m.accelerometer_noise_density,
                        "ins",
                    )?,
                    gyroscope_noise_density: positive(
                        "model.gyroscope_noise_density",
                        m.gyroscope_noise_density,
                        "ins",
                    )?,
                    accelerometer_random_walk: positive(
                        "model.accelerometer_random_walk",
                        m.accelerometer_random_walk,
                        "ins",
                    )?,
                    gyroscope_random_walk: positive("model.gyroscope_random_walk", m.gyroscope_random_walk, "ins")?,
                };
                let gravity_mps2 = positive("model.gravity_mps2", Some(m.gravity_mps2.unwrap_or(9.80665)), "ins")?;
                let alignment_samples = raw.alignment.as_ref().map_or(0, |a| a.static_samples);
                let nonholonomic = match &raw.constraints {
                    None => None,
                    Some(c) => Some(crate::model::ins::Nonholonomic {
                        std_mps: positive("constraints.nonholonomic_std_mps", Some(c.nonholonomic_std_mps), "ins")?,
                        interval_ns: c.nonholonomic_interval_ns,
                        min_speed_mps: if c.nonholonomic_min_speed_mps.is_finite()
                            && c.nonholonomic_min_speed_mps >= 0.0
                        {
                            c.nonholonomic_min_speed_mps
                        } else {
                            return Err(invalid(
                                "constraints.nonholonomic_min_speed_mps",
                                format!("must be a finite number >= 0, got {}", c.nonholonomic_min_speed_mps),
                            ));
                        },
                    }),
                };
                ModelConfig::Ins { noise, gravity_mps2, alignment_samples, nonholonomic }
            }
            other => return Err(invalid("model.kind", format!("unknown model {other:?}; known: \"linear\", \"ins\""))),
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
        if matches!(model, ModelConfig::Ins { .. }) {
            let q = &f.initial_state[6..10];
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(invalid(
                    "filter.initial_state",
                    format!("entries 6..10 are the attitude quaternion [w, x, y, z] and must have norm 1, got {norm}"),
                ));
            }
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
        for (key, value) in
            [("validation.accel_range_mps2", v.accel_range_mps2), ("validation.gyro_range_radps", v.gyro_range_radps)]
        {
            if !(value.is_finite() && value > 0.0) {
                return Err(invalid(key, format!("must be finite and > 0, got {value}")));
            }
        }
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
            validation: ValidationConfig {
                max_future_ns: v.max_future_ns,
                max_sensors: v.max_sensors,
                accel_range_mps2: v.accel_range_mps2,
                gyro_range_radps: v.gyro_range_radps,
            },
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
        assert!(err(&format!("{MIN}[alignment]\nstatic_samples = 5\n")).contains("alignment"));
    }

    const INS: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
        accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
        initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\ninitial_covariance_diagonal = [1,1,1, 1,1,1, 0.1,0.1,0.1, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
        [alignment]\nstatic_samples = 400\n";

    #[test]
    fn ins_config_uses_kalibr_names() {
        let c = Config::parse(INS).unwrap();
        let ModelConfig::Ins { noise, gravity_mps2, alignment_samples, .. } = c.model else { panic!() };
        assert_eq!((noise.gyroscope_random_walk, gravity_mps2, alignment_samples), (1e-5, 9.80665, 400));
        assert!(err(&INS.replace("1,0,0,0, 0,0,0", "2,0,0,0, 0,0,0")).contains("quaternion"));
        assert!(err(&INS.replace("gyroscope_random_walk = 1.0e-5\n", "")).contains("model.gyroscope_random_walk"));
        assert!(err(&INS.replace("1e-6,1e-6,1e-6]", "1e-6,1e-6]")).contains("needs 15 values"));
        let ModelConfig::Ins { nonholonomic, .. } = c.model else { panic!() };
        assert_eq!(nonholonomic, None, "the motion constraint is opt-in");
        let with = |table: &str| Config::parse(&format!("{INS}[constraints]\n{table}"));
        let ModelConfig::Ins { nonholonomic: Some(nhc), .. } = with("nonholonomic_std_mps = 0.2\n").unwrap().model
        else {
            panic!()
        };
        assert_eq!((nhc.std_mps, nhc.interval_ns, nhc.min_speed_mps), (0.2, 50_000_000, 1.0));
        let bad = |table: &str| with(table).unwrap_err().to_string();
        assert!(bad("nonholonomic_std_mps = 0\n").contains("constraints.nonholonomic_std_mps"));
        assert!(bad("nonholonomic_std_mps = 0.1\nnonholonomic_min_speed_mps = -1\n").contains("min_speed"));
        assert!(err(&format!("{MIN}[constraints]\nnonholonomic_std_mps = 0.1\n")).contains("constraints"));
        assert!(
            err(&INS.replace("kind = \"ins\"", "kind = \"ins\"\naccel_noise_std = 1"))
                .contains("model.accel_noise_std")
        );
        assert!(err("[model]\nkind = \"linear\"\n").contains("filter"));
    }
}
