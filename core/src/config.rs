//! TOML configuration, validated at start-up: the top of the daemon's layers.
//!
//! Unknown keys are errors; every validation error names the key and the problem.
//! Each table is read into the type of its owner, which checks it: `[model]` into
//! the model's own parameters through [`ModelConfig`] (generated from
//! `fusion_shared::for_each_model!`: [`LinearParams`],
//! [`InsParams`](crate::model::ins::InsParams)), `[health]` by
//! [`HealthConfig::from_table`](crate::health::HealthConfig::from_table),
//! `[validation]` by [`ValidationConfig`] (`crate::validate`), `[datum]` by
//! [`DatumTable`], `[[sensor]]` and `[imu]` by
//! `crate::frames`, the lock-out keys of `[gating]` by
//! [`LockoutConfig::from_keys`](crate::model::lockout::LockoutConfig::from_keys).
//! This file assembles them, and holds the tables that several parts share
//! (`[filter]`: the model's start, the engine's history, the filter's form;
//! `[gating]`; `[ipc]`). Defaults are written once, in the owners' `Default`
//! impls; `fusiond print-config` prints [`default_config_text`], which a test
//! checks against them, and which is also what an empty file means.

use std::path::Path;

use fusion_shared::SampleKind;
use fusion_shared::geodesy::Datum;
use serde::Deserialize;

use crate::filter::ChiSquareGate;
use crate::frames::{DatumTable, ImuConfig, SensorConfig};
use crate::health::{HealthConfig, HealthTable};
use crate::measurement::Needed;
use crate::model::linear::LinearParams;
use crate::model::lockout::LockoutConfig;
pub use crate::validate::ValidationConfig;

mod build;
pub use crate::setting::{ConfigError, invalid, positive};
pub use build::{Build, BuiltModel, InsBuilt, WithModel, initial_values, with_model};

/// The default configuration with comments, as printed by `fusiond print-config`
/// ([`default_config_text`] fills in the per-kind lines).
const DEFAULT_CONFIG_TEMPLATE: &str = r#"# fusiond configuration. Units are SI; frames: world ENU, body forward-left-up.

[model]
# "linear": constant-velocity model driven by world-frame acceleration with
# gravity removed (IMU accel), fused with 3-D positions and velocities.
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
# How the covariance is held: "joseph" (P itself, Joseph-form update; fastest) or
# "udu" (P = U D U^T: Thornton predict, Bierman update; positive definite by
# construction, equal to "joseph" to rounding; see docs/performance.md).
form = "joseph"

[gating]
# Chi-square gate on the NIS: the probability a consistent measurement passes.
# The one table whose values are not those of an empty file: a file without a
# [gating] table fuses every measurement (no gate, no lock-out recovery).
probability = 0.999
# Lock-out recovery: when every position fix for lockout_ns (and at least
# lockout_fixes of them) was gated, the filter re-initialises its position and
# velocity from the fixes (health "degraded: re-initialised after a lock-out"); when
# every sample of another kind (wheels, twist, heading, attitude, ...) was, its
# next sample resets the states it observes to what it says (a magnetometer's:
# the heading alone, from a field of the expected strength and inclination).
# 0 turns it off.
lockout_ns = 5_000_000_000
lockout_fixes = 5

[health]
# A stream is stale (health "degraded") after this long without a sample, per
# sample kind: <kind>_timeout_ns. The health stays "initialising" until samples
# of {required} were processed (ins, which dead-reckons, needs no position fix).
{timeouts}# NIS test over the last nis_window measurements of each sensor: degraded when
# their sum stays out of the two-sided chi-square band at nis_probability for
# nis_window measurements in a row.
nis_window = 20
nis_probability = 0.999

