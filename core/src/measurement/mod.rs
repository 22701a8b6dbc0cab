//! Measurement kinds: one module per sensor kind, everything the daemon knows of it.
//!
//! Each module gives, for its wire type ([`fusion_shared::sample`]):
//!
//! - [`Measurement`]: its validation, its processing rank at equal time, its
//!   default health timeout, and whether the health waits for it (its
//!   innovation dimension, the NIS band of the health, is the wire type's own:
//!   [`WireSample::INNOVATION_DIM`], or fewer by a sensor's settings); whether
//!   its samples are in the sensor's own axes; a sensor's settings of it (the
//!   type of its `[sensor.<table>]` table, its reading and its checks, held in
//!   a leaf module of the kind's), which [`settings`] looks up; and every other
//!   fact of the kind that a model, the daemon or the config builder acts on:
//!   what a sensor of it observes ([`Measurement::observes`], nothing by
//!   default: no heading until the kind says so), when a reading is exact, its
//!   lock-out rule, what an unconfigured sensor lacks, how to bring fewer of its
//!   auxiliary states and its check of the whole configuration;
//! - [`Fuse`]: how a model that can fuses it, written for what the model can do
//!   (a [`Kinematic`] model: a world position and velocity; the INS error state),
//!   with [`Observe`], its observation of a model's state (residual, H, R); it
//!   changes the state only through the model (for `ins`: `progress_mut`,
//!   `reset_attitude`). A model lists the kinds it fuses ([`fuses!`](crate::fuses),
//!   or [`EveryKind`]); every other it refuses ([`Fusion`]).
//!
//! The daemon keeps no list of kinds of its own: the registry at the end of this
//! file is generated from `fusion_shared::for_each_sample_kind!`, declaring each
//! kind's module (`measurement/<module>.rs`), the dispatch from a [`Sample`] to
//! it, and [`Kinds`], what the `[[sensor]]` reading needs of each kind (what a
//! new kind touches: `docs/architecture.md`). The land-vehicle motion
//! constraint, without a wire type, is the `ins` model's
//! ([`crate::model::ins::nonholonomic`]).

mod checks;
pub mod components;
pub mod lever_arm;
pub(crate) use checks::SYMMETRY_TOLERANCE;
pub use checks::{covariance, covariance3, finite, read_table, read_table_or_default};
#[cfg(test)]
mod observations;

use fusion_shared::{Sample, SampleKind, WireSample};
use nalgebra::{SMatrix, SVector};

pub use crate::frames::Observes;
use crate::frames::{Frames, KindCatalog, MountedSensor, Settings, SettingsValue};
use crate::model::ins::aux::{AuxPrior, AuxStates};
pub use crate::model::lockout::LockoutRule;
use crate::model::{Model, StepOutcome};
use crate::setting::ConfigError;
pub use crate::validate::{Limits, Rejection};

/// What the health waits for before it leaves "initialising": a sample of at
/// least one kind of each group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needed {
    /// A stream that drives the propagation (the IMU).
    Propagation,
    /// An absolute position (a fix in the world frame, or a geodetic one).
    Position,
}

/// What the daemon knows of one sample kind, beside its fusion ([`Fuse`]).
pub trait Measurement: WireSample {
    /// Processing order at equal time: lower first. The IMU (0) goes first, so a
    /// measurement at the time of an IMU sample is fused after the propagation to it.
    const RANK: u8;
    /// Health: a stream of this kind is stale after this long without a sample
    /// (the default of `[health] <kind>_timeout_ns`), ns.
    const TIMEOUT_NS: u64;
    /// The group of kinds of which the health waits for one ([`Needed`]), if any.
    const NEEDED: Option<Needed>;
    /// Whether its samples are another filter's estimate (an AHRS's attitude),
    /// whose errors are correlated over seconds: the scatter from one sample to
    /// the next, which the filter's innovations see, is far below the declared
    /// (absolute) error, so a small NIS says nothing of the filter's
    /// consistency and the health judges only a large one ([`crate::health`]).
    const FILTERED: bool = false;
    /// Whether its samples are in the sensor's own axes, so that a `[[sensor]]`
    /// rotation and axis convention apply to them (the others are in the world
    /// frame, or a scalar along the body's x axis).
    const ROTATED: bool = false;

