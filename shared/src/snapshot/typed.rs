//! Typed reading of a [`StateSnapshot`]: the estimate by name, health and codes
//! as enums.
//!
//! The layout of each model is in [`StateSnapshot`]'s documentation.

use super::{MAX_COV, MAX_STATE, StateSnapshot, aux, health, outcome};
use crate::SampleKind;

/// Generates [`Model`] from [`for_each_model!`](crate::for_each_model).
macro_rules! models {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident, $params:ident, $cov:literal, [$($layout:expr),* $(,)?];)*) => {
        /// The filter model that produced a snapshot ([`StateSnapshot::model`] code).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Model {
            $($(#[$doc])* $variant,)*
        }

        impl Model {
            /// Every model, in code order.
            pub const ALL: &'static [Model] = &[$(Model::$variant),*];

            /// The model of a wire code ([`model`](crate::snapshot::model)), if it is one.
            pub const fn from_code(code: u32) -> Option<Self> {
                match code {
                    $($code => Some(Self::$variant),)*
                    _ => None,
                }
            }

            /// Its wire code.
            pub const fn code(self) -> u32 {
                match self {
                    $(Self::$variant => $code,)*
                }
            }

            /// Its name, as in the config's `[model] kind`.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name,)*
                }
            }

            /// Every entry of its state vector: name (with unit) and the index of its
            /// standard deviation in the covariance (`None` for the quaternion, whose
            /// uncertainty is the 3 attitude errors).
            pub const fn state_layout(self) -> &'static [(&'static str, Option<usize>)] {
                match self {
                    $(Self::$variant => &[$($layout),*],)*
                }
            }

            /// Side of its covariance.
            pub const fn cov_dim(self) -> usize {
                match self {
                    $(Self::$variant => $cov,)*
                }
            }
        }
    };
}

crate::for_each_model!(models);

impl Model {
    /// Entries of its state vector.
    pub const fn state_len(self) -> usize {
        self.state_layout().len()
    }
}

impl std::fmt::Display for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The health of the estimate ([`StateSnapshot::health`] code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Health {
    /// Not yet a usable estimate: waiting for samples of every kind, or aligning.
    Initialising,
    /// Every stream is fresh and the filter is consistent.
    Ok,
    /// An estimate exists but something is wrong: see
    /// [`StateSnapshot::health_reasons`].
    Degraded,
    /// A code this version does not know (never sent by a fusiond of the same
    /// wire version: the snapshot's memory is not what fusiond wrote).
    Unknown(u32),
}

impl Health {
    /// The health of a wire code ([`health`]).
    pub const fn from_code(code: u32) -> Self {
        match code {
            health::INITIALISING => Self::Initialising,
            health::OK => Self::Ok,
            health::DEGRADED => Self::Degraded,
            other => Self::Unknown(other),
        }
    }

    /// Its name: `initialising`, `ok`, `degraded` or `unknown`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Initialising => health::name(health::INITIALISING),
            Self::Ok => health::name(health::OK),
            Self::Degraded => health::name(health::DEGRADED),
            Self::Unknown(_) => "unknown",
        }
    }
}

impl std::fmt::Display for Health {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why the health is [`Health::Degraded`]: one bit of
/// [`StateSnapshot::health_reasons`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HealthReason {
    /// The NIS of a sensor's recent measurements is persistently outside its χ²
    /// band ([`health::NIS_OUT_OF_BOUNDS`]).
    NisOutOfBounds,
    /// Samples were lost ([`health::SAMPLES_LOST`]).
    SamplesLost,
    /// The filter re-initialised itself after a lock-out recently
    /// ([`health::REINITIALISED`]).
    Reinitialised,
    /// No sample of this kind for longer than its timeout ([`health::stale`]);
    /// [`StateSnapshot::stale_sensor_counters`] says which sensor.
    Stale(SampleKind),
}

impl HealthReason {
    /// Its bit in [`StateSnapshot::health_reasons`].
    pub const fn bit(self) -> u32 {
        match self {
            Self::NisOutOfBounds => health::NIS_OUT_OF_BOUNDS,
            Self::SamplesLost => health::SAMPLES_LOST,
            Self::Reinitialised => health::REINITIALISED,
            Self::Stale(kind) => health::stale(kind),
        }
    }

