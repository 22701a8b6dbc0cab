//! A configuration value's error and the checks every layer's settings use.
//!
//! The bottom of the daemon's layers: each module validates its own settings with
//! these, and `config` assembles them from the TOML file.

/// A configuration problem found at start-up.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// Not TOML, an unknown key, or a value of the wrong type (the message names the key).
    #[error("config: {0}")]
    Parse(#[from] toml::de::Error),
    /// A value out of its range or inconsistent with another.
    #[error("config: {key}: {problem}")]
    Invalid {
        /// Dotted key, e.g. `filter.initial_state`.
        key: String,
        /// What is wrong.
        problem: String,
    },
}

/// A [`ConfigError::Invalid`].
pub fn invalid(key: impl Into<String>, problem: impl Into<String>) -> ConfigError {
    ConfigError::Invalid { key: key.into(), problem: problem.into() }
}

/// Checks that a parameter is finite and > 0.
pub fn positive(key: &str, v: f64) -> Result<f64, ConfigError> {
    if v.is_finite() && v > 0.0 { Ok(v) } else { Err(invalid(key, format!("must be finite and > 0, got {v}"))) }
}
