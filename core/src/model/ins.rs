//! The `ins` model: error-state EKF with strapdown mechanisation, for real IMUs.
//!
//! Solà, "Quaternion kinematics for the error-state Kalman filter" (2017), §5 and
//! §7 (local attitude error); Groves, *Principles of GNSS, Inertial, and
//! Multisensor Integrated Navigation Systems* (2nd ed. 2013), ch. 5 and 14.
//!
//! Nominal state `x` (16, as published):
//!
//! | index | symbol | unit | frame |
//! |---|---|---|---|
//! | 0..3 | p | m | world ENU |
//! | 3..6 | v | m/s | world ENU |
//! | 6..10 | q = [w, x, y, z] | – | rotates body (forward-left-up) into world |
//! | 10..13 | b_a, accelerometer bias | m/s² | body |
//! | 13..16 | b_g, gyroscope bias | rad/s | body |
//! | 16.. | auxiliary states, as configured ([`aux`]) | | |
//!
//! Error state `δx` (15, the covariance): `[δp, δv, δθ, δb_a, δb_g]`, then the
//! auxiliary states' errors (each a random walk, constant in `F`): the
//! odometry scale factor ([`OdometryScale`]), each barometer's bias, a pose
//! sensor's map frame (yaw and origin), declared by their kinds ([`aux`]);
//! with the **local** attitude error `q_true = q ⊗ Exp(δθ)` (δθ in the body
//! frame; Solà §5.3.3). The model is generic over this dimension (`InsModel<15>`
//! to `InsModel<21>`); which auxiliary states it has is a set of
//! [`fusion_shared::snapshot::aux`] bits, in whose order they follow the core.
//!
//! IMU model (Kalibr): `f_m = Rᵀ (a − g) + b_a + n_a`, `ω_m = ω + b_g + n_g`,
//! `ḃ_a = n_aw`, `ḃ_g = n_gw`, `g = [0, 0, −gravity]`, white noises with densities
//! `σ_a` (m/s²/√Hz), `σ_g` (rad/s/√Hz), `σ_aw` (m/s³/√Hz), `σ_gw` (rad/s²/√Hz).
//!
//! Time: on every sample the state is propagated from the filter time to the
//! sample time with the held IMU values (zero-order hold of the last IMU sample);
//! an IMU sample then replaces the held values; a position sample is fused on δp
//! (Joseph form, gated as configured), injected into the nominal state and the
//! error reset. Before the first IMU sample (and during static alignment) the
//! nominal state is held and only the covariance grows.
//!
//! Measurements are fused by their kinds' modules in the layer above (the
//! daemon's `measurement` module), with `InsModel::update_block` for those that
//! observe a 3-vector of the nominal state; the optional land-vehicle motion
//! constraint ([`nonholonomic`]) and standstill detection with its zero-velocity
//! and zero-rate updates ([`standstill`]) are fused after IMU samples. While the
//! vehicle stands the attitude is held: `ω = 0`, no `δθ` noise, no `δθ`–`δb_g`
//! coupling.
//!
//! Discretisation over `dt` with `f = f_m − b_a`, `ω = ω_m − b_g` held (Solà eq. 260, 269–271):
//!
//! ```text
//! p ← p + v dt + ½ (R f + g) dt²      v ← v + (R f + g) dt      q ← q ⊗ Exp(ω dt)
//!
//!       [ I  I dt   ½dt²·(−R[f]×)   ½dt²·(−R)   0          ]
//!       [ 0  I      −R[f]× dt       −R dt       0          ]
//! F  =  [ 0  0      Exp(ω dt)ᵀ       0          −I dt      ]
//!       [ 0  0      0                I           0          ]
//!       [ 0  0      0                0           I          ]
//!
//! Q: δv ← σ_a² dt I,  δp ← σ_a² dt³/3 I,  δp–δv ← σ_a² dt²/2 I   (white acceleration, integrated)
//!    δθ ← σ_g² dt I,  δb_a ← σ_aw² dt I,  δb_g ← σ_gw² dt I
//! ```
//!
//! The `½dt²` terms in the δp row and the exact δp–δv noise coupling go one order
//! beyond Solà's Euler form; the δθ row is exact for a constant rate. What is
//! first order is holding `R` over the interval in the δv row: its error per step
//! is `O(|ω| dt)` relative, so 1 % at 100 Hz for a 1 rad/s turn and 0.05 % at
//! 2 kHz; against the white-noise terms (`σ_a² dt`) this stays far below the
//! noise at every rate from 100 Hz to 2 kHz for vehicle dynamics (|ω| ≲ 1 rad/s),
//! which the consistency tests check at 200 Hz.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

