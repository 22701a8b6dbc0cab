//! Kalman filter core: initialise, predict (linear, with input, with mapped process
//! noise, EKF), Joseph-form update (linear or nonlinear h), diagnostics of each step.
//!
//! Notation follows Simon, *Optimal State Estimation* (2006), ch. 5 and 13:
//! `x⁻, P⁻` prior (after predict), `x⁺, P⁺` posterior (after update).
//! Generic over the scalar (`f64`, `f32`) and the fixed dimensions `N` (state) and
//! `M` (measurement); nothing here allocates.

#![allow(non_snake_case)]

use nalgebra::{Cholesky, RealField, SMatrix, SVector};

mod cholesky;
mod joseph;
mod selection;

use cholesky::SmallCholesky;

pub use super::measurement::{
    FaultDecision, FaultDetector, MeasurementView, UpdateDecision, UpdateDiagnostics, UpdateOptions,
};

/// Why a filter operation was refused. The filter state is unchanged in every case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FilterError {
    /// An input (x0, P0, F, Q, z, H, R, h(x)) or the result held NaN or ±∞.
    #[error("non-finite number in {0}")]
    NonFinite(&'static str),
    /// The innovation covariance `S = H P⁻ Hᵀ + R` has no Cholesky factor.
    #[error("innovation covariance S is not positive definite")]
    InnovationNotPositiveDefinite,
    /// The initial covariance is not symmetric positive definite.
    #[error("initial covariance is not symmetric positive definite")]
    CovarianceNotPositiveDefinite,
}

/// A Kalman filter on a fixed-size state: the estimate and its covariance, nothing
/// else, so that a history of filter states stays small and cheap to copy.
///
/// What the RTS smoother needs of a step (prior, transition) is kept by a
/// [`StepLog`](super::smoother::StepLog) around the calls, only when a caller smooths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KalmanFilter<T: RealField + Copy, const N: usize> {
    x: SVector<T, N>,
    P: SMatrix<T, N, N>,
}

fn all_finite<T: RealField + Copy, const R: usize, const C: usize>(m: &SMatrix<T, R, C>) -> bool {
    // `v · 0` is ±0 for a finite v and NaN for NaN and ±∞, so the sum is 0 exactly
    // when every entry is finite. Four independent sums over the contiguous slice
    // vectorise; a per-entry `is_finite` fold does not (it cost ~4 instructions an
    // entry, 900 for a 15×15 covariance).
    let s = m.as_slice();
    let zero = T::zero();
    let mut acc = [zero; 4];
    let chunks = s.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, v) in acc.iter_mut().zip(c) {
            *a += *v * zero;
        }
    }
    for (a, v) in acc.iter_mut().zip(rest) {
        *a += *v * zero;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) == T::zero()
}

/// `P ← ½ (P + Pᵀ)`: removes the asymmetry that rounding adds to every product.
fn symmetrize<T: RealField + Copy, const N: usize>(P: &mut SMatrix<T, N, N>) {
    symmetrize_leading(&mut P.data.0, N, Symmetrize::Average);
}

/// How [`symmetrize_leading`] makes a block symmetric.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Symmetrize {
    /// Each pair `(i, j)`, `(j, i)` becomes its mean.
    Average,
    /// The upper triangle (`i < j`: stored at `p[j][i]`) is copied to the lower.
    MirrorUpper,
}

/// Makes the leading `k × k` block of a column-major array (`p[column][row]`) symmetric.
#[allow(clippy::needless_range_loop)] // (i, j) and (j, i) are both indexed
pub(crate) fn symmetrize_leading<T: RealField + Copy, const N: usize>(p: &mut [[T; N]; N], k: usize, how: Symmetrize) {
    let half = T::from_subset(&0.5);
    for i in 0..k {
        for j in (i + 1)..k {
            let v = match how {
                Symmetrize::Average => (p[j][i] + p[i][j]) * half,
                Symmetrize::MirrorUpper => p[j][i],
            };
            p[j][i] = v;
            p[i][j] = v;
        }
    }
}

