//! Process and measurement models: what a sample does to the filter.
//!
//! - [`linear`]: constant velocity driven by world-frame acceleration (6 states).
//! - [`ins`]: error-state INS for real IMUs (16 nominal, 15 error states).
//!
//! A model owns its filter state type; the engine only stores, copies and replays
//! it, so a model may keep anything it needs for time handling (the filter time,
//! held IMU values) inside that state. A model names no sample kind: it
//! propagates to a time ([`Model::propagate_to`]) and says what it can do for
//! the kinds ([`Kinematic`]: fuse a world position or velocity); each kind's
//! module above it fuses its samples into the model's state, and
//! `measurement::Steps` composes the two into one step. What a model does by
//! kind it takes from the kinds' declarations: what each sensor observes
//! ([`crate::frames::Observes`], for the `ins` model's yaw rule and gravity
//! reference), each kind's lock-out rule ([`lockout::LockoutRule`]), what each
//! kind keeps between samples (`fusion_shared::sample::KindsProgress`, in
//! [`ins::aux`]).

pub mod held_imu;
pub mod ins;
pub mod linear;
pub mod lockout;

/// The time rule every model follows: the filter starts at the time of the first
/// sample it processes (no propagation before it); after that, a sample newer than
/// the filter time is reached by propagating over `dt = (t − t_filter)·1e-9` s,
/// returned here, and an equal time needs none. Moves `t_filter` on to `t`.
pub fn advance_time(t_filter: &mut Option<u64>, t: u64) -> Option<f64> {
    match *t_filter {
        None => {
            *t_filter = Some(t);
            None
        }
        Some(tf) if t > tf => {
            *t_filter = Some(t);
            Some((t - tf) as f64 * 1e-9)
        }
        Some(_) => None,
    }
}

/// What processing one sample did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepOutcome {
    /// An IMU sample: the state was propagated to its time and its values held;
    /// or a measurement that set a reference state from its value (a
    /// barometer's bias, a pose sensor's map frame: [`crate::model::ins::aux`])
    /// and fused nothing else.
    Propagated,
    /// A measurement fused, with its NIS.
    Fused {
        /// Normalised innovation squared.
        nis: f64,
    },
    /// A measurement refused by the gate, with its NIS; state only propagated.
    Gated {
        /// Normalised innovation squared.
        nis: f64,
    },
    /// The filter refused the step (e.g. S not positive definite); state unchanged
    /// apart from the propagation to the sample time.
    Refused,
}

impl StepOutcome {
    /// NIS of a measurement update, if one was computed.
    pub fn nis(&self) -> Option<f64> {
        match self {
            StepOutcome::Fused { nis } | StepOutcome::Gated { nis } => Some(*nis),
            _ => None,
        }
    }

    /// For a measurement: was it fused? `None` for an IMU sample.
    pub fn accepted(&self) -> Option<bool> {
        match self {
            StepOutcome::Propagated => None,
            StepOutcome::Fused { .. } => Some(true),
            StepOutcome::Gated { .. } | StepOutcome::Refused => Some(false),
        }
    }
}

/// What a model tells of its state besides the estimate: the counts and
/// estimates the health, the snapshot and the replay summary report. A model
/// without one of them leaves it at its default.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Diagnostics {
    /// Times the filter re-initialised itself up to this state: from the fixes
    /// after a lock-out, or the states a gated kind observes
    /// ([`crate::model::lockout`]).
    pub reinitialisations: u64,
    /// Whether the vehicle stands still at this state (the model's standstill
    /// detection, if it has one).
    pub standing: bool,
    /// The standstill updates fused up to this state.
    pub standstill_updates: u64,
    /// The gravity reference's updates fused up to this state (`ins`:
    /// [`ins::gravity`]).
    pub gravity_updates: u64,
    /// How late the velocity sensors' stamps look beyond their configured
    /// offset, from the residuals up to this state: `(τ̂, σ_τ, samples)`, s
    /// (`ins`: [`ins::clock`]); `None` where the model has no estimate.
    pub velocity_time_offset: Option<(f64, f64, u64)>,
}

/// A process and measurement model the engine can run.
pub trait Model {
    /// The complete filter state at one point of the sample stream: estimate,
    /// covariance, filter time and held inputs. Copied into the history.
    type State: Copy;
    /// What the smoother needs of one step.
    type Record: Copy;
    /// What a measurement update leaves the model to know (the `ins` model: the
    /// error injected, for its smoother).
    type Correction: Copy + Default;
    /// The smoother's record of a step while the step runs.
    type Log;

    /// Code in snapshots, and through it the name in the config: the model's
    /// line of [`fusion_shared::for_each_model!`] (checked where the config layer
    /// maps names to model types).
    const CODE: u32;

    /// Whether the estimate means nothing before an absolute position (the
    /// `linear` model: it has no other source). A model that dead-reckons from
    /// the IMU (`ins`, a robot with wheels and no GNSS) reads `ok` without
    /// one: its σ tells how good the position is.
    const NEEDS_POSITION: bool = true;