[validation]
# Live samples stamped more than this far ahead of, or behind, the daemon's
# clock (CLOCK_MONOTONIC) are rejected: an unset or foreign sensor clock.
max_future_ns = 50_000_000
max_past_ns = 5_000_000_000
# Replay has no clock: a sample more than this far ahead of every sample before
# it, or back behind them, is refused; 100 such samples in a row (the same way)
# show that the recording's clock was set or has a gap: the next starts a new
# timeline, the estimate starting over.
max_jump_ns = 600_000_000_000
# Distinct sensor ids per kind ({kinds}) the daemon tracks; at most 16 sensors
# in all (the rows of a snapshot). Further ids are refused and counted.
max_sensors = 8
# Per sensor: samples beyond this rate (measured on their timestamps, with
# bursts of up to max_burst) are dropped and counted, so that a flooding
# sensor cannot crowd out the others.
max_rate_hz = 10_000.0
max_burst = 100
# IMU samples beyond the sensor's range are rejected: |accel| (m/s^2), |gyro| (rad/s).
accel_range_mps2 = 160.0     # 16 g
gyro_range_radps = 35.0      # 2000 deg/s

# The world frame is east-north-up about a datum: the first geodetic fix
# (latitude, longitude, height above the WGS-84 ellipsoid), or a fixed one:
#   [datum]
#   latitude_deg = 48.137
#   longitude_deg = 11.575
#   height_m = 519.0

# Where each sensor sits on the vehicle (body frame forward-left-up, origin at
# the IMU) and how its axes point; one [[sensor]] per device. Sensors without an
# entry are at the origin with the body's axes.
#   [[sensor]]
#   name = "gnss"
#   id = 0
#   kinds = ["geodetic", "velocity"]
#   lever_arm_m = [1.2, 0.0, 1.4]          # antenna from the IMU, m, body frame
#   time_offset_ns = 0                     # its stamps are this late (valid at t - offset); |offset| <= 10 s
#   [[sensor]]
#   name = "imu-left"
#   id = 0
#   kinds = ["imu"]
#   axes = "frd"                           # "flu" (default) or "frd" (PX4, ArduPilot)
#   rotation_rpy_deg = [0.0, 0.0, 90.0]    # body <- sensor: Rz(yaw) Ry(pitch) Rx(roll)
#   [[sensor]]
#   name = "wheels"
#   id = 0
#   kinds = ["odometry"]
#   lever_arm_m = [-1.3, 0.0, -0.3]        # middle of the rear axle
#   [[sensor]]
#   name = "compass"
#   id = 0
#   kinds = ["magnetometer"]               # ins only
#   axes = "frd"                           # its axes, as an IMU's
#   rotation_rpy_deg = [0.0, 0.0, 0.0]
#   [[sensor]]
#   name = "camera"
#   id = 0
#   kinds = ["twist"]                      # ins only: visual/lidar odometry's velocity, sensor axes
#   axes = "frd"
#   rotation_rpy_deg = [0.0, 10.0, 0.0]    # body <- sensor
#   lever_arm_m = [0.8, 0.0, 1.2]          # its optical centre, m
#   [[sensor]]
#   name = "baro"
#   id = 0
#   kinds = ["barometer"]                  # ins only; one per fusiond
#   lever_arm_m = [0.0, 0.0, 0.3]          # its static port, m
#   [[sensor]]
#   name = "slam"
#   id = 0
#   kinds = ["pose"]                       # ins only: a localiser's pose in its map frame
#   axes = "frd"
#   rotation_rpy_deg = [0.0, 10.0, 0.0]    # body <- sensor
#   lever_arm_m = [0.8, 0.0, 1.2]
#   [[sensor]]
#   name = "ahrs"                          # an IMU with its own attitude filter (Microstrain, Xsens, BNO055)
#   id = 0
#   kinds = ["imu", "attitude"]            # attitude: ins only, its orientation in ENU
#   rotation_rpy_deg = [90.0, 0.0, -90.0]  # body <- sensor, for both kinds
# Each kind with settings of its own reads them from a table under its [[sensor]]:
{tables}# Several IMUs: "average" the samples of each instant (IMUs on one clock), or
# "failover" (different clocks or rates): the first listed alive IMU is used.
[imu]
combine = "average"
failover_after_ns = 20_000_000
# Average, live: one snapshot per IMU instant, after the sample that completes it;
# when an IMU is missing at an instant, this long after its first sample came, ns
# (--wait event: as soon as fusiond would sleep; 0: a snapshot after every sample).
instant_wait_ns = 250_000