/// `Q = G Q_w Gᵀ`: process noise of `W` white inputs mapped into the state
/// (Simon 2006, eq. 5.18 with `L = G`).
pub fn map_process_noise<T: RealField + Copy, const N: usize, const W: usize>(
    G: &SMatrix<T, N, W>,
    Qw: &SMatrix<T, W, W>,
) -> SMatrix<T, N, N> {
    let mut Q = G * Qw * G.transpose();
    symmetrize(&mut Q);
    Q
}

impl<T: RealField + Copy, const N: usize> KalmanFilter<T, N> {
    /// Starts from `x0` with covariance `P0`, which must be finite and symmetric
    /// positive definite (checked by Cholesky).
    pub fn new(x0: SVector<T, N>, P0: SMatrix<T, N, N>) -> Result<Self, FilterError> {
        if !all_finite(&x0) || !all_finite(&P0) {
            return Err(FilterError::NonFinite("initial state"));
        }
        let tol = T::from_subset(&1e-9) * P0.amax();
        if (P0 - P0.transpose()).amax() > tol || Cholesky::new(P0).is_none() {
            return Err(FilterError::CovarianceNotPositiveDefinite);
        }
        Ok(Self { x: x0, P: P0 })
    }

    /// State estimate (posterior of the last update, or prior if none followed).
    pub fn x(&self) -> &SVector<T, N> {
        &self.x
    }

    /// Covariance of [`x`](Self::x).
    pub fn P(&self) -> &SMatrix<T, N, N> {
        &self.P
    }

    /// Overwrites the estimate, e.g. after an error-state reset. Refused (state
    /// unchanged) if anything is non-finite.
    pub fn set_state(&mut self, x: SVector<T, N>, P: SMatrix<T, N, N>) -> Result<(), FilterError> {
        if !all_finite(&x) || !all_finite(&P) {
            return Err(FilterError::NonFinite("state"));
        }
        self.x = x;
        self.P = P;
        symmetrize(&mut self.P);
        Ok(())
    }

    /// Error-state reset after an injection: `x ← 0`, and `P` transformed in place
    /// by `reset` (`P ← G P Gᵀ` with the reset Jacobian `G`; Solà 2017, §7.2). The
    /// transform must keep `P` symmetric; it cannot make it non-finite when `G` is
    /// finite, and `G` derives from the accepted, finite correction.
    pub fn reset_error(&mut self, reset: impl FnOnce(&mut SMatrix<T, N, N>)) {
        self.x = SVector::zeros();
        reset(&mut self.P);
    }

    /// Linear predict `x⁻ = F x`, `P⁻ = F P Fᵀ + Q` (Simon 2006, eq. 5.19).
    pub fn predict(&mut self, F: &SMatrix<T, N, N>, Q: &SMatrix<T, N, N>) -> Result<(), FilterError> {
        let x = F * self.x;
        self.finish_predict(x, F, Q)
    }

    /// Linear predict with a known input term `x⁻ = F x + B u`, `P⁻ = F P Fᵀ + Q`
    /// (Simon 2006, eq. 5.19). `bu` is the product `B u` (discretised, e.g. with
    /// [`super::discretize::euler_input`]); for mapped noise pass
    /// `Q = `[`map_process_noise`]`(G, Q_w)`.
    pub fn predict_with_input(
        &mut self,
        F: &SMatrix<T, N, N>,
        bu: &SVector<T, N>,
        Q: &SMatrix<T, N, N>,
    ) -> Result<(), FilterError> {
        let x = F * self.x + bu;
        self.finish_predict(x, F, Q)
    }

    /// EKF predict: the model supplies `(f(x), F = ∂f/∂x)` at the current estimate;
    /// `x⁻ = f(x)`, `P⁻ = F P Fᵀ + Q` (Simon 2006, eq. 13.47).
    pub fn predict_ekf(
        &mut self,
        f: impl FnOnce(&SVector<T, N>) -> (SVector<T, N>, SMatrix<T, N, N>),
        Q: &SMatrix<T, N, N>,
    ) -> Result<(), FilterError> {
        let (x, F) = f(&self.x);
        self.finish_predict(x, &F, Q)
    }