    /// The state before the first sample.
    fn initial_state(&self) -> Self::State;

    /// The frames its measurements may be given in (the datum of geodetic fixes).
    fn frames(&self) -> &crate::frames::Frames;

    /// Propagates `state` to `t_ns` by the time rule of [`advance_time`] (nothing
    /// for the first sample or an equal time), noting the transition in `log` when
    /// a record of the step is kept.
    fn propagate_to(&self, state: &mut Self::State, t_ns: u64, log: Option<&mut Self::Log>);

    /// Starts the record of a step at the state before it.
    fn begin_record(state: &Self::State) -> Self::Log;

    /// Ends the record of a step at the state after it, given what its
    /// measurement update left ([`Correction`](Self::Correction)).
    fn finish_record(log: Self::Log, state: &Self::State, correction: Self::Correction) -> Self::Record;

    /// Fuses a measurement of `kind` at `t_ns` by `fuse` (the kind's fusion
    /// into this model), under the kind's lock-out rule: a model that keeps
    /// account of each kind's outcomes (the `ins` model: its lock-out runs,
    /// [`lockout::KindRuns`]) wraps it.
    #[inline]
    fn fuse_kind(
        &self,
        state: &mut Self::State,
        _kind: fusion_shared::SampleKind,
        _lockout: lockout::LockoutRule,
        _t_ns: u64,
        fuse: impl FnOnce(&Self, &mut Self::State) -> (StepOutcome, Self::Correction),
    ) -> (StepOutcome, Self::Correction) {
        fuse(self, state)
    }

    /// What the model tells of `state` besides the estimate ([`Diagnostics`]).
    fn diagnostics(_state: &Self::State) -> Diagnostics {
        Diagnostics::default()
    }

    /// Filter time, ns, or `None` before the first sample.
    fn time_ns(state: &Self::State) -> Option<u64>;

    /// The IMU values `state` holds, if the model holds IMU samples between
    /// its steps (both models do): what the IMU instants are read from
    /// ([`held_imu::Instants`]). `None` by default: no instants.
    fn held_imu(_state: &Self::State) -> Option<&held_imu::HeldImu> {
        None
    }

    /// Whether the model has a usable estimate in this state (e.g. an INS has
    /// finished its alignment). The health says "initialising" until it has.
    fn initialised(_state: &Self::State) -> bool {
        true
    }

    /// The state vector `x` as published.
    fn x(state: &Self::State) -> &[f64];

    /// Side of the published covariance (the error-state dimension).
    const COV_DIM: usize;

    /// The auxiliary states after the model's own layout in `state`, as bits
    /// of [`fusion_shared::snapshot::aux`] (0: none).
    fn aux_states(_state: &Self::State) -> u32 {
        0
    }

    /// Writes the covariance as published, row-major (it is symmetric), into
    /// `out` (`COV_DIM²` entries). In the UDU form it is composed from the factors.
    fn write_covariance(state: &Self::State, out: &mut [f64]);

    /// The covariance as published, row-major, in a new vector (for tools and
    /// tests; the live loop writes it in place with
    /// [`write_covariance`](Self::write_covariance)).
    fn covariance(state: &Self::State) -> Vec<f64> {
        let mut out = vec![0.0; Self::COV_DIM * Self::COV_DIM];
        Self::write_covariance(state, &mut out);
        out
    }

    /// Smooths a complete run of records in place (RTS). Returns the records
    /// the smoothing could not pass back from the next one (see
    /// [`rts_smooth`](crate::filter::rts_smooth)): each keeps its filtered
    /// estimate, and the stretches on either side are smoothed apart.
    fn smooth(records: &mut [Self::Record]) -> Vec<usize>;

    /// `(x, P)` of a record (after smoothing: the smoothed estimate).
    fn record_output(record: &Self::Record) -> (&[f64], &[f64]);
}

/// A model with a position and a velocity in the world frame (ENU about the
/// datum): the position fix, the geodetic fix and the velocity measurement
/// are implemented for it (`measurement::{position, geodetic, velocity}`), each
/// fused as the model says (`linear`: the state blocks selected; `ins`: of the
/// point at the sensor's lever arm).
#[allow(non_snake_case)]
pub trait Kinematic: Model {
    /// Fuses `z = p + n`, `n ~ N(0, R)`: the position of the sensor `sensor` of
    /// `kind` (m, world frame).
    fn fuse_position(
        &self,
        state: &mut Self::State,
        kind: fusion_shared::SampleKind,
        sensor: u32,
        z: &nalgebra::Vector3<f64>,
        R: &nalgebra::Matrix3<f64>,
    ) -> (StepOutcome, Self::Correction);

    /// Fuses `z = v + n`, `n ~ N(0, R)`: the velocity of velocity sensor
    /// `sensor` (m/s, world frame) at `t_ns`.
    fn fuse_velocity(
        &self,
        state: &mut Self::State,
        sensor: u32,
        t_ns: u64,
        z: &nalgebra::Vector3<f64>,
        R: &nalgebra::Matrix3<f64>,
    ) -> (StepOutcome, Self::Correction);
}
