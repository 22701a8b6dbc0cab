//! The `linear` model: constant velocity driven by measured world acceleration.
//!
//! | index | symbol | unit | frame |
//! |---|---|---|---|
//! | 0..3 | p = [p_x, p_y, p_z] | m | world ENU |
//! | 3..6 | v = [v_x, v_y, v_z] | m/s | world ENU |
//!
//! An IMU sample's `accel_mps2` is the world-frame acceleration with gravity
//! removed; its gyro is unused. For every sample at time t, in processing order:
//!
//! ```text
//! if t > t_f:  dt = (t − t_f)·1e-9 s
//!              F = [[I, dt I], [0, I]],  G = [[½dt² I], [dt I]]
//!              x ← F x + G a             (a: held acceleration, 0 before the first IMU sample)
//!              P ← F P Fᵀ + G (σₐ² I₃) Gᵀ,  t_f ← t
//! IMU:       a ← accel   (the mean of an instant's samples with several IMUs)
//! position:  z = pos, H = [I 0], R = cov; Joseph-form update, gated if configured
//! velocity:  z = vel, H = [0 I], R = cov; likewise
//! ```
//!
//! This is the discrete white-noise acceleration model of Bar-Shalom, Li and
//! Kirubarajan (2001), §6.3.3, eq. 6.3.3-2 to 6.3.3-4, per axis, with the measured
//! acceleration as a known input (zero-order hold). The filter starts at the time of
//! the first processed sample with x₀, P₀ (no propagation before it).

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::{Diagnostics, Kinematic, Model, StepOutcome, advance_time};
use crate::filter::{ChiSquareGate, KalmanFilter, RtsStep, StepLog, UpdateDecision, rts_smooth};
use crate::frames::Frames;
use crate::model::held_imu::{Held, HeldImu};
use crate::model::lockout::{Lockout, LockoutConfig};

/// State dimension.
pub const N: usize = 6;

/// `H = [I 0]` for a position, `[0 I]` for a velocity: the blocks selected
/// (no mounts: the linear model refuses a rotated or offset sensor).
impl Kinematic for LinearModel {
    fn fuse_position(
        &self,
        s: &mut LinearState,
        _kind: fusion_shared::SampleKind,
        _sensor: u32,
        z: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> (StepOutcome, ()) {
        (self.fuse_fix(s, z, R), ())
    }

    fn fuse_velocity(
        &self,
        s: &mut LinearState,
        _sensor: u32,
        _t_ns: u64,
        z: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> (StepOutcome, ()) {
        (self.update_block(s, z, 3, R), ())
    }
}

/// The `linear` model's parameters (`[model]` with `kind = "linear"`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearParams {
    /// σₐ, m/s²: white-noise acceleration per IMU interval.
    pub accel_noise_std: f64,
}

impl Default for LinearParams {
    fn default() -> Self {
        Self { accel_noise_std: 0.3 }
    }
}

/// The `linear` model's parameters.
#[derive(Debug, Clone)]
pub struct LinearModel {
    sigma_a: f64,
    initial: KalmanFilter<f64, N>,
    gate: Option<ChiSquareGate>,
    lockout: Option<LockoutConfig>,
    frames: Frames,
}

/// Filter state of the `linear` model at one point of the stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearState {
    kf: KalmanFilter<f64, N>,
    t_ns: Option<u64>,
    /// Held IMU acceleration (the input of the next propagations), combined
    /// over the IMUs.
    imu: HeldImu,
    /// The run of gated fixes ([`crate::model::lockout`]).
    lockout: Lockout,
}

impl LinearState {
    /// The filter.
    pub fn filter(&self) -> &KalmanFilter<f64, N> {
        &self.kf
    }

    /// The filter, to set up a test's state.
    #[cfg(test)]
    pub(crate) fn filter_mut(&mut self) -> &mut KalmanFilter<f64, N> {
        &mut self.kf
    }
}

impl LinearModel {
    /// A model with `σₐ` (m/s²), x₀, diag(P₀) and an optional gate.
    pub fn new(
        sigma_a: f64,
        x0: [f64; N],
        p0_diagonal: [f64; N],
        gate: Option<ChiSquareGate>,
    ) -> Result<Self, crate::filter::FilterError> {
        let initial =
            KalmanFilter::new(SVector::from(x0), SMatrix::from_diagonal(&SVector::<f64, N>::from(p0_diagonal)))?;
        Ok(Self { sigma_a, initial, gate, lockout: None, frames: Frames::default() })
    }