    /// Predict with a propagation the model computes itself, exploiting the
    /// structure of its `F` and `G` instead of dense products. `propagate(x, P)`
    /// must turn `(x, P)` in place into exactly `(x⁻, P⁻) = (f(x), F P Fᵀ + Q)` with
    /// `P⁻` symmetric (it is taken as it is, not symmetrised: a structured
    /// propagation computes one triangle and mirrors it). A non-finite result is
    /// refused and leaves the filter as it was.
    pub fn predict_structured(
        &mut self,
        propagate: impl FnOnce(&mut SVector<T, N>, &mut SMatrix<T, N, N>),
    ) -> Result<(), FilterError> {
        self.change_or_keep("predicted state", propagate)
    }

    fn finish_predict(
        &mut self,
        x: SVector<T, N>,
        F: &SMatrix<T, N, N>,
        Q: &SMatrix<T, N, N>,
    ) -> Result<(), FilterError> {
        let mut P = F * self.P * F.transpose() + Q;
        symmetrize(&mut P);
        // Math note: P⁻ is symmetric by construction; PD follows from P ≻ 0, Q ⪰ 0.
        self.change_or_keep("predicted state", |x_, P_| (*x_, *P_) = (x, P))
    }

    /// Changes the estimate in place with `change`, and puts the previous one back
    /// (refusing the change) if the result is not finite. The copy is taken before
    /// the work, not after it: writing the result in place leaves no store of the
    /// whole covariance for the next reader of it to wait on.
    fn change_or_keep(
        &mut self,
        what: &'static str,
        change: impl FnOnce(&mut SVector<T, N>, &mut SMatrix<T, N, N>),
    ) -> Result<(), FilterError> {
        let before = *self;
        change(&mut self.x, &mut self.P);
        if !all_finite(&self.x) || !all_finite(&self.P) {
            *self = before;
            return Err(FilterError::NonFinite(what));
        }
        Ok(())
    }

    /// Linear update with `z = H x + v`, `v ~ N(0, R)`; see [`update_nonlinear`](Self::update_nonlinear).
    pub fn update<const M: usize>(
        &mut self,
        z: &SVector<T, M>,
        H: &SMatrix<T, M, N>,
        R: &SMatrix<T, M, M>,
        options: UpdateOptions<'_, T, N, M>,
    ) -> Result<UpdateDiagnostics<T, N, M>, FilterError> {
        let predicted = H * self.x;
        self.update_nonlinear(z, &predicted, H, R, options)
    }