    /// Its name, as `fusionctl state` prints it (`samples lost`, `imu stale`, …).
    pub const fn name(self) -> &'static str {
        match self {
            Self::NisOutOfBounds => health::GENERAL_REASONS[0].1,
            Self::SamplesLost => health::GENERAL_REASONS[1].1,
            Self::Reinitialised => health::GENERAL_REASONS[2].1,
            Self::Stale(kind) => kind.stale_reason(),
        }
    }

    /// Every reason set in the bits `reasons`: the general ones, then the stale
    /// kinds in kind order. Bits no reason has are skipped.
    pub fn decode(reasons: u32) -> impl Iterator<Item = HealthReason> + use<> {
        let general = [Self::NisOutOfBounds, Self::SamplesLost, Self::Reinitialised].into_iter();
        let stale = SampleKind::ALL.iter().map(|k| Self::Stale(*k));
        general.chain(stale).filter(move |r| reasons & r.bit() != 0)
    }
}

impl std::fmt::Display for HealthReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What processing the newest sample did ([`StateSnapshot::outcome`] code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outcome {
    /// An IMU sample: propagated the state and is held for the next step.
    Propagated,
    /// A measurement, fused.
    Fused,
    /// A measurement the χ² gate refused.
    Gated,
    /// A measurement the filter refused (innovation covariance not positive definite).
    Refused,
}

impl Outcome {
    /// The outcome of a wire code ([`outcome`]), if it is one.
    pub const fn from_code(code: u32) -> Option<Self> {
        match code {
            outcome::PROPAGATED => Some(Self::Propagated),
            outcome::FUSED => Some(Self::Fused),
            outcome::GATED => Some(Self::Gated),
            outcome::REFUSED => Some(Self::Refused),
            _ => None,
        }
    }
}

/// Index of the attitude error δθ in the ins covariance.
const ATTITUDE_ERROR: usize = 6;

/// The typed accessors. They know the layout of each model (see [`StateSnapshot`]),
/// so that `std_devs()[i]`, which lines up with `state()[i]` only for `i < 6` in
/// the ins model, need not be indexed by hand.
///
/// ```
/// use fusion_shared::StateSnapshot;
/// use fusion_shared::snapshot::{Health, HealthReason, Model, Outcome, model, health, outcome};
/// use fusion_shared::SampleKind;
///
/// // What fusiond publishes for the ins model (built by hand here).
/// let mut s = StateSnapshot { model: model::INS, state_len: 16, cov_dim: 15, ..Default::default() };
/// let half = std::f64::consts::FRAC_PI_8; // a yaw of 45°: q = [cos 22.5°, 0, 0, sin 22.5°]
/// s.x[..16].copy_from_slice(&[
///     1.0, 2.0, 3.0, 10.0, 0.5, 0.0, half.cos(), 0.0, 0.0, half.sin(), 0.01, 0.0, 0.0, 0.0, 0.0, 1e-4,
/// ]);
/// for (i, var) in [0.25, 0.25, 1.0, 0.01, 0.01, 0.04, 1e-4, 1e-4, 4e-4, 1e-6, 1e-6, 1e-6, 1e-8, 1e-8, 1e-8]
///     .into_iter()
///     .enumerate()
/// {
///     s.cov[i * 15 + i] = var;
/// }
/// s.health = health::DEGRADED;
/// s.health_reasons = health::SAMPLES_LOST | health::stale(SampleKind::Geodetic);
/// s.input_kind = SampleKind::Imu as u32;
/// s.sample_kind = SampleKind::Imu as u32;
/// s.outcome = outcome::PROPAGATED;
///
/// assert_eq!(s.model(), Some(Model::Ins));
/// assert_eq!(s.position(), Some([1.0, 2.0, 3.0]));
/// assert_eq!(s.velocity(), Some([10.0, 0.5, 0.0]));
/// assert_eq!(s.attitude(), Some([half.cos(), 0.0, 0.0, half.sin()]));
/// let [roll, pitch, yaw] = s.roll_pitch_yaw().unwrap(); // rad
/// assert!(roll.abs() < 1e-12 && pitch.abs() < 1e-12 && (yaw.to_degrees() - 45.0).abs() < 1e-9);
/// assert_eq!(s.accel_bias(), Some([0.01, 0.0, 0.0]));
/// assert_eq!(s.gyro_bias(), Some([0.0, 0.0, 1e-4]));
/// let close = |a: Option<[f64; 3]>, b: [f64; 3]| a.unwrap().iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-12);
/// assert!(close(s.position_std(), [0.5, 0.5, 1.0]));
/// assert!(close(s.velocity_std(), [0.1, 0.1, 0.2]));
/// assert!(close(s.attitude_std(), [0.01, 0.01, 0.02])); // rad, about the body axes
/// assert!(close(s.roll_pitch_yaw_std(), [0.01, 0.01, 0.02])); // level: the same
/// assert!(close(s.accel_bias_std(), [1e-3; 3]));
/// assert!(close(s.gyro_bias_std(), [1e-4; 3]));
/// assert_eq!(s.health(), Health::Degraded);
/// let reasons: Vec<HealthReason> = s.health_reasons().collect();
/// assert_eq!(reasons, [HealthReason::SamplesLost, HealthReason::Stale(SampleKind::Geodetic)]);
/// assert_eq!(reasons[1].to_string(), "geodetic stale");
/// assert_eq!(s.input_kind(), Some(SampleKind::Imu));
/// assert_eq!(s.sample_kind(), Some(SampleKind::Imu));
/// assert_eq!(s.outcome(), Some(Outcome::Propagated));
/// ```
impl StateSnapshot {
    /// The model that produced the estimate; `None` for a code this version
    /// does not know (and on a default, never published snapshot).
    pub const fn model(&self) -> Option<Model> {
        Model::from_code(self.model)
    }

    /// Entries `at..at + 3` of the state, if the model is known and has them.
    fn state3(&self, at: usize) -> Option<[f64; 3]> {
        self.model()?;
        self.state().get(at..at + 3)?.try_into().ok()
    }

    /// Standard deviations of covariance entries `at..at + 3`.
    fn std3(&self, at: usize) -> Option<[f64; 3]> {
        self.model()?;
        let n = self.cov_dim as usize;
        if at + 3 > n || n > super::MAX_COV {
            return None;
        }
        Some(std::array::from_fn(|i| self.cov[(at + i) * n + at + i].max(0.0).sqrt()))
    }

    /// Only for the ins model.
    fn ins(&self) -> Option<()> {
        (self.model() == Some(Model::Ins)).then_some(())
    }

    /// Position, m, world frame (ENU about the datum): `x[0..3]` in every model.
    /// For latitude, longitude and height see [`position_geodetic`](Self::position_geodetic).
    pub fn position(&self) -> Option<[f64; 3]> {
        self.state3(0)
    }

    /// Velocity, m/s, world frame (ENU): `x[3..6]` in every model.
    pub fn velocity(&self) -> Option<[f64; 3]> {
        self.state3(3)
    }

    /// Attitude as the unit quaternion `[w, x, y, z]` that rotates the body frame
    /// (forward-left-up) into the world frame (ENU): `x[6..10]`, ins model only.
    pub fn attitude(&self) -> Option<[f64; 4]> {
        self.ins()?;
        self.state().get(6..10)?.try_into().ok()
    }

    /// Attitude as roll, pitch and yaw, rad: the rotation body → world is
    /// `R = Rz(yaw) Ry(pitch) Rx(roll)` (the ZYX sequence, on ENU and
    /// forward-left-up axes). Yaw is
    /// the angle of the body's forward axis from east, counter-clockwise (a
    /// compass heading is 90° − yaw); roll is positive with the right side down,
    /// pitch positive nose down (rotations about forward and left). Ins model only.
    pub fn roll_pitch_yaw(&self) -> Option<[f64; 3]> {
        let [w, x, y, z] = self.attitude()?;
        let norm = (w * w + x * x + y * y + z * z).sqrt();
        if norm.is_nan() || norm <= 0.0 {
            return None;
        }
        let [w, x, y, z] = [w, x, y, z].map(|c| c / norm);
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        Some([roll, pitch, yaw])
    }

    /// Accelerometer bias, m/s², body frame: `x[10..13]`, ins model only.
    pub fn accel_bias(&self) -> Option<[f64; 3]> {
        self.ins()?;
        self.state3(10)
    }

    /// Gyroscope bias, rad/s, body frame: `x[13..16]`, ins model only.
    pub fn gyro_bias(&self) -> Option<[f64; 3]> {
        self.ins()?;
        self.state3(13)
    }

    /// Standard deviation of each position component, m.
    pub fn position_std(&self) -> Option<[f64; 3]> {
        self.std3(0)
    }

    /// Standard deviation of each velocity component, m/s.
    pub fn velocity_std(&self) -> Option<[f64; 3]> {
        self.std3(3)
    }

    /// Standard deviation of the attitude error about each body axis (forward,
    /// left, up), rad: the error state δθ, ins model only.
    pub fn attitude_std(&self) -> Option<[f64; 3]> {
        self.ins()?;
        self.std3(ATTITUDE_ERROR)
    }

    /// Standard deviation of roll, pitch and yaw, rad, ins model only: the
    /// attitude error covariance `Σ_θ` mapped through the Euler-angle rates,
    /// `Σ_rpy = E Σ_θ Eᵀ`, `E = [[1, sφ tθ, cφ tθ], [0, cφ, −sφ], [0, sφ/cθ, cφ/cθ]]`
    /// (φ roll, θ pitch): the rates of ZYX Euler angles under a body-frame
    /// rotation, which a local error `Exp(δθ)` is. Infinite at pitch ±90°, where
    /// roll and yaw are not defined.
    pub fn roll_pitch_yaw_std(&self) -> Option<[f64; 3]> {
        let [roll, pitch, _] = self.roll_pitch_yaw()?;
        self.attitude_std()?;
        let n = self.cov_dim as usize;
        let sigma = |i: usize, j: usize| self.cov[(ATTITUDE_ERROR + i) * n + ATTITUDE_ERROR + j];
        let (sr, cr, tp, cp) = (roll.sin(), roll.cos(), pitch.tan(), pitch.cos());
        let e = [[1.0, sr * tp, cr * tp], [0.0, cr, -sr], [0.0, sr / cp, cr / cp]];
        Some(std::array::from_fn(|r| {
            let mut var = 0.0;
            for i in 0..3 {
                for j in 0..3 {
                    var += e[r][i] * sigma(i, j) * e[r][j];
                }
            }
            var.max(0.0).sqrt()
        }))
    }

    /// Standard deviation of each accelerometer bias component, m/s², ins model only.
    pub fn accel_bias_std(&self) -> Option<[f64; 3]> {
        self.ins()?;
        self.std3(9)
    }

    /// Standard deviation of each gyroscope bias component, rad/s, ins model only.
    pub fn gyro_bias_std(&self) -> Option<[f64; 3]> {
        self.ins()?;
        self.std3(12)
    }

    /// Every entry of the state vector in use: the model's
    /// ([`Model::state_layout`]), then the auxiliary states of
    /// [`aux_states`](Self::aux_states) in bit order, each with the index of its
    /// standard deviation in the covariance. Empty for an unknown model or when
    /// the lengths disagree with the layout (the memory is not what fusiond wrote).
    pub fn state_layout(&self) -> impl Iterator<Item = (&'static str, Option<usize>)> + use<> {
        let model = self.model().filter(|_| self.aux_layout_fits());
        let own = model.map_or(&[][..], |m| m.state_layout()).iter().copied();
        let cov0 = model.map_or(0, |m| m.cov_dim());
        let bits = if model.is_some() { self.aux_states } else { 0 };
        let extra = aux::ALL.iter().filter(move |(bit, _)| bits & bit != 0).enumerate();
        own.chain(extra.map(move |(i, (_, name))| (*name, Some(cov0 + i))))
    }

    /// Whether `state_len` and `cov_dim` are the model's plus one per auxiliary state.
    fn aux_layout_fits(&self) -> bool {
        let Some(m) = self.model() else { return false };
        let extra = (self.aux_states & aux::ALL.iter().fold(0, |a, (bit, _)| a | bit)).count_ones() as usize;
        self.aux_states.count_ones() as usize == extra
            && self.state_len as usize == m.state_len() + extra
            && self.cov_dim as usize == m.cov_dim() + extra
            && self.state_len as usize <= MAX_STATE
            && self.cov_dim as usize <= MAX_COV
    }

    /// The value and standard deviation of auxiliary state `bit`, if the
    /// estimate has it.
    fn aux(&self, bit: u32) -> Option<(f64, f64)> {
        let m = self.model()?;
        if self.aux_states & bit == 0 || !self.aux_layout_fits() {
            return None;
        }
        let rank = (self.aux_states & (bit - 1)).count_ones() as usize;
        let (i, c, n) = (m.state_len() + rank, m.cov_dim() + rank, self.cov_dim as usize);
        Some((self.x[i], self.cov[c * n + c].max(0.0).sqrt()))
    }

    /// The odometry scale factor `k` (odometry speed = `k` × true speed), when
    /// it is estimated (`ins` with `[model.odometry_scale]`).
    pub fn odometry_scale(&self) -> Option<f64> {
        self.aux(aux::ODOMETRY_SCALE).map(|(k, _)| k)
    }

    /// The standard deviation of [`odometry_scale`](Self::odometry_scale).
    pub fn odometry_scale_std(&self) -> Option<f64> {
        self.aux(aux::ODOMETRY_SCALE).map(|(_, sd)| sd)
    }

    /// The barometer's bias `b` (pressure altitude minus height, m) and its
    /// standard deviation (`ins` with a barometer).
    pub fn baro_bias(&self) -> Option<[f64; 2]> {
        self.aux(aux::BARO_BIAS).map(|(b, sd)| [b, sd])
    }

    /// A pose sensor's estimated map frame: yaw (rad), origin east, north, up
    /// (m), then their four standard deviations (`ins` with a pose sensor
    /// whose frame is estimated).
    pub fn pose_frame(&self) -> Option<[f64; 8]> {
        let bits = [aux::POSE_FRAME_YAW, aux::POSE_FRAME_EAST, aux::POSE_FRAME_NORTH, aux::POSE_FRAME_UP];
        let mut out = [0.0; 8];
        for (k, bit) in bits.into_iter().enumerate() {
            (out[k], out[k + 4]) = self.aux(bit)?;
        }
        Some(out)
    }

    /// The health of the estimate (the raw code is the field `health`).
    pub const fn health(&self) -> Health {
        Health::from_code(self.health)
    }

    /// Why the health is degraded: each reason bit of the field `health_reasons`
    /// that is set (general reasons first, then stale kinds in kind order).
    pub fn health_reasons(&self) -> impl Iterator<Item = HealthReason> + use<> {
        HealthReason::decode(self.health_reasons)
    }

    /// The health reasons as text, the NIS reason naming the sensors it is about
    /// (`nis out of bounds: odometry 0`, from the field `nis_sensors`).
    pub fn health_reason_texts(&self) -> Vec<String> {
        let nis: Vec<String> = self
            .nis_sensor_counters()
            .map(|c| format!("{} {}", SampleKind::from_code(c.kind).map_or("none", |k| k.name()), c.sensor))
            .collect();
        self.health_reasons()
            .map(|r| match r {
                HealthReason::NisOutOfBounds if !nis.is_empty() => format!("{}: {}", r.name(), nis.join(", ")),
                r => r.name().to_string(),
            })
            .collect()
    }

    /// The kind of the input sample that triggered this snapshot; `None` on a
    /// snapshot sent because the health changed while no sample arrived
    /// ([`INPUT_NONE`](super::INPUT_NONE)).
    pub const fn input_kind(&self) -> Option<SampleKind> {
        SampleKind::from_code(self.input_kind)
    }

    /// The kind of the newest processed sample, the one the estimate is at.
    pub const fn sample_kind(&self) -> Option<SampleKind> {
        SampleKind::from_code(self.sample_kind)
    }

    /// What processing the newest sample did.
    pub const fn outcome(&self) -> Option<Outcome> {
        Outcome::from_code(self.outcome)
    }
}

#[cfg(test)]
mod tests;