    /// A sensor's settings of this kind: the type of its `[sensor.<TABLE>]`
    /// table, checked (`()` for a kind without one).
    type Settings: SettingsValue;
    /// The key of its table in a `[[sensor]]` entry, if it has one.
    const TABLE: Option<&'static str> = None;
    /// The table's keys with their defaults, as `fusiond print-config` prints
    /// them (commented lines).
    const TABLE_DOC: &'static str = "";

    /// A configured sensor's settings from its table as written (`None`: not
    /// given), checked; an error names the key (`key(field)`; `key("")` is the
    /// table's). `None`: the sensor has none (the kind's defaults apply).
    fn settings(
        _table: Option<&toml::Value>,
        _key: &dyn Fn(&str) -> String,
    ) -> Result<Option<Self::Settings>, ConfigError> {
        Ok(None)
    }

    /// How many of its innovation's components a sensor with `settings` fuses
    /// (the health's NIS band; the wire type's whole [`WireSample::INNOVATION_DIM`]
    /// by default).
    fn fused_dim(_settings: &Self::Settings) -> usize {
        Self::INNOVATION_DIM
    }

    /// The priors of the auxiliary states a sensor with `settings` brings to
    /// the `ins` model: one per state of its wire type's instance
    /// ([`WireSample::AUX`], which gives their bits and names), or none (a
    /// sensor that brings none; every sensor by default).
    fn aux_priors(_settings: &Self::Settings) -> Vec<AuxPrior> {
        Vec::new()
    }

    /// Checks the payload; the header is the engine's business.
    fn validate(&self, limits: &Limits) -> Result<(), Rejection>;

    /// Whether [`validate_as`](Self::validate_as) reads the sensor's settings
    /// (a kind whose settings select components): only then are they looked
    /// up for each sample.
    const VALIDATES_AS_SELECTED: bool = false;

    /// Checks the payload as a sensor with `settings` fuses it (`None`: the
    /// kind's defaults): a kind whose settings select components checks only
    /// those ([`components`]: what was not selected is never looked at).
    /// [`validate`](Self::validate) by default.
    fn validate_as(&self, limits: &Limits, _settings: Option<&Self::Settings>) -> Result<(), Rejection> {
        self.validate(limits)
    }

    /// A valid sample about to be processed may set what the frames still lack
    /// (a geodetic fix: the datum). Nothing by default.
    fn admit(&self, _frames: &Frames) {}

    /// What a sensor with `settings` (`None`: not configured) observes of the
    /// `ins` state ([`Observes`]). Nothing by default, the safe side: a kind
    /// gives no heading until it says so. A test over the kind list checks it
    /// against the kind's `H` ([`Observe`]): it sees the turn about world up
    /// exactly when it declares a heading or a horizontal position.
    fn observes(_settings: Option<&Self::Settings>) -> Observes {
        Observes::NOTHING
    }

    /// Whether this sample is an exact reading, without the noise its variance
    /// says (an encoder that counts no tick reads exactly 0): fused as any
    /// other, left out of the health's NIS test. None is, by default.
    fn exact(&self) -> bool {
        false
    }

    /// What a run of gated samples of this kind does ([`LockoutRule`]).
    const LOCKOUT: LockoutRule;

    /// What a sensor of this kind needs its `[[sensor]]` entry for, when
    /// samples of an unconfigured one are refused for good ("its bias state is
    /// made at start-up"): the daemon's warning says it with the entry to
    /// add. `None`: an unconfigured sensor is fused with the kind's defaults.
    const NEEDS_ENTRY: Option<&'static str> = None;

    /// How a configuration whose auxiliary states do not fit may bring fewer
    /// of this kind's (`""`: it brings none, or cannot).
    const FEWER_AUX: &'static str = "";

    /// The check this kind makes of the whole configuration (`sensors`: every
    /// configured stream, of every kind), beyond each sensor's own table: an
    /// error names the sensor and says why. None by default.
    fn check_sensors(_sensors: &[MountedSensor]) -> Result<(), ConfigError> {
        Ok(())
    }
}

