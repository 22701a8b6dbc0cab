//! Builds the daemon's parts from a validated [`Config`]: the model (and its
//! frames), the engine's limits. The only place that maps `[model] kind` to a
//! model type; the parts themselves know nothing of the file.

use super::{Config, ConfigError, ModelConfig, Tables, invalid, positive};
use crate::engine::EngineConfig;
use crate::frames::{Frames, MountedSensor};
use crate::measurement::Steps;
use crate::model::Model;
use crate::model::ins::{self, AlignmentParams, CourseAlignment, ImuNoise, InsModel, InsParams, OdometryScale};
use crate::model::linear::{self, LinearModel};

/// Runs something generic over the model type with the configured model.
pub trait WithModel {
    /// What it gives.
    type Output;
    /// Runs with `model`.
    fn run<M: Steps>(self, model: M) -> Self::Output;
}

/// How a model type is built from a config and handed to a [`WithModel`].
pub trait Build {
    /// A built model: the type itself, or an enum of its forms with different
    /// state dimensions ([`InsBuilt`]).
    type Built: Clone + std::fmt::Debug;
    /// Builds it from a config of its kind.
    fn build(config: &Tables) -> Result<Self::Built, ConfigError>;
    /// Hands `built`, as its own type, to `f`.
    fn run<F: WithModel>(built: Self::Built, f: F) -> F::Output;
}

// The kinds each model fuses (every other is refused: `measurement::Fusion`).
crate::fuses!(LinearModel: Imu, Position, Velocity, Geodetic);
impl<const D: usize> crate::measurement::EveryKind for InsModel<D> {}

impl Build for LinearModel {
    type Built = LinearModel;
    fn build(config: &Tables) -> Result<Self, ConfigError> {
        Self::from_config(config)
    }
    fn run<F: WithModel>(built: Self, f: F) -> F::Output {
        f.run(built)
    }
}