pub mod aux;
pub mod clock;
pub mod course;
mod error_state;
pub mod gravity;
mod inputs;
mod linearised;
pub mod nonholonomic;
pub mod observability;
mod odometry_scale;
mod params;
pub mod record;
mod reinit;
pub mod standstill;
mod state_changes;
mod update;

pub(crate) use error_state::inject_and_reset;
use error_state::{ProcessNoise, inject};

use super::{Model, advance_time};
use crate::filter::{ChiSquareGate, FilterError, KalmanFilter, RtsStep, StepLog, rts_smooth};
use crate::frames::Frames;
use crate::model::held_imu::HeldImu;
use crate::model::lockout::{KindRuns, Lockout, LockoutConfig};
pub use aux::{AuxPrior, AuxStates};
pub use course::CourseAlignment;
pub use gravity::GravityReference;
pub use nonholonomic::Nonholonomic;
pub use odometry_scale::OdometryScale;
pub use params::{AlignmentParams, ImuNoise, InsParams};
pub use record::{InsLog, InsRecord};
pub use standstill::Standstill;

/// Error-state dimension of the core model: `[δp, δv, δθ, δb_a, δb_g]`.
pub const N: usize = 15;
/// Nominal state length of the core model.
pub const NOMINAL: usize = 16;
/// The most auxiliary error states: what a snapshot carries
/// ([`fusion_shared::snapshot::aux::MAX`]); which states a configuration
/// brings, their kinds declare ([`aux`]).
pub const MAX_AUX: usize = fusion_shared::snapshot::aux::MAX;
/// The largest error-state dimension (the core and every auxiliary state).
pub const MAX_N: usize = N + MAX_AUX;
/// Room for the nominal state of any dimension.
const NOMINAL_MAX: usize = MAX_N + 1;

/// The `ins` model: `D` is the error-state dimension, [`N`] for the core
/// states and up to [`MAX_N`] with the auxiliary states ([`aux`]).
#[derive(Debug, Clone)]
pub struct InsModel<const D: usize = N> {
    noise: ImuNoise,
    gravity: f64,
    x0: [f64; NOMINAL_MAX],
    initial: KalmanFilter<f64, D>,
    gate: Option<ChiSquareGate>,
    lockout: Option<LockoutConfig>,
    alignment_samples: u32,
    course: Option<CourseAlignment>,
    nonholonomic: Option<Nonholonomic>,
    standstill: Option<Standstill>,
    /// The gravity reference and its gate, where nothing else keeps the tilt
    /// observable ([`gravity`]).
    gravity_reference: Option<(GravityReference, ChiSquareGate)>,
    /// Nothing configured observes the yaw: the observability constraint is on
    /// ([`observability`]).
    yaw_unobserved: bool,
    aux: AuxStates,
    /// Random-walk variance per second of each auxiliary error state (index
    /// `N + i`).
    aux_noise: [f64; MAX_AUX],
    frames: Frames,
}