# State readers at once (fusionctl, applications); one more is refused with an
# error that names this key.
[ipc]
max_readers = 8

# For the error-state INS (real IMU: body specific force and angular rate), use
#   [model]
#   kind = "ins"
#   accelerometer_noise_density = 0.02     # m/s^2/sqrt(Hz)   (Kalibr names and units)
#   gyroscope_noise_density = 0.001        # rad/s/sqrt(Hz)
#   accelerometer_random_walk = 0.001      # m/s^3/sqrt(Hz)
#   gyroscope_random_walk = 1.0e-5         # rad/s^2/sqrt(Hz)
#   gravity_mps2 = 9.80665
#   [model.alignment]                      # optional alignment
#   static_samples = 400                   # at rest: roll/pitch from the mean specific force, yaw from initial_state
#   heading_from_velocity_mps = 3.0        # an unknown heading (>0.2 rad) from the course of a velocity this fast
#   heading_sideslip_std_deg = 2.0         #   (vehicle moving forward), the angle between body x and track, 1 sigma
#   [model.constraints]                    # optional, land vehicles: no sideways or vertical body velocity
#   nonholonomic_std_mps = 0.1             # how far the vehicle violates it (slip, suspension), 1 sigma
#   nonholonomic_interval_ns = 50_000_000  # applied at most this often
#   nonholonomic_min_speed_mps = 0.0       # and only above this forward speed, either way (0: always)
#   nonholonomic_lever_arm_m = [0, 0, 0]   # the point that does not slide (rear axle on the ground), from the IMU
#   [model.standstill]                     # optional: detect standing still (IMU and speed), then
#   window_ns = 200_000_000                #   zero-velocity and zero-rate updates every window, attitude held
#   imu_threshold = 3.0                    # quiet window: variance <= this x the noise densities' at rest
#   max_speed_mps = 0.3                    # estimated speed at most this (without recent odometry)
#   odometry_speed_mps = 0.01              # odometry speed at most this (when odometry came)
#   velocity_std_mps = 0.01                # sigma of the zero-velocity update
#   [model.gravity]                        # where no sensor gives a position, velocity or attitude (imu,
#   window_ns = 100_000_000                #   magnetometer, barometer alone): the accelerometer as gravity,
#   max_deviation_mps2 = 0.5               #   fused each window whose mean force is within this of g,
#   variance_threshold = 10.0              #   whose variance is <= this x the noise density's at rest,
#   acceleration_std_mps2 = 0.005          #   with this sigma of unseen acceleration (+ what motion shows)
#   [model.odometry_scale]                 # optional: the odometry's scale factor k as a state
#   initial = 1.0                          #   (odometry speed = k x true speed), at start
#   initial_std = 0.02                     # its sigma at start (2 %)
#   random_walk = 1.0e-5                   # how fast it wanders, 1/sqrt(s)
#   [filter]
#   initial_state = [px, py, pz, vx, vy, vz, qw, qx, qy, qz, bax, bay, baz, bgx, bgy, bgz]
#   initial_covariance_diagonal = [15 values: dp(3), dv(3), dtheta(3), dba(3), dbg(3)]
"#;