/// Generates [`InsBuilt`], a variant per number of auxiliary states (none to
/// [`ins::MAX_AUX`]), its building and its dispatch.
macro_rules! ins_forms {
    ($($variant:ident = $aux:literal),* $(,)?) => {
        /// The `ins` model as configured: the core 15 error states and the
        /// auxiliary states the config brings ([`ins::aux`]), one variant per
        /// dimension.
        #[derive(Debug, Clone)]
        #[allow(clippy::large_enum_variant, reason = "one value per config, built once at start-up")]
        pub enum InsBuilt {
            /// Without auxiliary states.
            Core(InsModel),
            $(#[doc = concat!("With ", stringify!($aux), " auxiliary error states.")] $variant(InsModel<{ ins::N + $aux }>),)*
        }

        impl InsBuilt {
            /// `core` with `aux` in form `f`, as the variant of its dimension.
            fn of(core: InsModel, aux: ins::AuxStates, f: crate::filter::Form) -> Result<Self, crate::filter::FilterError> {
                Ok(match aux.len() {
                    0 => Self::Core(core.with_form(f)?),
                    $($aux => Self::$variant(core.with_aux(aux)?.with_form(f)?),)*
                    n => return Err(crate::filter::FilterError::StateDimension { got: ins::N + n, expected: ins::MAX_N }),
                })
            }

            /// Hands the model, as its own type, to `f`.
            fn run_with<F: WithModel>(self, f: F) -> F::Output {
                match self {
                    Self::Core(m) => f.run(m),
                    $(Self::$variant(m) => f.run(m),)*
                }
            }
        }

        const _: () = assert!([$($aux),*].len() == ins::MAX_AUX, "a variant per number of auxiliary states");
    };
}

ins_forms!(Aux1 = 1, Aux2 = 2, Aux3 = 3, Aux4 = 4, Aux5 = 5, Aux6 = 6);

impl InsBuilt {
    /// The model of a config with `kind = "ins"`.
    pub fn from_config(config: &Tables) -> Result<Self, ConfigError> {
        let ModelConfig::Ins(p) = &config.model else {
            return Err(invalid("model.kind", "not \"ins\""));
        };
        let core = InsModel::core_from_config(config)?;
        let aux = aux_states(p.odometry_scale, core.frames())?;
        Self::of(core, aux, config.filter.form).map_err(|e| invalid("filter.initial_state", e.to_string()))
    }

    /// The model with the odometry scale factor as its one auxiliary state, if
    /// the config has it so.
    pub fn scaled(self) -> Option<InsModel<{ ins::N + 1 }>> {
        match self {
            Self::Aux1(m) if m.estimates_odometry_scale() => Some(m),
            _ => None,
        }
    }
}

/// The auxiliary states of a config: `[model.odometry_scale]`'s, and those
/// its sensors bring (each kind declares its own: [`ins::aux`]). A snapshot
/// carries at most [`ins::MAX_AUX`] of them, and a kind as many instances as
/// it declares: a config that brings more is refused with the count (two
/// estimated map frames, eight states, never fit).
fn aux_states(scale: Option<OdometryScale>, frames: &Frames) -> Result<ins::AuxStates, ConfigError> {
    let mut own = ins::AuxStates::default();
    if let Some(k) = scale {
        check_odometry_scale(&k)?;
        own = own.with_odometry_scale(k);
    }
    let (aux, beyond) = crate::measurement::aux_states(own, frames);
    if !aux.fits() {
        let culprit = beyond.map_or("model.odometry_scale", |m| m.name.as_str());
        return Err(invalid(
            "sensor",
            format!(
                "{culprit:?}: the configuration brings {} auxiliary states ({}), and a snapshot carries at most {}; \
                 configure fewer{}",
                aux.wanted(),
                aux.describe(),
                ins::MAX_AUX,
                fewer_aux(frames)
            ),
        ));
    }
    Ok(aux)
}

/// How the configured sensors' kinds say a configuration may bring fewer
/// auxiliary states (`Measurement::FEWER_AUX`), as a clause: `""` if none says.
fn fewer_aux(frames: &Frames) -> String {
    let mut ways: Vec<&str> = Vec::new();
    for m in frames.sensors() {
        let way = crate::measurement::fewer_aux(m.kind);
        if !way.is_empty() && !ways.contains(&way) {
            ways.push(way);
        }
    }
    if ways.is_empty() { String::new() } else { format!(" ({})", ways.join("; ")) }
}

/// `[model.odometry_scale]`'s values: `initial` in (0.5, 2), `initial_std` in
/// (0, 0.5], `random_walk` ≥ 0 and below 0.1/√s; all finite.
fn check_odometry_scale(k: &OdometryScale) -> Result<(), ConfigError> {
    if !(k.initial > 0.5 && k.initial < 2.0) {
        return Err(invalid("model.odometry_scale.initial", format!("must be in (0.5, 2), got {}", k.initial)));
    }
    if !(k.initial_std > 0.0 && k.initial_std <= 0.5) {
        return Err(invalid(
            "model.odometry_scale.initial_std",
            format!("must be in (0, 0.5] (a share of the speed), got {}", k.initial_std),
        ));
    }
    if !(k.random_walk >= 0.0 && k.random_walk < 0.1) {
        return Err(invalid(
            "model.odometry_scale.random_walk",
            format!("must be in [0, 0.1) per square root of a second, got {}", k.random_walk),
        ));
    }
    Ok(())
}

impl Build for InsModel {
    type Built = InsBuilt;
    fn build(config: &Tables) -> Result<InsBuilt, ConfigError> {
        InsBuilt::from_config(config)
    }
    fn run<F: WithModel>(built: InsBuilt, f: F) -> F::Output {
        built.run_with(f)
    }
}

/// Generates [`BuiltModel`] from [`fusion_shared::for_each_model!`], and checks
/// that each model type's snapshot code is its line's.
macro_rules! dispatch {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident, $params:ident, $cov:literal, [$($layout:expr),* $(,)?];)*) => {
        /// The configured model, built: one variant per model type.
        #[derive(Debug, Clone)]
        #[allow(clippy::large_enum_variant, reason = "one value per config, built once at start-up")]
        pub enum BuiltModel {
            $($(#[$doc])* $variant(<crate::model::$module::$ty as Build>::Built),)*
        }

        impl BuiltModel {
            /// Builds the model `[model] kind` names: the one place that maps
            /// it to a model type (each type's `from_config`).
            pub fn build(tables: &Tables) -> Result<Self, ConfigError> {
                Ok(match &tables.model {
                    $(ModelConfig::$variant(_) => Self::$variant(<crate::model::$module::$ty as Build>::build(tables)?),)*
                })
            }

            /// Hands the model, as its own type, to `f`.
            pub fn run<F: WithModel>(self, f: F) -> F::Output {
                match self {
                    $(Self::$variant(model) => <crate::model::$module::$ty as Build>::run(model, f),)*
                }
            }
        }

        $(const _: () = assert!(
            <crate::model::$module::$ty as crate::model::Model>::CODE == $code,
            concat!("the snapshot code of ", $name, " is not its line's in for_each_model!")
        );)*
    };
}

fusion_shared::for_each_model!(dispatch);

/// Hands a copy of the model built when `config` was read to `f` (the frames
/// and the model are not built again).
pub fn with_model<F: WithModel>(config: &Config, f: F) -> F::Output {
    config.built().clone().run(f)
}

/// `[filter] initial_state` and `initial_covariance_diagonal` as the arrays of a
/// model with `N` states and `C` error states: right lengths, finite values, and
/// variances > 0.
pub fn initial_values<const N: usize, const C: usize>(config: &Tables) -> Result<([f64; N], [f64; C]), ConfigError> {
    let (f, kind) = (&config.filter, config.model.kind());
    let x0: [f64; N] = f.initial_state.as_slice().try_into().map_err(|_| {
        invalid("filter.initial_state", format!("model {kind:?} needs {N} values, got {}", f.initial_state.len()))
    })?;
    if let Some(v) = x0.iter().find(|v| !v.is_finite()) {
        return Err(invalid("filter.initial_state", format!("non-finite value {v}")));
    }
    let p0: [f64; C] = f.initial_covariance_diagonal.as_slice().try_into().map_err(|_| {
        let got = f.initial_covariance_diagonal.len();
        invalid("filter.initial_covariance_diagonal", format!("model {kind:?} needs {C} values, got {got}"))
    })?;
    if let Some(v) = p0.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(invalid(
            "filter.initial_covariance_diagonal",
            format!("variances must be finite and > 0, got {v}"),
        ));
    }
    Ok((x0, p0))
}