/// How model `M` fuses a sample of this kind. The state has already been
/// propagated to the sample's time; `M::Correction` is what a model needs to know
/// of the update afterwards (the `ins` model: the error injected, for its smoother).
///
/// A kind implements it for what a model can do: the position fix, the
/// geodetic fix and the velocity for every [`Kinematic`] model (a position and
/// a velocity in the world frame), the IMU for a model that holds it, the kinds
/// that need an attitude, a body frame or an auxiliary state for the INS error
/// state (`InsModel<D>`). A model fuses the kinds it lists with
/// [`fuses!`](crate::fuses) and refuses every other ([`Fusion`]), or fuses every
/// kind ([`EveryKind`]).
pub trait Fuse<M: Model> {
    /// Fuses the sample into `state`.
    fn fuse(&self, model: &M, state: &mut M::State) -> (StepOutcome, M::Correction);
}

/// A measurement's observation of the INS error state at a state: the
/// residual `y = z ⊖ h(x)` (`⊖` a difference, or the rotation between two
/// attitudes, or an angle wrapped), `H = ∂h/∂δx` (so `∂y/∂δx = −H` to first
/// order) and the noise covariance `R`, `M` components.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation<const M: usize, const D: usize> {
    /// The residual.
    pub y: SVector<f64, M>,
    /// Its Jacobian, with the sign of `h`'s.
    pub H: SMatrix<f64, M, D>,
    /// The noise covariance.
    pub R: SMatrix<f64, M, M>,
}

/// What a sample of a kind observes of the state of model `Mdl` (`M` its
/// [`WireSample::INNOVATION_DIM`], `D` the model's error-state dimension): the
/// observation its fusion into that model updates with, from the same
/// functions, for each model that fuses it through a residual. `None` where
/// the fusion does not update with the sample: the IMU (it drives the
/// propagation), a sample that sets a state from its value (a barometer's
/// first, a pose setting its map frame), an attitude for roll and pitch only
/// (`attitude::tilt`). Tests over the kind list check every `H` against
/// central differences of its `y`, for each model.
pub trait Observe<Mdl: Model, const M: usize, const D: usize> {
    /// The observation of this sample at state `s` of `model`.
    fn observe(&self, model: &Mdl, s: &Mdl::State) -> Option<Observation<M, D>>;
}

/// Implements [`Fusion`] for a model: the kinds listed (their
/// [`fusion_shared::SampleKind`] variants) are fused by their [`Fuse`] impl for
/// the model, every other kind is refused (the default). A configured sensor
/// of a kind the model refuses fails the start-up (its `from_config`), and a
/// sample of an unconfigured one is refused ([`StepOutcome::Refused`]).
///
/// ```text
/// fuses!(LinearModel: Imu, Position, Velocity, Geodetic);
/// ```
///
/// A model that fuses every kind implements [`EveryKind`] instead.
#[macro_export]
macro_rules! fuses {
    ($model:ty: $($variant:ident),+ $(,)?) => {
        #[allow(non_snake_case)]
        impl $crate::measurement::Fusion for $model {
            fn accepts(kind: fusion_shared::SampleKind) -> bool {
                matches!(kind, $(fusion_shared::SampleKind::$variant)|+)
            }
            $(
                #[inline]
                fn $variant(
                    &self,
                    state: &mut <Self as $crate::model::Model>::State,
                    sample: &$crate::measurement::wire::$variant,
                ) -> ($crate::model::StepOutcome, <Self as $crate::model::Model>::Correction) {
                    $crate::measurement::Fuse::<Self>::fuse(sample, self, state)
                }
            )+
        }
    };
}

pub use crate::model::Kinematic;

/// A model that fuses or refuses every sample kind: what the engine runs. One
/// step propagates the state to the sample's time ([`Model::propagate_to`]) and
/// fuses the sample through its kind's module ([`fuse`]). Every model with a
/// [`Fusion`] has it.
pub trait Steps: Model {
    /// Whether this model can use `kind` at all ([`Fusion::accepts`]).
    fn accepts(kind: SampleKind) -> bool;

    /// How late `sample`'s stamp is by its sensor's configuration (`[[sensor]]
    /// time_offset_ns`), ns: the sample is valid that much earlier.
    fn time_offset_ns(&self, sample: &Sample) -> i64;