    /// The filter the model starts from (x₀, P₀, form).
    pub fn initial_filter(&self) -> &KalmanFilter<f64, N> {
        &self.initial
    }

    /// The same model with its filter in `form` (`[filter] form`).
    pub fn with_form(mut self, form: crate::filter::Form) -> Result<Self, crate::filter::FilterError> {
        self.initial = self.initial.with_form(form)?;
        Ok(self)
    }

    /// The same model with lock-out recovery ([`crate::model::lockout`]).
    pub fn with_lockout(mut self, lockout: Option<LockoutConfig>) -> Self {
        self.lockout = lockout;
        self
    }

    /// The same model with these frames (a configured datum).
    pub fn with_frames(mut self, frames: Frames) -> Self {
        self.frames = frames;
        self
    }

    /// `F` and `Q = G σₐ² Gᵀ` for a step of `dt` seconds, with `Q` in closed form:
    /// per axis `σₐ² [[¼dt⁴, ½dt³], [½dt³, dt²]]` (Bar-Shalom et al. 2001, eq. 6.3.3-4).
    pub fn transition_and_noise(&self, dt: f64) -> (SMatrix<f64, N, N>, SMatrix<f64, N, N>) {
        let q = self.sigma_a * self.sigma_a;
        let dt2 = dt * dt;
        let mut F = SMatrix::<f64, N, N>::identity();
        let mut Q = SMatrix::<f64, N, N>::zeros();
        for i in 0..3 {
            F[(i, i + 3)] = dt;
            Q[(i, i)] = 0.25 * dt2 * dt2 * q;
            Q[(i, i + 3)] = 0.5 * dt2 * dt * q;
            Q[(i + 3, i)] = 0.5 * dt2 * dt * q;
            Q[(i + 3, i + 3)] = dt2 * q;
        }
        (F, Q)
    }

    /// Propagates to `t` ([`advance_time`]), logging the predict's transition for
    /// the smoother when `log` is given.
    fn propagate(&self, s: &mut LinearState, t: u64, log: Option<&mut StepLog<f64, N>>) {
        if let Some(dt) = advance_time(&mut s.t_ns, t) {
            let (F, Q) = self.transition_and_noise(dt);
            let a = s.imu.mean().map_or_else(Vector3::zeros, |(a, _, _)| a);
            // A non-finite result is refused by the filter and leaves x, P as they
            // were; the filter time still moves on so later samples stay in order.
            let propagated =
                s.kf.predict_structured(|x| propagate_x(x, &a, dt), |P| propagate_covariance(P, &Q, dt), || (F, Q));
            if propagated.is_ok()
                && let Some(log) = log
            {
                log.predicted(&s.kf, &F);
            }
        }
    }

    /// Fuses `z = x[offset..offset+3] + v`, `v ~ N(0, R)`: `H` selects three
    /// consecutive states (position at 0, velocity at 3). Joseph-form update,
    /// gated as configured.
    pub(crate) fn update_block(
        &self,
        s: &mut LinearState,
        z: &Vector3<f64>,
        offset: usize,
        R: &Matrix3<f64>,
    ) -> StepOutcome {
        let (predicted, _) = block(s, offset);
        match s.kf.update_selection_lean(z, &predicted, offset, R, self.gate.as_ref()) {
            Ok((UpdateDecision::Accepted, nis)) => StepOutcome::Fused { nis },
            Ok((_, nis)) => StepOutcome::Gated { nis },
            Err(_) => StepOutcome::Refused,
        }
    }

    /// Holds IMU `sensor`'s values at `t_ns` as the input of the next
    /// propagations (combined over the IMUs as configured).
    pub(crate) fn hold_imu(
        &self,
        s: &mut LinearState,
        sensor: u32,
        t_ns: u64,
        f: Vector3<f64>,
        w: Vector3<f64>,
    ) -> Held {
        s.imu.hold(self.frames.imus(), sensor, t_ns, f, w)
    }