impl LinearModel {
    /// The model of a config with `kind = "linear"`.
    pub fn from_config(config: &Tables) -> Result<Self, ConfigError> {
        let ModelConfig::Linear(params) = &config.model else {
            return Err(invalid("model.kind", "not \"linear\""));
        };
        let sigma_a = positive("model.accel_noise_std", params.accel_noise_std)?;
        let (x0, p0) = initial_values::<{ linear::N }, { linear::N }>(config)?;
        let frames = Frames::from_config(config.datum, &config.sensors, config.imu, &crate::measurement::Kinds)?;
        for MountedSensor { kind, name, mount, .. } in frames.sensors() {
            if !<LinearModel as Steps>::accepts(*kind) {
                return Err(invalid(
                    "sensor",
                    format!("{name:?}: the linear model cannot fuse {}; use kind = \"ins\"", kind.name()),
                ));
            }
            if !(mount.unrotated && mount.at_origin) {
                return Err(invalid(
                    "sensor",
                    format!(
                        "{name:?}: the linear model has no attitude, so no rotation or lever arm; use kind = \"ins\""
                    ),
                ));
            }
        }
        Self::new(sigma_a, x0, p0, config.gating.clone())
            .and_then(|m| m.with_form(config.filter.form))
            .map(|m| m.with_frames(frames).with_lockout(config.lockout))
            .map_err(|e| invalid("filter.initial_covariance_diagonal", e.to_string()))
    }
}

impl InsModel {
    /// The model of a config with `kind = "ins"` and without auxiliary states
    /// (see [`InsBuilt::from_config`] for every config).
    pub fn from_config(config: &Tables) -> Result<Self, ConfigError> {
        match InsBuilt::from_config(config)? {
            InsBuilt::Core(m) => Ok(m),
            _ => Err(invalid(
                "model",
                "the configuration brings auxiliary states (its sensors' or the model's): build the model with \
                 InsBuilt::from_config",
            )),
        }
    }

    /// The core model of a config with `kind = "ins"`, in the default form.
    fn core_from_config(config: &Tables) -> Result<Self, ConfigError> {
        let ModelConfig::Ins(p) = &config.model else {
            return Err(invalid("model.kind", "not \"ins\""));
        };
        let noise = ImuNoise {
            accelerometer_noise_density: positive("model.accelerometer_noise_density", p.accelerometer_noise_density)?,
            gyroscope_noise_density: positive("model.gyroscope_noise_density", p.gyroscope_noise_density)?,
            accelerometer_random_walk: positive("model.accelerometer_random_walk", p.accelerometer_random_walk)?,
            gyroscope_random_walk: positive("model.gyroscope_random_walk", p.gyroscope_random_walk)?,
        };
        let gravity = positive("model.gravity_mps2", p.gravity_mps2)?;
        check_ins_tables(p)?;
        let (x0, p0) = initial_values::<{ ins::NOMINAL }, { ins::N }>(config)?;
        let norm = x0[6..10].iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(invalid(
                "filter.initial_state",
                format!("entries 6..10 are the attitude quaternion [w, x, y, z] and must have norm 1, got {norm}"),
            ));
        }
        let alignment = p.alignment.map_or(0, |a| a.static_samples);
        let course = course_alignment(p.alignment)?;
        let frames = Frames::from_config(config.datum, &config.sensors, config.imu, &crate::measurement::Kinds)?;
        if let Some(m) = frames.sensors().iter().find(|m| !<InsModel as Steps>::accepts(m.kind)) {
            return Err(invalid("sensor", format!("{:?}: the ins model cannot fuse {}", m.name, m.kind.name())));
        }
        Self::new(noise, gravity, x0, p0, config.gating.clone(), alignment)
            .map(|m| {
                let m = m.with_nonholonomic(p.constraints).with_standstill(p.standstill).with_course_alignment(course);
                let unobserved = ins::observability::yaw_unobserved(frames.sensors());
                let gravity = ins::observability::unaided(frames.sensors()).then(|| p.gravity.unwrap_or_default());
                m.with_gravity_reference(gravity)
                    .with_yaw_unobserved(unobserved)
                    .with_frames(frames)
                    .with_lockout(config.lockout)
            })
            .map_err(|e| invalid("filter.initial_state", e.to_string()))
    }
}

