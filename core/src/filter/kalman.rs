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
mod factored;
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
    /// The process noise `Q` is not symmetric positive semi-definite (UDU form:
    /// it has no UDU factors).
    #[error("process noise is not symmetric positive semi-definite")]
    ProcessNoiseNotPositiveSemiDefinite,
    /// The measurement noise `R` is not positive definite (UDU form: it has no
    /// Cholesky factor to decorrelate the components with).
    #[error("measurement noise R is not positive definite")]
    MeasurementNoiseNotPositiveDefinite,
    /// A model was asked for another state dimension than its states have.
    #[error("state dimension {got} is not the model's {expected}")]
    StateDimension {
        /// The dimension asked for.
        got: usize,
        /// The model's.
        expected: usize,
    },
}

/// How a [`KalmanFilter`] holds and updates its covariance (`[filter] form`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// `P` itself, the Joseph-form update and the dense (or model-structured)
    /// `F P Fᵀ + Q` predict.
    #[default]
    Joseph,
    /// The factors `P = U D Uᵀ`, Thornton's MWGS predict and Bierman's sequential
    /// scalar update ([`super::udu`]): positive definite by construction, and the
    /// factors span about the square root of `P`'s dynamic range.
    Udu,
}

impl Form {
    /// Name as in the config.
    pub fn name(self) -> &'static str {
        match self {
            Form::Joseph => "joseph",
            Form::Udu => "udu",
        }
    }
}