    /// Lets a valid sample about to be processed set what the model's frames
    /// still lack (a geodetic fix: the datum; [`Measurement::admit`]).
    fn admit(&self, sample: &Sample);

    /// Validates a sample as its sensor's settings select it ([`validate`]).
    fn validate(&self, sample: &Sample, limits: &Limits) -> Result<(), Rejection>;

    /// Processes one sample.
    fn step(&self, state: &mut Self::State, sample: &Sample) -> StepOutcome;

    /// [`step`](Self::step), also returning the smoother's record of the step. The
    /// state it leaves is bit for bit the one `step` leaves: a smoother re-runs the
    /// final samples through this after the fact, so the history stays compact.
    fn step_recorded(&self, state: &mut Self::State, sample: &Sample) -> (StepOutcome, Self::Record);
}

/// The settings of sensor `sensor` of kind `T` (`None`: not configured, or
/// without settings: the kind's defaults apply).
#[inline]
pub fn settings<T: Measurement>(frames: &Frames, sensor: u32) -> Option<&T::Settings> {
    frames.settings(T::KIND, sensor)
}

/// The auxiliary states the configured sensors bring to the `ins` model, in
/// `[[sensor]]` order, after `model`'s own ([`aux_priors`]), and the first
/// sensor whose states do not fit, if one does not ([`AuxStates::fits`]).
pub fn aux_states(model: AuxStates, frames: &Frames) -> (AuxStates, Option<&MountedSensor>) {
    let mut first_beyond = None;
    let aux = frames.sensors().iter().fold(model, |aux, m| {
        let aux = aux.with_sensor(m.kind, m.id, &aux_priors(m));
        if !aux.fits() && first_beyond.is_none() {
            first_beyond = Some(m);
        }
        aux
    });
    (aux, first_beyond)
}

/// The kind list as the `[[sensor]]` reading needs it ([`KindCatalog`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Kinds;