/// An unknown key inside a table that is read through a tagged enum (`[model]`)
/// comes back from the parser at its table's header line: the key and its own
/// line instead, found in `text` below that header. Any other error as it is.
fn locate_unknown_key(text: &str, e: toml::de::Error) -> ConfigError {
    let message = e.message().to_string();
    let Some(span) = e.span() else { return e.into() };
    let Some(field) = message.strip_prefix("unknown field `").and_then(|r| r.split('`').next()) else {
        return locate_bad_value(text, span.start, &message).unwrap_or_else(|| e.into());
    };
    let rest = &text[span.start.min(text.len())..];
    let header = rest.lines().next().unwrap_or("").trim();
    let Some(table) = header.strip_prefix('[').and_then(|h| h.strip_suffix(']')).filter(|t| !t.starts_with('[')) else {
        return e.into();
    };
    let first_line = text[..span.start.min(text.len())].matches('\n').count() + 1;
    // The table's own keys, then those of its sub-tables (`[model.alignment]`),
    // which the parser reports at the same header.
    let table = table.trim();
    let mut current = table.to_string();
    for (i, line) in rest.lines().enumerate().skip(1) {
        let line = line.trim_start();
        if let Some(header) = line.strip_prefix('[') {
            match header.split(']').next().map(str::trim) {
                Some(sub) if !sub.starts_with('[') && sub.strip_prefix(table).is_some_and(|r| r.starts_with('.')) => {
                    current = sub.to_string();
                    continue;
                }
                _ => break,
            }
        }
        if line.split(['=', ' ', '\t']).next() == Some(field) {
            let expected = message.split_once(", ").map_or(String::new(), |(_, x)| format!("; {x}"));
            return invalid(format!("{current}.{field}"), format!("unknown key (line {}){expected}", first_line + i));
        }
    }
    e.into()
}

/// A value of the wrong type or range inside a table read through a tagged
/// enum (`[model]`, `[model.alignment]`) comes back at the table's header
/// line, with the value but not its key: the key holding that value, found
/// below the header (its sub-tables too), and its own line instead.
fn locate_bad_value(text: &str, at: usize, message: &str) -> Option<ConfigError> {
    // `invalid value: integer `-3`, expected u32`, `invalid type: string "x", expected f64`.
    let literal = if let Some((_, r)) = message.split_once('`') {
        r.split('`').next()?.to_string()
    } else {
        let r = message.split_once(" string \"")?.1;
        format!("\"{}\"", r.split('"').next()?)
    };
    let rest = &text[at.min(text.len())..];
    let header = rest.lines().next()?.trim();
    let table = header.strip_prefix('[')?.strip_suffix(']')?.trim();
    let first_line = text[..at.min(text.len())].matches('\n').count() + 1;
    let mut current = table.to_string();
    for (i, line) in rest.lines().enumerate().skip(1) {
        let line = line.trim_start();
        if let Some(header) = line.strip_prefix('[') {
            match header.split(']').next().map(str::trim) {
                Some(sub) if sub.strip_prefix(table).is_some_and(|r| r.starts_with('.')) => {
                    current = sub.to_string();
                    continue;
                }
                _ => return None,
            }
        }
        let Some((key, value)) = line.split_once('=') else { continue };
        let value = value.split('#').next().unwrap_or("").trim();
        if value == literal || value.replace('_', "") == literal {
            return Some(invalid(format!("{current}.{}", key.trim()), format!("{message} (line {})", first_line + i)));
        }
    }
    None
}

/// The default configuration with comments, as printed by `fusiond print-config`:
/// what an empty file means. A test checks it against the `Default` impls.
pub fn default_config_text() -> String {
    let names = |group: Option<Needed>| -> Vec<&str> {
        let kinds = SampleKind::ALL.iter().filter(|&&k| group.is_none() || crate::measurement::needed(k) == group);
        kinds.map(|k| k.name()).collect()
    };
    let needed = [Needed::Propagation, Needed::Position].map(|g| names(Some(g)).join(" or "));
    let timeouts: String = SampleKind::ALL
        .iter()
        .map(|&k| format!("{}_timeout_ns = {}\n", k.name(), grouped(crate::measurement::default_timeout_ns(k))))
        .collect();
    DEFAULT_CONFIG_TEMPLATE
        .replace("{required}", &needed.join(", and of "))
        .replace("{timeouts}", &timeouts)
        .replace("{kinds}", &names(None).join(", "))
        .replace("{tables}", &crate::measurement::table_docs())
}

/// `n` with its digits in groups of three (`1_000_000`), as TOML allows.
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push('_');
        }
        out.push(c);
    }
    out
}