/// A Kalman filter on a fixed-size state: the estimate and its covariance (as `P`
/// or as its UDU factors, by [`Form`]), nothing else, so that a history of filter
/// states stays small and cheap to copy.
///
/// What the RTS smoother needs of a step (prior, transition) is kept by the
/// smoother's `StepLog` around the calls, only when a caller smooths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KalmanFilter<T: RealField + Copy, const N: usize> {
    x: SVector<T, N>,
    /// [`Form::Joseph`]: `P`. [`Form::Udu`]: `P`'s packed factors (`D` on the
    /// diagonal, `U` above it; [`super::udu`]).
    c: SMatrix<T, N, N>,
    form: Form,
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
    /// positive definite (checked by Cholesky), in the Joseph form (see
    /// [`with_form`](Self::with_form)).
    pub fn new(x0: SVector<T, N>, P0: SMatrix<T, N, N>) -> Result<Self, FilterError> {
        if !all_finite(&x0) || !all_finite(&P0) {
            return Err(FilterError::NonFinite("initial state"));
        }
        let tol = T::from_subset(&1e-9) * P0.amax();
        if (P0 - P0.transpose()).amax() > tol || Cholesky::new(P0).is_none() {
            return Err(FilterError::CovarianceNotPositiveDefinite);
        }
        Ok(Self { x: x0, c: P0, form: Form::Joseph })
    }

    /// State estimate (posterior of the last update, or prior if none followed).
    pub fn x(&self) -> &SVector<T, N> {
        &self.x
    }

    /// Covariance of [`x`](Self::x) (in the UDU form composed from the factors,
    /// `U D Uᵀ`).
    pub fn P(&self) -> SMatrix<T, N, N> {
        match self.form {
            Form::Joseph => self.c,
            Form::Udu => super::udu::compose(&self.c),
        }
    }

    /// Overwrites the estimate, e.g. after an error-state reset. Refused (state
    /// unchanged) if anything is non-finite, or in the UDU form if `P` is not
    /// positive definite.
    pub fn set_state(&mut self, x: SVector<T, N>, P: SMatrix<T, N, N>) -> Result<(), FilterError> {
        if !all_finite(&x) || !all_finite(&P) {
            return Err(FilterError::NonFinite("state"));
        }
        let mut P = P;
        symmetrize(&mut P);
        self.c = self.stored(P)?;
        self.x = x;
        Ok(())
    }

    /// Error-state reset: `x ← 0`, and `P` changed in place by `reset` (e.g. a
    /// variance raised to a floor). The change must keep `P` symmetric positive
    /// definite; in the UDU form `P` is composed, changed and factorised again
    /// (kept as it was if the change left it without factors). For a linear
    /// transform `P ← G P Gᵀ` use [`reset_transform`](Self::reset_transform),
    /// which works on the factors.
    pub fn reset_error(&mut self, reset: impl FnOnce(&mut SMatrix<T, N, N>)) {
        self.x = SVector::zeros();
        match self.form {
            Form::Joseph => reset(&mut self.c),
            Form::Udu => {
                let mut P = self.P();
                reset(&mut P);
                if let Some(ud) = super::udu::factorize(&P, T::zero()) {
                    self.c = ud;
                }
            }
        }
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
    /// structure of its `F` and `G` instead of dense products: `propagate_x(x)`
    /// turns `x` into `x⁻ = f(x)`; in the Joseph form `propagate_P(P)` turns `P`
    /// in place into exactly `P⁻ = F P Fᵀ + Q`, symmetric (it is taken as it is,
    /// not symmetrised: a structured propagation computes one triangle and
    /// mirrors it); in the UDU form `transition()` gives `(F, Q)` for Thornton's
    /// update of the factors. Only the one the form needs is called. A
    /// non-finite result is refused and leaves the filter as it was.
    pub fn predict_structured(
        &mut self,
        propagate_x: impl FnOnce(&mut SVector<T, N>),
        propagate_P: impl FnOnce(&mut SMatrix<T, N, N>),
        transition: impl FnOnce() -> (SMatrix<T, N, N>, SMatrix<T, N, N>),
    ) -> Result<(), FilterError> {
        match self.form {
            Form::Joseph => self.change_or_keep("predicted state", |x, P| {
                propagate_x(x);
                propagate_P(P);
            }),
            Form::Udu => {
                let (F, Q) = transition();
                self.predict_factored(propagate_x, &F, &Q)
            }
        }
    }

    fn finish_predict(
        &mut self,
        x: SVector<T, N>,
        F: &SMatrix<T, N, N>,
        Q: &SMatrix<T, N, N>,
    ) -> Result<(), FilterError> {
        if self.form == Form::Udu {
            return self.predict_factored(|x_| *x_ = x, F, Q);
        }
        let mut P = F * self.c * F.transpose() + Q;
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
        change(&mut self.x, &mut self.c);
        if !all_finite(&self.x) || !all_finite(&self.c) {
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
    /// `joseph::joseph_low_rank`), exactly symmetric. In the UDU form `P Hᵀ`
    /// comes from the factors and the accepted update is Bierman's, one
    /// decorrelated component at a time ([`super::udu`]); the state then moves by
    /// `dx` up to rounding.
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
        let consider = options.consider;
        let PHt = self.times_transpose(H);
        let mut view = MeasurementView::new(z - predicted, *H, *R, H * PHt + R);
        let mut decision = UpdateDecision::Accepted;
        let mut PHt = PHt;
        if let Some(hook) = options.fault_detector {
            match hook.inspect(&mut view) {
                FaultDecision::Keep => {}
                FaultDecision::Modified => {
                    PHt = self.times_transpose(&view.H);
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

        // K = P Hᵀ S⁻¹, solved, never inverted; with a consider direction c,
        // K ← (I − c cᵀ) K.
        let mut K = chol.gain(&PHt);
        if let Some(c) = &consider {
            K -= c * (c.transpose() * K);
        }
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

        match self.form {
            Form::Joseph => self.change_or_keep("updated state", |x, P| {
                *x += dx;
                joseph::joseph_low_rank(P, &K, &PHt, &S);
            })?,
            Form::Udu if consider.is_none() => self.update_factors(&y, &view.H, &view.R)?,
            // Thornton-Bierman's update is the optimal gain's: a consider
            // update composes P, takes the Joseph form and factorises again.
            Form::Udu => {
                let mut P = self.P();
                joseph::joseph_low_rank(&mut P, &K, &PHt, &S);
                self.set_state(self.x + dx, P)?;
            }
        }
        Ok(diagnostics)
    }
}

#[cfg(test)]
mod tests;