    /// Update with `z = h(x) + v`, given `h(x⁻)` and `H = ∂h/∂x` at `x⁻`
    /// (Simon 2006, eq. 13.49; linear when `h(x) = H x`):
    ///
    /// ```text
    /// y  = z − h(x⁻)                         residual
    /// S  = H P⁻ Hᵀ + R                       factorised by Cholesky, S = L Lᵀ
    /// K  = P⁻ Hᵀ S⁻¹                         solved, never inverted
    /// x⁺ = x⁻ + K y
    /// P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ  Joseph form (Simon 2006, eq. 5.19)
    /// ```
    ///
    /// The Joseph form is evaluated in O(N² M), without the N×N product (see
    /// `joseph::joseph_low_rank`), exactly symmetric.
    ///
    /// The hook (if any) edits `y, H, R` first; then the gate (if any) refuses the
    /// measurement when `NIS = yᵀ S⁻¹ y` exceeds the χ²ₘ quantile. A refused or
    /// failed update leaves the state untouched. The Joseph form keeps P⁺ symmetric
    /// positive semi-definite for any gain, so rounding cannot make it indefinite.
    pub fn update_nonlinear<const M: usize>(
        &mut self,
        z: &SVector<T, M>,
        predicted: &SVector<T, M>,
        H: &SMatrix<T, M, N>,
        R: &SMatrix<T, M, M>,
        options: UpdateOptions<'_, T, N, M>,
    ) -> Result<UpdateDiagnostics<T, N, M>, FilterError> {
        if !all_finite(z) || !all_finite(predicted) || !all_finite(H) || !all_finite(R) {
            return Err(FilterError::NonFinite("measurement"));
        }
        let PHt = self.P * H.transpose();
        let mut view = MeasurementView::new(z - predicted, *H, *R, H * PHt + R);
        let mut decision = UpdateDecision::Accepted;
        let mut PHt = PHt;
        if let Some(hook) = options.fault_detector {
            match hook.inspect(&mut view) {
                FaultDecision::Keep => {}
                FaultDecision::Modified => {
                    PHt = self.P * view.H.transpose();
                    view.S = view.H * PHt + view.R;
                }
                FaultDecision::Reject => decision = UpdateDecision::RejectedByHook,
            }
        }
        let mut S = view.S;
        symmetrize(&mut S);
        let chol = SmallCholesky::new(S).ok_or(FilterError::InnovationNotPositiveDefinite)?;
        let y = view.residual;
        let dims = view.active_dims();

        // K = P Hᵀ S⁻¹, solved, never inverted.
        let K = chol.gain(&PHt);
        let dx = K * y;
        let w = chol.whiten(&y);
        let nis = w.dot(&w);

        let gate_threshold = options.gate.map(|g| T::from_subset(&g.threshold(dims)));
        if decision == UpdateDecision::Accepted && gate_threshold.is_some_and(|th| nis > th) {
            decision = UpdateDecision::Gated;
        }
        let diagnostics = UpdateDiagnostics {
            decision,
            z: *z,
            predicted: *predicted,
            residual: y,
            H: view.H,
            R: view.R,
            S,
            K,
            dx,
            nis,
            dims,
            gate_threshold,
        };
        if decision != UpdateDecision::Accepted {
            return Ok(diagnostics);
        }

        self.change_or_keep("updated state", |x, P| {
            *x += dx;
            joseph::joseph_low_rank(P, &K, &PHt, &S);
        })?;
        Ok(diagnostics)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::ChiSquareGate;
    use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

    #[test]
    fn all_finite_finds_every_non_finite_entry() {
        let mut m = SMatrix::<f64, 5, 3>::from_fn(|i, j| (i as f64 - 2.0) * 1e300 * (j as f64 + 0.5));
        m[(4, 2)] = -f64::MAX;
        assert!(all_finite(&m));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for k in 0..15 {
                let mut b = m;
                b.as_mut_slice()[k] = bad;
                assert!(!all_finite(&b), "{bad} at {k}");
            }
        }
    }

    fn hand_filter() -> KalmanFilter<f64, 2> {
        KalmanFilter::new(Vector2::new(1.0, 2.0), Matrix2::new(4.0, 1.0, 1.0, 2.0)).unwrap()
    }