/// Filter state of the `ins` model at one point of the stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InsState<const D: usize = N> {
    /// Nominal state [p, v, q_wxyz, b_a, b_g] and the auxiliary states (the
    /// first `D + 1` entries are used).
    nominal: [f64; NOMINAL_MAX],
    /// Error-state filter (its mean is zero between updates).
    kf: KalmanFilter<f64, D>,
    t_ns: Option<u64>,
    /// Held IMU values (specific force, rate; body frame), combined over the IMUs.
    imu: HeldImu,
    /// Static alignment: samples summed so far and their sums.
    aligned: u32,
    sum_f: Vector3<f64>,
    sum_w: Vector3<f64>,
    /// IMU values are held and the alignment (if any) is done.
    ready: bool,
    /// Time of the last motion-constraint update.
    constrained_ns: Option<u64>,
    /// The run of gated fixes ([`crate::model::lockout`]).
    lockout: Lockout,
    /// The runs of gated samples of the other kinds ([`crate::model::lockout::KindRuns`]).
    kind_runs: KindRuns,
    /// Standstill detection ([`standstill`]).
    still: standstill::Detector,
    /// The gravity reference's window ([`gravity`]).
    gravity: gravity::Window,
    /// The velocity sensors' time offset estimate ([`clock`]).
    clock: clock::ClockEstimate,
    /// Which auxiliary states follow the core ([`fusion_shared::snapshot::aux`] bits).
    aux_bits: u32,
    /// Where the auxiliary states that are set from a first measurement stand
    /// ([`aux::AuxProgress`]).
    aux: aux::AuxProgress,
}

impl<const D: usize> InsState<D> {
    /// A state before any sample: nominal state and error-state filter.
    fn new(nominal: [f64; NOMINAL_MAX], kf: KalmanFilter<f64, D>, aux_bits: u32) -> Self {
        const { assert!(D >= N && D <= MAX_N, "the ins error state is the core and up to MAX_AUX more") };
        Self {
            nominal,
            kf,
            t_ns: None,
            imu: HeldImu::EMPTY,
            aligned: 0,
            sum_f: Vector3::zeros(),
            sum_w: Vector3::zeros(),
            ready: false,
            constrained_ns: None,
            lockout: Lockout::default(),
            kind_runs: KindRuns::default(),
            still: standstill::Detector::default(),
            gravity: gravity::Window::default(),
            clock: clock::ClockEstimate::default(),
            aux_bits,
            aux: aux::AuxProgress::default(),
        }
    }

    /// The error-state index of auxiliary state `bit` ([`aux::index`]), if the
    /// state has it; its nominal index is one more.
    #[inline]
    pub fn aux_index(&self, bit: u32) -> Option<usize> {
        aux::index(self.aux_bits, bit)
    }

    /// Where the auxiliary states set from a sample stand (the barometer's
    /// bias set, the pose frame's alignments).
    pub fn aux_progress(&self) -> &aux::AuxProgress {
        &self.aux
    }

    /// The nominal value of auxiliary error state `i` (`i ≥ N`).
    #[inline]
    pub(crate) fn aux_value(&self, i: usize) -> f64 {
        self.nominal[i + 1]
    }