/// Generates each kind's module and the dispatch from a [`Sample`] (or a
/// [`SampleKind`]) to it, from `fusion_shared::for_each_sample_kind!`.
macro_rules! registry {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        $(pub mod $module;)*

        impl KindCatalog for Kinds {
            fn rotated(&self, kind: SampleKind) -> bool {
                match kind {
                    $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::ROTATED,)*
                }
            }

            fn table(&self, kind: SampleKind) -> Option<&'static str> {
                match kind {
                    $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::TABLE,)*
                }
            }

            fn settings(
                &self,
                kind: SampleKind,
                table: Option<&toml::Value>,
                key: &dyn Fn(&str) -> String,
            ) -> Result<Settings, ConfigError> {
                Ok(match kind {
                    $(SampleKind::$variant => {
                        <fusion_shared::$ty as Measurement>::settings(table, key)?.map_or_else(Settings::default, Settings::new)
                    })*
                })
            }

            fn observes(&self, kind: SampleKind, settings: &Settings) -> Observes {
                match kind {
                    $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::observes(
                        settings.get::<<fusion_shared::$ty as Measurement>::Settings>(),
                    ),)*
                }
            }

            fn check_sensors(&self, kind: SampleKind, sensors: &[MountedSensor]) -> Result<(), ConfigError> {
                match kind {
                    $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::check_sensors(sensors),)*
                }
            }
        }

        /// Whether `sample` is an exact reading ([`Measurement::exact`]):
        /// fused as any other; the health leaves it out of the NIS test.
        #[inline]
        pub fn exact(sample: &Sample) -> bool {
            match sample {
                $(Sample::$variant(s) => s.exact(),)*
            }
        }

        /// What a run of gated samples of `kind` does ([`Measurement::LOCKOUT`]).
        #[inline]
        pub const fn lockout_rule(kind: SampleKind) -> LockoutRule {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::LOCKOUT,)*
            }
        }

        /// What an unconfigured sensor of `kind` lacks, if its samples are
        /// refused for good ([`Measurement::NEEDS_ENTRY`]).
        pub const fn needs_entry(kind: SampleKind) -> Option<&'static str> {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::NEEDS_ENTRY,)*
            }
        }

        /// How a configuration may bring fewer of `kind`'s auxiliary states
        /// ([`Measurement::FEWER_AUX`]).
        pub const fn fewer_aux(kind: SampleKind) -> &'static str {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::FEWER_AUX,)*
            }
        }

        /// Every kind's settings table as `fusiond print-config` prints it, in
        /// kind order ([`Measurement::TABLE_DOC`]).
        pub fn table_docs() -> String {
            [$(<fusion_shared::$ty as Measurement>::TABLE_DOC),*].concat()
        }

        /// How many of its innovation's components sensor `m` fuses
        /// ([`Measurement::fused_dim`]; its kind's whole dimension without settings).
        pub fn fused_dim(m: &MountedSensor) -> usize {
            match m.kind {
                $(SampleKind::$variant => m
                    .settings
                    .get::<<fusion_shared::$ty as Measurement>::Settings>()
                    .map_or(m.kind.innovation_dim(), <fusion_shared::$ty as Measurement>::fused_dim),)*
            }
        }

        /// The priors of the auxiliary states sensor `m` brings
        /// ([`Measurement::aux_priors`]; none without settings).
        pub fn aux_priors(m: &MountedSensor) -> Vec<AuxPrior> {
            match m.kind {
                $(SampleKind::$variant => m
                    .settings
                    .get::<<fusion_shared::$ty as Measurement>::Settings>()
                    .map_or_else(Vec::new, <fusion_shared::$ty as Measurement>::aux_priors),)*
            }
        }

        /// Processing rank of a kind ([`Measurement::RANK`]).
        pub const fn rank(kind: SampleKind) -> u8 {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::RANK,)*
            }
        }

        /// Default health timeout of a kind ([`Measurement::TIMEOUT_NS`]), ns.
        pub const fn default_timeout_ns(kind: SampleKind) -> u64 {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::TIMEOUT_NS,)*
            }
        }

        /// Whether a kind's samples are another filter's estimate ([`Measurement::FILTERED`]).
        pub const fn filtered(kind: SampleKind) -> bool {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::FILTERED,)*
            }
        }

        /// The group the health waits for a kind of ([`Measurement::NEEDED`]).
        pub const fn needed(kind: SampleKind) -> Option<Needed> {
            match kind {
                $(SampleKind::$variant => <fusion_shared::$ty as Measurement>::NEEDED,)*
            }
        }

        /// Lets a valid sample about to be processed set what the frames lack
        /// ([`Measurement::admit`]).
        pub fn admit(sample: &Sample, frames: &Frames) {
            match sample {
                $(Sample::$variant(s) => s.admit(frames),)*
            }
        }

        /// Validates a sample: its header names the kind of its payload, and the
        /// payload passes its kind's checks as its sensor's settings in
        /// `frames` select it ([`Measurement::validate_as`]).
        pub fn validate(sample: &Sample, limits: &Limits, frames: &Frames) -> Result<(), Rejection> {
            if sample.header().kind != sample.kind() as u32 {
                return Err(Rejection::WrongKind);
            }
            match sample {
                $(Sample::$variant(s) => if <fusion_shared::$ty as Measurement>::VALIDATES_AS_SELECTED {
                    s.validate_as(limits, settings::<fusion_shared::$ty>(frames, s.header.sensor))
                } else {
                    s.validate(limits)
                },)*
            }
        }

        /// Each kind's wire type under its [`SampleKind`] variant's name (what
        /// [`fuses!`] names).
        pub mod wire {
            $(#[doc = concat!("The ", $name, " sample.")] pub type $variant = fusion_shared::$ty;)*
        }

        /// How a model fuses each sample kind: one method per kind (named by its
        /// [`SampleKind`] variant), each refusing by default. A model lists the
        /// kinds it fuses with [`fuses!`], which gives each its kind's [`Fuse`]
        /// impl; a kind needs no line for a model that refuses it.
        #[allow(non_snake_case)]
        pub trait Fusion: Model {
            /// Whether the model can use `kind` at all (none by default).
            fn accepts(_kind: SampleKind) -> bool {
                false
            }
            $(
                #[doc = concat!("Fuses a ", $name, " sample (refused by default).")]
                #[inline]
                fn $variant(&self, _state: &mut Self::State, _sample: &fusion_shared::$ty) -> (StepOutcome, Self::Correction) {
                    (StepOutcome::Refused, Self::Correction::default())
                }
            )*
        }

        /// A model that fuses every kind, each by its [`Fuse`] impl for the
        /// model: its [`Fusion`] follows from the kind list, so a new kind
        /// needs no line for it (only its `Fuse` impl, which this requires).
        pub trait EveryKind: Model + Sized
        where
            $(fusion_shared::$ty: Fuse<Self>,)*
        {
        }

        #[allow(non_snake_case)]
        impl<M: EveryKind> Fusion for M
        where
            $(fusion_shared::$ty: Fuse<M>,)*
        {
            fn accepts(_kind: SampleKind) -> bool {
                true
            }
            $(
                #[inline]
                fn $variant(&self, state: &mut M::State, sample: &fusion_shared::$ty) -> (StepOutcome, M::Correction) {
                    sample.fuse(self, state)
                }
            )*
        }

        impl<M: Fusion> Steps for M {
            fn accepts(kind: SampleKind) -> bool {
                <M as Fusion>::accepts(kind)
            }

            #[inline]
            fn time_offset_ns(&self, sample: &Sample) -> i64 {
                self.frames().time_offset_ns(sample.kind(), sample.header().sensor)
            }

            #[inline]
            fn admit(&self, sample: &Sample) {
                admit(sample, self.frames())
            }

            #[inline]
            fn validate(&self, sample: &Sample, limits: &Limits) -> Result<(), Rejection> {
                validate(sample, limits, self.frames())
            }

            fn step(&self, state: &mut M::State, sample: &Sample) -> StepOutcome {
                self.propagate_to(state, sample.t_ns(), None);
                fuse(sample, self, state).0
            }

            fn step_recorded(&self, state: &mut M::State, sample: &Sample) -> (StepOutcome, M::Record) {
                let mut log = M::begin_record(state);
                self.propagate_to(state, sample.t_ns(), Some(&mut log));
                let (outcome, correction) = fuse(sample, self, state);
                (outcome, M::finish_record(log, state, correction))
            }
        }

        /// Checks each kind's observation ([`Observe`], the kind's
        /// [`WireSample::INNOVATION_DIM`] components), in kind order.
        #[cfg(test)]
        fn each_observation(check: &mut observations::Checker) {
            $(check.kind::<fusion_shared::$ty, { <fusion_shared::$ty as WireSample>::INNOVATION_DIM }>($name);)*
        }

        /// Fuses a sample into a state of model `M` (propagated to its time already).
        pub fn fuse<M: Fusion>(sample: &Sample, model: &M, state: &mut M::State) -> (StepOutcome, M::Correction) {
            let kind = sample.kind();
            model.fuse_kind(state, kind, lockout_rule(kind), sample.t_ns(), |model, state| match sample {
                $(Sample::$variant(s) => model.$variant(state, s),)*
            })
        }
    };
}

fusion_shared::for_each_sample_kind!(registry);

/// The largest innovation dimension of any kind (the health's NIS bands).
pub const MAX_INNOVATION_DIM: usize = 6;

const _: () = {
    let mut i = 0;
    while i < SampleKind::COUNT {
        assert!(SampleKind::ALL[i].innovation_dim() <= MAX_INNOVATION_DIM);
        i += 1;
    }
};

#[cfg(test)]
mod tests {
    use fusion_shared::PositionSample;

    use super::*;

    #[test]
    fn imu_goes_first_at_equal_time_and_the_header_must_name_the_payload() {
        for &k in SampleKind::ALL {
            assert!(k == SampleKind::Imu || rank(k) > rank(SampleKind::Imu));
        }
        let mut p = PositionSample::new(5, 0, 0, [0.0; 3], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let frames = Frames::new(None);
        assert_eq!(validate(&Sample::Position(p), &limits, &frames), Ok(()));
        p.header.kind = SampleKind::Imu as u32;
        assert_eq!(validate(&Sample::Position(p), &limits, &frames), Err(Rejection::WrongKind));
        p.header.kind = 0;
        assert_eq!(validate(&Sample::Position(p), &limits, &frames), Err(Rejection::WrongKind));
    }
}