    #[test]
    fn joseph_update_matches_hand_computed_values() {
        // x = [1, 2], P = [[4, 1], [1, 2]], z = 3, H = [1 0], R = 1.
        // y = 2, S = 5, K = [4/5, 1/5], x⁺ = [2.6, 2.4],
        // P⁺ = (I−KH) P (I−KH)ᵀ + K R Kᵀ = [[0.8, 0.2], [0.2, 1.8]], NIS = 4/5.
        let mut kf = hand_filter();
        let d = kf
            .update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default())
            .unwrap();
        assert_eq!(d.decision, UpdateDecision::Accepted);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-14;
        assert!(close(d.residual[0], 2.0) && close(d.S[(0, 0)], 5.0));
        assert!(close(d.K[0], 0.8) && close(d.K[1], 0.2));
        assert!(close(kf.x()[0], 2.6) && close(kf.x()[1], 2.4));
        let P = kf.P();
        assert!(close(P[(0, 0)], 0.8) && close(P[(0, 1)], 0.2) && close(P[(1, 0)], 0.2) && close(P[(1, 1)], 1.8));
        assert!(close(d.nis, 0.8));
        let ll = -0.5 * (0.8 + 5f64.ln() + (2.0 * std::f64::consts::PI).ln());
        assert!(close(d.log_likelihood().unwrap(), ll));
        assert!(close(d.dx[0], 1.6) && close(d.dx[1], 0.4));
        // Σdx = K S Kᵀ = 5 [[.64, .16], [.16, .04]].
        let sdx = d.sigma_dx();
        assert!(close(sdx[(0, 0)], 3.2) && close(sdx[(0, 1)], 0.8) && close(sdx[(1, 1)], 0.2));
    }

    #[test]
    fn small_cholesky_solves_match_the_explicit_inverse() {
        let S = nalgebra::Matrix3::new(2.0, 0.6, -0.3, 0.6, 1.5, 0.2, -0.3, 0.2, 0.9);
        let B = SMatrix::<f64, 5, 3>::from_fn(|i, j| (i as f64 - 1.7) * (j as f64 + 0.3) + 0.1 * (i * j) as f64);
        let y = nalgebra::Vector3::new(0.7, -1.1, 0.4);
        let c = SmallCholesky::new(S).unwrap();
        let Si = S.try_inverse().unwrap();
        assert!((c.gain(&B) - B * Si).amax() < 1e-13);
        let w = c.whiten(&y);
        assert!((w.dot(&w) - (y.transpose() * Si * y)[0]).abs() < 1e-13);
        assert!(SmallCholesky::new(nalgebra::Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_none());
    }

    #[test]
    fn joseph_form_stays_psd_with_a_suboptimal_gain() {
        // With an exactly zero R the optimal update makes P⁺ singular; the Joseph
        // form must still give a symmetric PSD result, never a negative variance.
        let mut kf = hand_filter();
        kf.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1e-300), UpdateOptions::default())
            .unwrap();
        let eig = kf.P().symmetric_eigenvalues();
        assert!(eig.iter().all(|e| *e >= -1e-12), "{eig}");
    }

    #[test]
    fn predict_with_input_and_mapped_noise() {
        // Constant velocity, dt = 0.5: F = [[1, .5], [0, 1]], G = [.125, .5], q = 4.
        let mut kf = hand_filter();
        let F = Matrix2::new(1.0, 0.5, 0.0, 1.0);
        let G = nalgebra::Matrix2x1::new(0.125, 0.5);
        let Q = map_process_noise(&G, &Matrix1::new(4.0));
        kf.predict_with_input(&F, &(G * 2.0), &Q).unwrap();
        // x = F x + G a = [1 + 1 + .25, 2 + 1] ; P = F P Fᵀ + G q Gᵀ.
        assert_eq!(*kf.x(), Vector2::new(2.25, 3.0));
        let P = F * Matrix2::new(4.0, 1.0, 1.0, 2.0) * F.transpose() + G * 4.0 * G.transpose();
        assert!((kf.P() - P).amax() < 1e-15);
    }

    #[test]
    fn ekf_predict_uses_the_model_jacobian() {
        let mut kf = hand_filter();
        // f(x) = [x0², x1], F = [[2 x0, 0], [0, 1]]
        kf.predict_ekf(
            |x| (Vector2::new(x[0] * x[0], x[1]), Matrix2::new(2.0 * x[0], 0.0, 0.0, 1.0)),
            &Matrix2::zeros(),
        )
        .unwrap();
        assert_eq!(*kf.x(), Vector2::new(1.0, 2.0));
        assert_eq!(kf.P()[(0, 0)], 16.0);
        assert_eq!(kf.P()[(0, 1)], 2.0);
    }

    #[test]
    fn indefinite_innovation_is_refused_and_state_kept() {
        let mut kf = hand_filter();
        let before = kf;
        let err = kf
            .update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(-10.0), UpdateOptions::default())
            .unwrap_err();
        assert_eq!(err, FilterError::InnovationNotPositiveDefinite);
        assert_eq!(kf, before);
    }

    #[test]
    fn non_finite_inputs_never_enter_the_state() {
        let mut kf = hand_filter();
        let before = kf;
        let H = Matrix1x2::new(1.0, 0.0);
        assert!(kf.update(&Vector1::new(f64::NAN), &H, &Matrix1::new(1.0), UpdateOptions::default()).is_err());
        assert!(kf.update(&Vector1::new(1.0), &H, &Matrix1::new(f64::INFINITY), UpdateOptions::default()).is_err());
        assert!(kf.predict(&Matrix2::new(1e300, 0.0, 0.0, 1.0), &Matrix2::zeros()).is_err());
        assert!(kf.set_state(Vector2::new(f64::NAN, 0.0), Matrix2::identity()).is_err());
        assert_eq!(kf, before);
        assert!(KalmanFilter::new(Vector2::new(0.0, 0.0), Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_err());
    }

    #[test]
    fn gated_measurement_leaves_the_state_untouched() {
        let gate = ChiSquareGate::new(0.99).unwrap();
        let mut kf = hand_filter();
        let before = kf;
        let opts = UpdateOptions { gate: Some(&gate), fault_detector: None };
        // y = 99, S = 5: NIS = 1960 ≫ 6.63.
        let d = kf.update(&Vector1::new(100.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), opts).unwrap();
        assert_eq!(d.decision, UpdateDecision::Gated);
        assert!((d.gate_threshold.unwrap() - 6.634896601021214).abs() < 1e-9);
        assert_eq!(kf, before);
    }

    struct DropSecond;
    impl FaultDetector<f64, 2, 2> for DropSecond {
        fn inspect(&mut self, m: &mut MeasurementView<f64, 2, 2>) -> FaultDecision {
            m.drop_component(1);
            FaultDecision::Modified
        }
    }

    #[test]
    fn fault_hook_can_drop_a_component() {
        // Measuring both states with component 1 dropped equals measuring state 0 only.
        let mut a = hand_filter();
        let mut b = hand_filter();
        let mut hook = DropSecond;
        let d = a
            .update(
                &Vector2::new(3.0, 1000.0),
                &Matrix2::identity(),
                &Matrix2::new(1.0, 0.3, 0.3, 1.0),
                UpdateOptions { gate: None, fault_detector: Some(&mut hook) },
            )
            .unwrap();
        b.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default()).unwrap();
        assert_eq!(d.dims, 1);
        assert!((a.x() - b.x()).amax() < 1e-12 && (a.P() - b.P()).amax() < 1e-12);
        assert!((d.nis - 0.8).abs() < 1e-12);
    }

    #[test]
    fn fault_hook_reweighting_and_rejection() {
        struct Inflate(f64);
        impl FaultDetector<f64, 2, 1> for Inflate {
            fn inspect(&mut self, m: &mut MeasurementView<f64, 2, 1>) -> FaultDecision {
                if self.0 == 0.0 {
                    return FaultDecision::Reject;
                }
                m.reweight_component(0, self.0);
                FaultDecision::Modified
            }
        }
        let H = Matrix1x2::new(1.0, 0.0);
        let mut a = hand_filter();
        let mut b = hand_filter();
        let mut hook = Inflate(9.0);
        a.update(
            &Vector1::new(3.0),
            &H,
            &Matrix1::new(1.0),
            UpdateOptions { gate: None, fault_detector: Some(&mut hook) },
        )
        .unwrap();
        b.update(&Vector1::new(3.0), &H, &Matrix1::new(9.0), UpdateOptions::default()).unwrap();
        assert!((a.x() - b.x()).amax() < 1e-12 && (a.P() - b.P()).amax() < 1e-12);

        let mut c = hand_filter();
        let before = c;
        let mut reject = Inflate(0.0);
        let d = c
            .update(
                &Vector1::new(3.0),
                &H,
                &Matrix1::new(1.0),
                UpdateOptions { gate: None, fault_detector: Some(&mut reject) },
            )
            .unwrap();
        assert_eq!(d.decision, UpdateDecision::RejectedByHook);
        assert_eq!(c, before);
    }

    #[test]
    fn f32_filter_matches_f64() {
        let mut a = KalmanFilter::<f32, 2>::new(Vector2::new(1.0, 2.0), Matrix2::new(4.0, 1.0, 1.0, 2.0)).unwrap();
        a.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default()).unwrap();
        assert!((a.x()[0] - 2.6).abs() < 1e-6 && (a.P()[(1, 1)] - 1.8).abs() < 1e-6);
    }
}