/// Which process model the filter runs, with its own parameters (`[model]`,
/// selected by `kind`), generated from [`fusion_shared::for_each_model!`].
macro_rules! model_config {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident, $params:ident, $cov:literal, [$($layout:expr),* $(,)?];)*) => {
        /// The `[model]` table: the model named by `kind`, with its own parameters.
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(tag = "kind")]
        // Read once at start-up: the variants' sizes cost nothing.
        #[allow(clippy::large_enum_variant)]
        pub enum ModelConfig {
            $($(#[$doc])* #[serde(rename = $name)] $variant(crate::model::$module::$params),)*
        }

        impl ModelConfig {
            /// The model's name as in the config and snapshots.
            pub fn kind(&self) -> &'static str {
                match self {
                    $(ModelConfig::$variant(_) => $name,)*
                }
            }
        }
    };
}

fusion_shared::for_each_model!(model_config);

impl Default for ModelConfig {
    fn default() -> Self {
        ModelConfig::Linear(LinearParams::default())
    }
}

/// Filter start and history settings (`[filter]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterConfig {
    /// x₀ (its layout is the model's).
    pub initial_state: Vec<f64>,
    /// diag(P₀) (its layout is the model's).
    pub initial_covariance_diagonal: Vec<f64>,
    /// Rewind window, ns.
    #[serde(default = "FilterConfig::default_history_ns")]
    pub history_ns: u64,
    /// Most entries in the rewind history.
    #[serde(default = "FilterConfig::default_history_capacity")]
    pub history_capacity: usize,
    /// How the covariance is held and updated: `"joseph"` (default) or `"udu"`.
    #[serde(default)]
    pub form: crate::filter::Form,
}

impl FilterConfig {
    fn default_history_ns() -> u64 {
        1_000_000_000
    }
    fn default_history_capacity() -> usize {
        4096
    }
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            initial_state: vec![0.0; 6],
            initial_covariance_diagonal: vec![100.0, 100.0, 100.0, 10.0, 10.0, 10.0],
            history_ns: Self::default_history_ns(),
            history_capacity: Self::default_history_capacity(),
            form: crate::filter::Form::default(),
        }
    }
}

/// `[gating]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGating {
    probability: f64,
    lockout_ns: Option<u64>,
    lockout_fixes: Option<u32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    model: ModelConfig,
    filter: FilterConfig,
    gating: Option<RawGating>,
    #[serde(default)]
    health: HealthTable,
    #[serde(default)]
    validation: ValidationConfig,
    datum: Option<DatumTable>,
    #[serde(default)]
    sensor: Vec<SensorConfig>,
    #[serde(default)]
    imu: ImuConfig,
    #[serde(default)]
    ipc: IpcConfig,
    /// fusion-ros's table (its ROS 2 node), which fusiond does not read.
    #[allow(dead_code)]
    ros: Option<toml::Value>,
    /// Moved to `[model.alignment]`; named only to say so.
    alignment: Option<toml::Value>,
    /// Moved to `[model.constraints]`; named only to say so.
    constraints: Option<toml::Value>,
}

/// The tables of a configuration file, each checked by its owner: the data a
/// [`Config`] was made of (read through it).
#[derive(Debug, Clone, PartialEq)]
pub struct Tables {
    /// The model and its parameters.
    pub model: ModelConfig,
    /// Filter start and history.
    pub filter: FilterConfig,
    /// The gate, if gating is on.
    pub gating: Option<ChiSquareGate>,
    /// Lock-out recovery, if gating is on and it is not turned off.
    pub lockout: Option<LockoutConfig>,
    /// Health monitoring.
    pub health: HealthConfig,
    /// Input validation.
    pub validation: ValidationConfig,
    /// The origin of the world frame (`[datum]`); `None`: the first geodetic fix.
    pub datum: Option<Datum>,
    /// Per-sensor mounts (`[[sensor]]`).
    pub sensors: Vec<SensorConfig>,
    /// How several IMUs are combined (`[imu]`).
    pub imu: ImuConfig,
    /// Shared-memory services (`[ipc]`).
    pub ipc: IpcConfig,
}

/// Shared-memory service settings (`[ipc]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IpcConfig {
    /// Most state readers at once; one more is refused with a clear error.
    pub max_readers: usize,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self { max_readers: fusion_shared::service::MAX_STATE_SUBSCRIBERS }
    }
}

