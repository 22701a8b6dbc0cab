//! The `ins` model's parameters as configured: the IMU noise (Kalibr's names and
//! units), gravity, and the optional tables of `[model]`; the model's builders
//! and accessors of them.

use super::{AuxStates, GravityReference, InsModel, Nonholonomic, OdometryScale, Standstill};
use crate::filter::FilterError;
use crate::frames::Frames;

/// IMU noise parameters, named and scaled as in Kalibr's IMU model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuNoise {
    /// Accelerometer white noise density σ_a, m/s²/√Hz.
    pub accelerometer_noise_density: f64,
    /// Gyroscope white noise density σ_g, rad/s/√Hz.
    pub gyroscope_noise_density: f64,
    /// Accelerometer bias random walk σ_aw, m/s³/√Hz.
    pub accelerometer_random_walk: f64,
    /// Gyroscope bias random walk σ_gw, rad/s²/√Hz.
    pub gyroscope_random_walk: f64,
}

/// The `ins` model's parameters as configured (`[model]` with `kind = "ins"`, Kalibr
/// names and units).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InsParams {
    /// Accelerometer white noise density σ_a, m/s²/√Hz.
    pub accelerometer_noise_density: f64,
    /// Gyroscope white noise density σ_g, rad/s/√Hz.
    pub gyroscope_noise_density: f64,
    /// Accelerometer bias random walk σ_aw, m/s³/√Hz.
    pub accelerometer_random_walk: f64,
    /// Gyroscope bias random walk σ_gw, rad/s²/√Hz.
    pub gyroscope_random_walk: f64,
    /// Gravity, m/s².
    #[serde(default = "InsParams::default_gravity")]
    pub gravity_mps2: f64,
    /// Static alignment (`[model.alignment]`), if any.
    pub alignment: Option<AlignmentParams>,
    /// Land-vehicle motion constraint (`[model.constraints]`), if any.
    pub constraints: Option<Nonholonomic>,
    /// Standstill detection and its updates (`[model.standstill]`), if any.
    pub standstill: Option<Standstill>,
    /// The odometry scale factor as a state (`[model.odometry_scale]`), if any.
    pub odometry_scale: Option<OdometryScale>,
    /// The gravity reference's parameters (`[model.gravity]`; the defaults
    /// without it). It is on only where nothing else keeps the tilt
    /// observable ([`super::gravity`]).
    pub gravity: Option<GravityReference>,
}

impl InsParams {
    fn default_gravity() -> f64 {
        9.80665
    }
}

/// `[model.alignment]`: roll, pitch and gyro bias from the first samples at
/// rest, and the heading from the course over ground.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlignmentParams {
    /// IMU samples averaged at rest (0: none, the initial state's attitude is
    /// used).
    #[serde(default)]
    pub static_samples: u32,
    /// Least horizontal speed at which an unknown heading (1σ above 0.2 rad) is
    /// taken from a velocity sample's course over ground, m/s; unset: never
    /// ([`super::course`]).
    pub heading_from_velocity_mps: Option<f64>,
    /// Standard deviation of the angle between the body's forward axis and the
    /// velocity when the heading is aligned (sideslip), degrees (default 2).
    #[serde(default = "AlignmentParams::default_sideslip_deg")]
    pub heading_sideslip_std_deg: f64,
}

impl AlignmentParams {
    fn default_sideslip_deg() -> f64 {
        2.0
    }
}

impl<const D: usize> InsModel<D> {
    /// The same model with these frames (a configured datum).
    pub fn with_frames(mut self, frames: Frames) -> Self {
        self.frames = frames;
        self
    }

    /// The same model with its error-state filter in `form` (`[filter] form`).
    pub fn with_form(mut self, form: crate::filter::Form) -> Result<Self, FilterError> {
        self.initial = self.initial.with_form(form)?;
        Ok(self)
    }

    /// The same model with the land-vehicle motion constraint applied.
    pub fn with_nonholonomic(mut self, constraint: Option<Nonholonomic>) -> Self {
        self.nonholonomic = constraint;
        self
    }

    /// The same model with standstill detection and its updates.
    pub fn with_standstill(mut self, standstill: Option<Standstill>) -> Self {
        self.standstill = standstill;
        self
    }

    /// The same model with the observability constraint on when `unobserved`:
    /// nothing configured observes the yaw ([`super::observability`]).
    pub fn with_yaw_unobserved(mut self, unobserved: bool) -> Self {
        self.yaw_unobserved = unobserved;
        self
    }

    /// Whether nothing configured observes the yaw: it is then a consider
    /// direction of every update ([`super::observability`]).
    pub fn yaw_unobserved(&self) -> bool {
        self.yaw_unobserved
    }

    /// The same model with the gravity reference on (`Some`) or off.
    pub fn with_gravity_reference(mut self, reference: Option<GravityReference>) -> Self {
        let gate = super::gravity::GATE_PROBABILITY;
        self.gravity_reference = reference.and_then(|r| crate::filter::ChiSquareGate::new(gate).ok().map(|g| (r, g)));
        self
    }

    /// The gravity reference and its gate, if on.
    pub fn gravity_reference(&self) -> Option<&(GravityReference, crate::filter::ChiSquareGate)> {
        self.gravity_reference.as_ref()
    }

    /// Standstill detection, if configured.
    pub fn standstill(&self) -> Option<&Standstill> {
        self.standstill.as_ref()
    }

    /// Whether the odometry scale factor is a state.
    pub fn estimates_odometry_scale(&self) -> bool {
        self.aux.bits() & fusion_shared::snapshot::aux::ODOMETRY_SCALE != 0
    }

    /// The auxiliary states and their parameters.
    pub fn aux(&self) -> &AuxStates {
        &self.aux
    }

    /// The IMU noise.
    pub fn noise(&self) -> &ImuNoise {
        &self.noise
    }
}