    /// Position, m.
    pub fn p(&self) -> Vector3<f64> {
        Vector3::new(self.nominal[0], self.nominal[1], self.nominal[2])
    }
    /// Velocity, m/s.
    pub fn v(&self) -> Vector3<f64> {
        Vector3::new(self.nominal[3], self.nominal[4], self.nominal[5])
    }
    /// Attitude.
    pub fn q(&self) -> UnitQuaternion<f64> {
        let n = &self.nominal;
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(n[6], n[7], n[8], n[9]))
    }
    /// Accelerometer bias, m/s².
    pub fn b_a(&self) -> Vector3<f64> {
        Vector3::new(self.nominal[10], self.nominal[11], self.nominal[12])
    }
    /// Gyroscope bias, rad/s.
    pub fn b_g(&self) -> Vector3<f64> {
        Vector3::new(self.nominal[13], self.nominal[14], self.nominal[15])
    }
    /// The odometry scale factor `k` (odometry speed = `k` × true speed), if
    /// it is estimated.
    pub fn odometry_scale(&self) -> Option<f64> {
        self.aux_index(fusion_shared::snapshot::aux::ODOMETRY_SCALE).map(|i| self.aux_value(i))
    }
    /// The error-state filter.
    pub fn filter(&self) -> &KalmanFilter<f64, D> {
        &self.kf
    }

    /// The error-state filter, to set up a test's state.
    #[cfg(test)]
    pub(crate) fn filter_mut(&mut self) -> &mut KalmanFilter<f64, D> {
        &mut self.kf
    }

    /// Whether IMU values are held and the static alignment (if any) is done.
    #[inline]
    pub fn ready(&self) -> bool {
        self.ready
    }

    /// The IMU values held (specific force, rate; body frame), combined over
    /// the IMUs.
    #[inline]
    pub fn held_imu(&self) -> &HeldImu {
        &self.imu
    }

    /// [`aux_progress`](Self::aux_progress), to set up a test's state.
    #[cfg(test)]
    pub(crate) fn aux_progress_mut(&mut self) -> &mut aux::AuxProgress {
        &mut self.aux
    }

    /// Resets the attitude to `q`, its error covariance to `block`, uncorrelated
    /// with the other states (an attitude set from a measurement of it:
    /// [`InsModel::reset_attitude`]).
    fn reset_attitude(&mut self, q: UnitQuaternion<f64>, block: &Matrix3<f64>) {
        let (p, v, b_a, b_g) = (self.p(), self.v(), self.b_a(), self.b_g());
        self.put(p, v, q, b_a, b_g);
        self.kf.reset_error(|P| {
            for i in 6..9 {
                for j in 0..D {
                    P[(i, j)] = 0.0;
                    P[(j, i)] = 0.0;
                }
            }
            P.fixed_view_mut::<3, 3>(6, 6).copy_from(block);
        });
    }

    /// Sets the nominal core state, to set up a test's state.
    #[cfg(test)]
    pub(crate) fn set(
        &mut self,
        p: Vector3<f64>,
        v: Vector3<f64>,
        q: UnitQuaternion<f64>,
        b_a: Vector3<f64>,
        b_g: Vector3<f64>,
    ) {
        self.put(p, v, q, b_a, b_g);
    }

    /// Sets the nominal core state (the model's steps, in this module).
    fn put(&mut self, p: Vector3<f64>, v: Vector3<f64>, q: UnitQuaternion<f64>, b_a: Vector3<f64>, b_g: Vector3<f64>) {
        let n = &mut self.nominal;
        n[0..3].copy_from_slice(p.as_slice());
        n[3..6].copy_from_slice(v.as_slice());
        let c = q.quaternion().coords; // nalgebra stores [x, y, z, w]
        n[6..10].copy_from_slice(&[c[3], c[0], c[1], c[2]]);
        n[10..13].copy_from_slice(b_a.as_slice());
        n[13..16].copy_from_slice(b_g.as_slice());
    }
}

impl<const D: usize> InsModel<D> {
    /// The nominal state `x` of a state (same as [`Model::x`]).
    pub fn x_of(s: &InsState<D>) -> &[f64] {
        &s.nominal[..D + 1]
    }
}

impl InsModel {
    /// A model with the IMU noise, gravity (m/s²), nominal x₀, diag(P₀) (error-state
    /// order), optional gate, and a static alignment over the first
    /// `alignment_samples` IMU samples (0: none, x₀'s attitude is used).
    pub fn new(
        noise: ImuNoise,
        gravity: f64,
        x0: [f64; NOMINAL],
        p0_diagonal: [f64; N],
        gate: Option<ChiSquareGate>,
        alignment_samples: u32,
    ) -> Result<Self, FilterError> {
        let initial = KalmanFilter::new(SVector::zeros(), SMatrix::from_diagonal(&SVector::from(p0_diagonal)))?;
        let mut x0 = pad(x0);
        let q = nalgebra::Quaternion::new(x0[6], x0[7], x0[8], x0[9]);
        let norm = q.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(FilterError::NonFinite("initial attitude"));
        }
        for v in &mut x0[6..10] {
            *v /= norm;
        }
        Ok(Self {
            noise,
            gravity,
            x0,
            initial,
            gate,
            lockout: None,
            alignment_samples,
            course: None,
            nonholonomic: None,
            standstill: None,
            gravity_reference: None,
            yaw_unobserved: false,
            aux: AuxStates::default(),
            aux_noise: [0.0; MAX_AUX],
            frames: Frames::default(),
        })
    }
}