    /// Fuses a position fix `z` (covariance `R`) on the position states
    /// ([`update_block`](Self::update_block)), re-initialising position and
    /// velocity from the fixes after a lock-out ([`crate::model::lockout`]):
    /// `x = [p, v]`, `P = blockdiag(P_pp, P_vv + P₀,vv)`.
    pub(crate) fn fuse_fix(&self, s: &mut LinearState, z: &Vector3<f64>, R: &Matrix3<f64>) -> StepOutcome {
        let outcome = self.update_block(s, z, 0, R);
        let t = s.t_ns.unwrap_or(0);
        if let Some(r) = s.lockout.observe(self.lockout.as_ref(), &outcome, t, z, R) {
            let mut x = SVector::<f64, N>::zeros();
            x.fixed_rows_mut::<3>(0).copy_from(&r.p);
            x.fixed_rows_mut::<3>(3).copy_from(&r.v);
            // Finite by construction from validated fixes; a refusal keeps the estimate.
            let _ = s.kf.set_state(x, r.covariance(&self.initial.P()));
        }
        outcome
    }

    /// `F` and `G` for a step of `dt` seconds.
    pub fn transition(dt: f64) -> (SMatrix<f64, N, N>, SMatrix<f64, N, 3>) {
        let mut F = SMatrix::<f64, N, N>::identity();
        let mut G = SMatrix::<f64, N, 3>::zeros();
        for i in 0..3 {
            F[(i, i + 3)] = dt;
            G[(i, i)] = 0.5 * dt * dt;
            G[(i + 3, i)] = dt;
        }
        (F, G)
    }
}

/// `h(x) = x[offset..offset+3]` and its Jacobian `H = ∂h/∂x`, which selects
/// those states (`offset` 0: the position, 3: the velocity): what a position
/// fix or a velocity observes of the state (`y = z − h(x)`, its
/// [`Observe`](crate::measurement::Observe) for this model), and what
/// `LinearModel::update_block` updates with.
#[inline]
pub fn block(s: &LinearState, offset: usize) -> (Vector3<f64>, SMatrix<f64, 3, N>) {
    let x = s.kf.x();
    let mut H = SMatrix::<f64, 3, N>::zeros();
    H.fixed_view_mut::<3, 3>(0, offset).fill_with_identity();
    (Vector3::new(x[offset], x[offset + 1], x[offset + 2]), H)
}

/// `x⁻ = F x + G a`.
fn propagate_x(x: &mut SVector<f64, N>, a: &Vector3<f64>, dt: f64) {
    let half_dt2 = 0.5 * dt * dt;
    for i in 0..3 {
        x[i] += dt * x[i + 3] + half_dt2 * a[i];
        x[i + 3] += dt * a[i];
    }
}

/// `P⁻ = F P Fᵀ + Q` in block form, with `P = [[A, B], [Bᵀ, D]]` (position,
/// velocity blocks) and `F = [[I, dt I], [0, I]]`:
///
/// ```text
/// F P Fᵀ = [[A + dt (B + Bᵀ) + dt² D,  B + dt D],
///           [Bᵀ + dt D,                D       ]]
/// ```
///
/// 36 multiply-adds instead of the 432 of two dense 6×6 products.
fn propagate_covariance(P: &mut SMatrix<f64, N, N>, Q: &SMatrix<f64, N, N>, dt: f64) {
    // Each (i, j) reads and writes its own four entries: in place is exact.
    for i in 0..3 {
        for j in 0..3 {
            let (pp, pv, vp, vv) = (P[(i, j)], P[(i, j + 3)], P[(i + 3, j)], P[(i + 3, j + 3)]);
            P[(i, j)] = pp + dt * (pv + vp) + dt * dt * vv;
            P[(i, j + 3)] = pv + dt * vv;
            P[(i + 3, j)] = vp + dt * vv;
        }
    }
    *P += Q;
}

impl Model for LinearModel {
    type State = LinearState;
    type Record = RtsStep<f64, N>;
    type Correction = ();
    type Log = StepLog<f64, N>;
    const CODE: u32 = fusion_shared::snapshot::model::LINEAR;

    fn initial_state(&self) -> LinearState {
        LinearState { kf: self.initial, t_ns: None, imu: HeldImu::EMPTY, lockout: Lockout::default() }
    }

    fn frames(&self) -> &Frames {
        &self.frames
    }

    fn propagate_to(&self, s: &mut LinearState, t_ns: u64, log: Option<&mut StepLog<f64, N>>) {
        self.propagate(s, t_ns, log)
    }

    fn begin_record(s: &LinearState) -> StepLog<f64, N> {
        StepLog::begin(&s.kf)
    }

    fn finish_record(log: StepLog<f64, N>, s: &LinearState, _: ()) -> RtsStep<f64, N> {
        log.finish(&s.kf)
    }