/// A valid configuration: its [`Tables`] (read through `Deref`: `config.filter`)
/// and the model built from them, once, when the file was read: every error of
/// the file shows at load time, and [`with_model`] hands out that model.
/// Read-only: a changed value is a changed text, parsed again.
#[derive(Debug, Clone)]
pub struct Config {
    tables: Tables,
    built: BuiltModel,
}

impl std::ops::Deref for Config {
    type Target = Tables;
    fn deref(&self) -> &Tables {
        &self.tables
    }
}

impl PartialEq for Config {
    /// Equal tables (the model is built from them).
    fn eq(&self, other: &Self) -> bool {
        self.tables == other.tables
    }
}

impl Default for Config {
    /// What an empty file means ([`Tables::default`]).
    fn default() -> Self {
        Self::from_tables(Tables::default()).expect("the default tables are valid")
    }
}

impl Default for Tables {
    /// The defaults of every table, as [`default_config_text`] writes them out.
    fn default() -> Self {
        Self {
            model: ModelConfig::default(),
            filter: FilterConfig::default(),
            gating: Some(ChiSquareGate::new(0.999).expect("0.999 is a probability")),
            lockout: Some(LockoutConfig::default()),
            health: HealthConfig::default(),
            validation: ValidationConfig::default(),
            datum: None,
            sensors: Vec::new(),
            imu: ImuConfig::default(),
            ipc: IpcConfig::default(),
        }
    }
}

impl Config {
    /// Reads and validates a config file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| ConfigError::Io { path: path.display().to_string(), source })?;
        Self::parse(&text)
    }

    /// The default configuration ([`default_config_text`]).
    pub fn default_config() -> Self {
        // Checked by the test `print_config_is_the_defaults`.
        Self::parse(&default_config_text()).expect("the default config is valid")
    }

    /// Builds the model of checked tables (which checks the model's parameters,
    /// the frames of the sensors and which kinds the model takes).
    pub fn from_tables(tables: Tables) -> Result<Self, ConfigError> {
        let built = BuiltModel::build(&tables)?;
        Ok(Self { tables, built })
    }

    /// The model [`from_tables`](Self::from_tables) built.
    pub fn built(&self) -> &BuiltModel {
        &self.built
    }

    /// Parses and validates TOML text, and builds the model ([`from_tables`](Self::from_tables)).
    pub fn parse(text: &str) -> Result<Self, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| locate_unknown_key(text, e))?;
        for (table, present) in [("alignment", raw.alignment.is_some()), ("constraints", raw.constraints.is_some())] {
            if present {
                return Err(invalid(table, format!("this table is now [model.{table}]")));
            }
        }
        let f = &raw.filter;
        if f.history_ns == 0 {
            return Err(invalid("filter.history_ns", "must be > 0"));
        }
        if !(2..=1 << 20).contains(&f.history_capacity) {
            return Err(invalid(
                "filter.history_capacity",
                format!("must be in 2..=1048576, got {}", f.history_capacity),
            ));
        }
        let (gating, lockout) = match &raw.gating {
            None => (None, None),
            Some(g) => (
                Some(ChiSquareGate::new(g.probability).map_err(|e| invalid("gating.probability", e.to_string()))?),
                LockoutConfig::from_keys(g.lockout_ns, g.lockout_fixes)?,
            ),
        };
        let health = HealthConfig::from_table(raw.health)?;
        raw.validation.check()?;
        if !(1..=1024).contains(&raw.ipc.max_readers) {
            return Err(invalid("ipc.max_readers", format!("must be in 1..=1024, got {}", raw.ipc.max_readers)));
        }
        let datum = raw.datum.map(DatumTable::datum).transpose()?;
        Self::from_tables(Tables {
            model: raw.model,
            filter: raw.filter,
            gating,
            lockout,
            health,
            validation: raw.validation,
            datum,
            sensors: raw.sensor,
            imu: raw.imu,
            ipc: raw.ipc,
        })
    }
}

#[cfg(test)]
mod tests;