/// A core nominal state in the array that has room for the auxiliary states.
fn pad(x: [f64; NOMINAL]) -> [f64; NOMINAL_MAX] {
    let mut out = [0.0; NOMINAL_MAX];
    out[..NOMINAL].copy_from_slice(&x);
    out
}

impl<const D: usize> InsModel<D> {
    fn g(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -self.gravity)
    }

    /// The discrete process noise over `dt`, with the IMU's white noise held as
    /// the mean of `imus` IMUs (density `σ/√imus`).
    fn process_noise(&self, dt: f64, imus: u32) -> ProcessNoise {
        let n = &self.noise;
        let mut qa = n.accelerometer_noise_density.powi(2);
        let mut qg = n.gyroscope_noise_density.powi(2);
        if imus > 1 {
            qa /= f64::from(imus);
            qg /= f64::from(imus);
        }
        ProcessNoise {
            pp: qa * dt * dt * dt / 3.0,
            pv: qa * dt * dt / 2.0,
            vv: qa * dt,
            theta: qg * dt,
            ba: n.accelerometer_random_walk.powi(2) * dt,
            bg: n.gyroscope_random_walk.powi(2) * dt,
            aux: self.aux_noise.map(|q| q * dt),
        }
    }

    /// Propagates nominal state and error covariance over `dt` with the held IMU
    /// values; the transition used (if the filter accepted it) goes to `log`.
    fn propagate(&self, s: &mut InsState<D>, dt: f64, log: Option<&mut StepLog<f64, D>>) {
        let held = s.imu.mean();
        let mut Q = self.process_noise(dt, held.map_or(1, |(_, _, n)| n));
        let moving = held.filter(|_| s.ready);
        let Some((f_m, w_m, _)) = moving else {
            // Nothing to integrate yet: hold the nominal state, grow the covariance.
            if s.kf.predict_structured(|_| {}, |P| Q.add_to(P), || (SMatrix::identity(), Q.dense())).is_ok()
                && let Some(log) = log
            {
                log.predicted(&s.kf, &SMatrix::identity());
            }
            return;
        };
        let (p_new, v_new, q_new, F) =
            if s.still.standing { self.mechanise_at_rest(s, f_m, dt, &mut Q) } else { self.mechanise(s, f_m, w_m, dt) };
        if s.kf.predict_structured(|_| {}, |P| F.propagate_covariance(P, &Q), || (F.dense(), Q.dense())).is_ok() {
            let dv = v_new - s.v();
            s.clock.integrated += nalgebra::Vector2::new(dv.x, dv.y);
            let (b_a, b_g) = (s.b_a(), s.b_g());
            s.put(p_new, v_new, q_new, b_a, b_g);
            if let Some(log) = log {
                log.predicted(&s.kf, &F.dense());
            }
        }
    }

    /// The motion constraint, if configured.
    pub fn nonholonomic(&self) -> Option<&Nonholonomic> {
        self.nonholonomic.as_ref()
    }

    /// The gate, if gating is on.
    pub fn gate(&self) -> Option<&ChiSquareGate> {
        self.gate.as_ref()
    }
}

impl<const D: usize> Model for InsModel<D> {
    type State = InsState<D>;
    type Record = InsRecord<D>;
    type Correction = Option<SVector<f64, D>>;
    type Log = InsLog<D>;
    const CODE: u32 = fusion_shared::snapshot::model::INS;
    const NEEDS_POSITION: bool = false;
    fn aux_states(s: &InsState<D>) -> u32 {
        s.aux_bits
    }

    fn initial_state(&self) -> InsState<D> {
        InsState::new(self.x0, self.initial, self.aux.bits())
    }

    fn frames(&self) -> &Frames {
        &self.frames
    }

    fn propagate_to(&self, s: &mut InsState<D>, t_ns: u64, log: Option<&mut InsLog<D>>) {
        if let Some(dt) = advance_time(&mut s.t_ns, t_ns) {
            self.propagate(s, dt, log.map(|l| &mut l.step));
        }
    }

    fn begin_record(s: &InsState<D>) -> InsLog<D> {
        InsLog { step: StepLog::begin(&s.kf), sets: s.aux.sets }
    }