/// The `ins` model's optional tables, checked: the motion constraint, the
/// standstill detector and the gravity reference.
fn check_ins_tables(p: &InsParams) -> Result<(), ConfigError> {
    if let Some(c) = &p.constraints {
        positive("model.constraints.nonholonomic_std_mps", c.std_mps)?;
        if !(c.min_speed_mps.is_finite() && c.min_speed_mps >= 0.0) {
            return Err(invalid(
                "model.constraints.nonholonomic_min_speed_mps",
                format!("must be a finite number >= 0, got {}", c.min_speed_mps),
            ));
        }
        if !c.lever_arm_m.iter().all(|v| v.is_finite() && v.abs() <= 100.0) {
            return Err(invalid(
                "model.constraints.nonholonomic_lever_arm_m",
                format!("must be finite and within 100 m of the IMU, got {:?}", c.lever_arm_m),
            ));
        }
    }
    if let Some(c) = &p.standstill {
        window("model.standstill.window_ns", c.window_ns)?;
        positive("model.standstill.imu_threshold", c.imu_threshold)?;
        positive("model.standstill.velocity_std_mps", c.velocity_std_mps)?;
        for (key, v) in [
            ("model.standstill.max_speed_mps", c.max_speed_mps),
            ("model.standstill.odometry_speed_mps", c.odometry_speed_mps),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(key, format!("must be a finite number >= 0, got {v}")));
            }
        }
    }
    if let Some(c) = &p.gravity {
        window("model.gravity.window_ns", c.window_ns)?;
        positive("model.gravity.max_deviation_mps2", c.max_deviation_mps2)?;
        positive("model.gravity.variance_threshold", c.variance_threshold)?;
        positive("model.gravity.acceleration_std_mps2", c.acceleration_std_mps2)?;
    }
    Ok(())
}

/// The heading from the course (`[model.alignment] heading_from_velocity_mps`),
/// checked; `None` without it.
fn course_alignment(alignment: Option<AlignmentParams>) -> Result<Option<CourseAlignment>, ConfigError> {
    Ok(match alignment {
        Some(AlignmentParams { heading_from_velocity_mps: Some(speed), heading_sideslip_std_deg: slip, .. }) => {
            if !(speed.is_finite() && speed > 0.0) {
                let why = format!("must be a finite speed > 0 m/s, got {speed}");
                return Err(invalid("model.alignment.heading_from_velocity_mps", why));
            }
            if !(slip.is_finite() && (0.0..90.0).contains(&slip)) {
                let why = format!("must be a finite angle in [0, 90) degrees, got {slip}");
                return Err(invalid("model.alignment.heading_sideslip_std_deg", why));
            }
            Some(CourseAlignment { min_speed_mps: speed, sideslip_std_rad: slip.to_radians() })
        }
        _ => None,
    })
}

impl Default for EngineConfig {
    /// The limits of the default config.
    fn default() -> Self {
        Self::from_config(&Tables::default())
    }
}

impl EngineConfig {
    /// The limits of a validated config.
    pub fn from_config(c: &Tables) -> Self {
        Self {
            history_ns: c.filter.history_ns,
            history_capacity: c.filter.history_capacity,
            max_sensors: c.validation.max_sensors,
            max_future_ns: c.validation.max_future_ns,
            max_past_ns: c.validation.max_past_ns,
            max_jump_ns: c.validation.max_jump_ns,
            max_rate_hz: c.validation.max_rate_hz,
            max_burst: c.validation.max_burst,
            limits: c.validation.limits(),
        }
    }
}

/// Checks a detection window's length: 10 ms to 10 s.
fn window(key: &str, ns: u64) -> Result<(), ConfigError> {
    if (10_000_000..=10_000_000_000).contains(&ns) {
        return Ok(());
    }
    Err(invalid(key, format!("must be in 10_000_000..=10_000_000_000 (10 ms to 10 s), got {ns}")))
}