    #[inline]
    fn diagnostics(s: &LinearState) -> Diagnostics {
        Diagnostics { reinitialisations: s.lockout.count(), ..Diagnostics::default() }
    }

    fn time_ns(s: &LinearState) -> Option<u64> {
        s.t_ns
    }

    #[inline]
    fn held_imu(s: &LinearState) -> Option<&crate::model::held_imu::HeldImu> {
        Some(&s.imu)
    }

    fn x(s: &LinearState) -> &[f64] {
        s.kf.x().as_slice()
    }

    const COV_DIM: usize = N;

    fn write_covariance(s: &LinearState, out: &mut [f64]) {
        s.kf.write_covariance(out);
    }

    fn smooth(records: &mut [RtsStep<f64, N>]) -> Vec<usize> {
        rts_smooth(records)
    }

    fn record_output(r: &RtsStep<f64, N>) -> (&[f64], &[f64]) {
        (r.x_post.as_slice(), r.P_post.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::Steps;
    use fusion_shared::{ImuSample, PositionSample, Sample};

    fn model() -> LinearModel {
        LinearModel::new(0.5, [0.0; 6], [1.0; 6], None).unwrap()
    }

    #[test]
    fn constant_acceleration_integrates_exactly() {
        let m = model();
        let mut s = m.initial_state();
        let imu = |t: u64| {
            Sample::Imu(ImuSample {
                header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t, 0, 0),
                accel_mps2: [1.0, -2.0, 0.5],
                ..Default::default()
            })
        };
        m.step(&mut s, &imu(1_000_000_000));
        for i in 1..=100 {
            m.step(&mut s, &imu(1_000_000_000 + i * 10_000_000));
        }
        // After 1 s at a = [1, -2, .5] from rest: p = ½ a, v = a (exact for piecewise-constant a).
        let x = s.kf.x();
        let expect = [0.5, -1.0, 0.25, 1.0, -2.0, 0.5];
        for i in 0..6 {
            assert!((x[i] - expect[i]).abs() < 1e-12, "x[{i}] = {}", x[i]);
        }
        assert_eq!(s.t_ns, Some(2_000_000_000));
    }

    #[test]
    fn the_first_sample_starts_the_filter_without_propagation() {
        let m = model();
        let mut s = m.initial_state();
        let p = PositionSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, 5, 0, 0),
            pos_m: [1.0, 0.0, 0.0],
            cov_m2: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        };
        let out = m.step(&mut s, &Sample::Position(p));
        // Prior P₀ = I, R = I: K = ½ on the position block, x = ½ z, NIS = 1²/2.
        assert!(matches!(out, StepOutcome::Fused { nis } if (nis - 0.5).abs() < 1e-15));
        assert!((s.kf.x()[0] - 0.5).abs() < 1e-15);
        assert!((s.kf.P()[(0, 0)] - 0.5).abs() < 1e-15);
        assert_eq!(s.kf.P()[(3, 3)], 1.0);
    }

    #[test]
    fn structured_propagation_equals_the_dense_products() {
        let m = model();
        let dt = 0.0123;
        let (F, Q) = m.transition_and_noise(dt);
        let (F2, G) = LinearModel::transition(dt);
        assert_eq!(F, F2);
        assert!((Q - G * (0.25 * Matrix3::<f64>::identity()) * G.transpose()).amax() < 1e-18);
        let L = SMatrix::<f64, N, N>::from_fn(|i, j| if i >= j { 1.0 + (i * 7 + j * 3) as f64 * 0.1 } else { 0.0 });
        let P = L * L.transpose();
        let x = SVector::<f64, N>::from_fn(|i, _| i as f64 - 2.5);
        let a = Vector3::new(0.3, -1.0, 2.0);
        let (mut xp, mut Pp) = (x, P);
        propagate_x(&mut xp, &a, dt);
        propagate_covariance(&mut Pp, &Q, dt);
        assert!((xp - (F * x + G * a)).amax() < 1e-14);
        assert!((Pp - (F * P * F.transpose() + Q)).amax() < 1e-12 * P.amax());
    }

    #[test]
    fn equal_timestamps_do_not_propagate() {
        let m = model();
        let mut s = m.initial_state();
        let imu = Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, 7, 0, 0),
            accel_mps2: [3.0, 0.0, 0.0],
            ..Default::default()
        });
        m.step(&mut s, &imu);
        let before = s.kf;
        m.step(&mut s, &imu);
        assert_eq!(s.kf.x(), before.x());
        assert_eq!(s.kf.P(), before.P());
    }
}