    /// The record of an error-state step, in the frame of the nominal state after
    /// it (see [`smooth`](Model::smooth)): prior mean `−dx` (the correction the
    /// step injected, 0 if none), posterior mean 0, `P⁻`, `P⁺` after the reset,
    /// the step's `F`, and that nominal state. A step that set auxiliary states
    /// from its sample records them as new states (`aux::smoother_record`).
    fn finish_record(log: InsLog<D>, s: &InsState<D>, injected: Option<SVector<f64, D>>) -> InsRecord<D> {
        let mut step = log.step.finish(&s.kf);
        if let Some(dx) = injected {
            step.x_prior = -dx;
        }
        if s.aux.sets != log.sets {
            aux::smoother_record(&mut step, s.aux.last_set);
        }
        InsRecord { step, nominal: s.nominal }
    }

    fn time_ns(s: &InsState<D>) -> Option<u64> {
        s.t_ns
    }

    #[inline]
    fn held_imu(s: &InsState<D>) -> Option<&crate::model::held_imu::HeldImu> {
        Some(&s.imu)
    }

    fn initialised(s: &InsState<D>) -> bool {
        s.ready
    }

    /// Keeps each kind's lock-out run ([`crate::model::lockout::KindRuns`]):
    /// whether it is due before the fusion, its outcome after.
    #[inline]
    fn fuse_kind(
        &self,
        s: &mut InsState<D>,
        kind: fusion_shared::SampleKind,
        lockout: crate::model::lockout::LockoutRule,
        t_ns: u64,
        fuse: impl FnOnce(&Self, &mut InsState<D>) -> (crate::model::StepOutcome, Option<SVector<f64, D>>),
    ) -> (crate::model::StepOutcome, Option<SVector<f64, D>>) {
        s.kind_runs.before(kind);
        let out = fuse(self, s);
        s.kind_runs.after(self.lockout.as_ref(), kind, lockout, t_ns, &out.0);
        out
    }

    #[inline]
    fn diagnostics(s: &InsState<D>) -> crate::model::Diagnostics {
        crate::model::Diagnostics {
            reinitialisations: s.lockout.count() + s.kind_runs.resets(),
            standing: s.standing(),
            standstill_updates: s.standstill_updates(),
            gravity_updates: s.gravity.updates,
            velocity_time_offset: s.clock.estimate(),
        }
    }

    fn x(s: &InsState<D>) -> &[f64] {
        &s.nominal[..D + 1]
    }

    const COV_DIM: usize = D;

    fn write_covariance(s: &InsState<D>, out: &mut [f64]) {
        s.kf.write_covariance(out);
    }

    /// Error-state RTS smoothing. Each step's error is taken about the nominal
    /// state after it (post-injection, post-reset: mean 0, covariance `P⁺`); the
    /// filter's prior at that step, about the nominal before the injection, is
    /// `−dx` in this frame to first order (the reset Jacobian differs from `I` by
    /// `[½δθ]×`). The linear RTS recursion ([`rts_smooth`]) then gives each step's
    /// smoothed error `δxˢₖ = Cₖ (δxˢₖ₊₁ + dxₖ₊₁)` and `Pˢₖ`, and the smoothed nominal is
    /// `x⁺ₖ ⊕ δxˢₖ` (injected as a correction is).
    fn smooth(records: &mut [InsRecord<D>]) -> Vec<usize> {
        let mut steps: Vec<RtsStep<f64, D>> = records.iter().map(|r| r.step).collect();
        let breaks = rts_smooth(&mut steps);
        // `inject` works on the nominal part of a state only.
        let placeholder = linearised::placeholder();
        for (r, smoothed) in records.iter_mut().zip(&steps) {
            let mut s = InsState::<D>::new(r.nominal, placeholder, 0);
            inject(&mut s, &smoothed.x_post);
            r.nominal = s.nominal;
            r.step.x_post = SVector::zeros();
            r.step.P_post = smoothed.P_post;
        }
        breaks
    }

    fn record_output(r: &InsRecord<D>) -> (&[f64], &[f64]) {
        (&r.nominal[..D + 1], r.step.P_post.as_slice())
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
pub(crate) mod tests_support;
