//! What an update works on and reports: the decision, the fault-detection hook
//! and its view of the measurement, the diagnostics, the options.
//!
//! The update itself (Joseph form, gating) is in the `kalman` module, which re-exports these types.

#![allow(non_snake_case)]

use nalgebra::{Cholesky, RealField, SMatrix, SVector};

use super::gate::ChiSquareGate;

/// What happened to a measurement offered to `KalmanFilter::update`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpdateDecision {
    /// Fused into the state.
    Accepted,
    /// Refused by the chi-square gate (NIS above the threshold); state untouched.
    Gated,
    /// Refused by the fault-detection hook; state untouched.
    RejectedByHook,
}

/// A fault-detection hook's verdict on a measurement (see [`FaultDetector`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultDecision {
    /// Use the measurement as it is.
    Keep,
    /// The hook edited the measurement (dropped or re-weighted components); `S` is
    /// recomputed from the edited `H` and `R` before gating and the gain.
    Modified,
    /// Do not use the measurement at all.
    Reject,
}

/// The measurement as the fault-detection hook sees it, before the gain is computed.
#[derive(Debug, Clone, Copy)]
pub struct MeasurementView<T: RealField + Copy, const N: usize, const M: usize> {
    /// Residual (innovation) `y = z − h(x⁻)`.
    pub residual: SVector<T, M>,
    /// Measurement Jacobian `H`.
    pub H: SMatrix<T, M, N>,
    /// Measurement noise covariance `R`.
    pub R: SMatrix<T, M, M>,
    /// Innovation covariance `S = H P⁻ Hᵀ + R` of the unedited measurement.
    pub S: SMatrix<T, M, M>,
    active: [bool; M],
}

impl<T: RealField + Copy, const N: usize, const M: usize> MeasurementView<T, N, M> {
    pub(crate) fn new(residual: SVector<T, M>, H: SMatrix<T, M, N>, R: SMatrix<T, M, M>, S: SMatrix<T, M, M>) -> Self {
        Self { residual, H, R, S, active: [true; M] }
    }

    /// Removes component `i` from the update: its residual and row of `H` become
    /// zero and it is decorrelated from the others with unit variance, so it adds
    /// nothing to the gain, the NIS or the gate's degrees of freedom.
    pub fn drop_component(&mut self, i: usize) {
        self.residual[i] = T::zero();
        for j in 0..N {
            self.H[(i, j)] = T::zero();
        }
        for j in 0..M {
            self.R[(i, j)] = T::zero();
            self.R[(j, i)] = T::zero();
        }
        self.R[(i, i)] = T::one();
        self.active[i] = false;
    }

    /// Scales the variance of component `i` by `factor` (> 1 down-weights it),
    /// keeping its correlations: row and column `i` of `R` are scaled by √factor.
    pub fn reweight_component(&mut self, i: usize, factor: T) {
        let s = factor.sqrt();
        for j in 0..M {
            self.R[(i, j)] *= s;
            self.R[(j, i)] *= s;
        }
    }

    /// Number of components still in the measurement.
    pub fn active_dims(&self) -> usize {
        self.active.iter().filter(|a| **a).count()
    }
}

/// A user-supplied fault-detection hook, run on every update before gating and the
/// gain (e.g. a per-axis residual test that drops a bad component of a GNSS fix).
pub trait FaultDetector<T: RealField + Copy, const N: usize, const M: usize> {
    /// Inspects, and may edit, the measurement.
    fn inspect(&mut self, measurement: &mut MeasurementView<T, N, M>) -> FaultDecision;
}

/// Diagnostics of one update, returned by `KalmanFilter::update` whether or not
/// the measurement was fused.
#[derive(Debug, Clone, Copy)]
pub struct UpdateDiagnostics<T: RealField + Copy, const N: usize, const M: usize> {
    /// Accepted, gated or rejected by the hook.
    pub decision: UpdateDecision,
    /// The measurement `z`.
    pub z: SVector<T, M>,
    /// Predicted measurement `h(x⁻)` (`H x⁻` for a linear update).
    pub predicted: SVector<T, M>,
    /// Residual `y = z − h(x⁻)` after the hook's edits.
    pub residual: SVector<T, M>,
    /// `H` used (after the hook's edits).
    pub H: SMatrix<T, M, N>,
    /// `R` used (after the hook's edits).
    pub R: SMatrix<T, M, M>,
    /// Innovation covariance `S = H P⁻ Hᵀ + R`.
    pub S: SMatrix<T, M, M>,
    /// Gain `K = P⁻ Hᵀ S⁻¹`.
    pub K: SMatrix<T, N, M>,
    /// Correction `dx = K y` (applied only if accepted).
    pub dx: SVector<T, N>,
    /// Normalised innovation squared `NIS = yᵀ S⁻¹ y`.
    pub nis: T,
    /// Degrees of freedom `m` (components left after the hook).
    pub dims: usize,
    /// Gate threshold used, if gating was on.
    pub gate_threshold: Option<T>,
}

impl<T: RealField + Copy, const N: usize, const M: usize> UpdateDiagnostics<T, N, M> {
    /// Covariance of the correction `Σdx = K S Kᵀ` (computed on request).
    pub fn sigma_dx(&self) -> SMatrix<T, N, N> {
        self.K * self.S * self.K.transpose()
    }

    /// Gaussian log-likelihood of the residual, `−½ (NIS + ln|S| + m ln 2π)`
    /// (computed on request; `None` if S has no Cholesky factor).
    pub fn log_likelihood(&self) -> Option<T> {
        let chol = Cholesky::new(self.S)?;
        let ln_det_S = chol.l().diagonal().iter().fold(T::zero(), |acc, d| acc + d.ln()) * T::from_subset(&2.0);
        let m = T::from_subset(&(self.dims as f64));
        Some(-(self.nis + ln_det_S + m * T::two_pi().ln()) * T::from_subset(&0.5))
    }
}

/// Options of one update.
pub struct UpdateOptions<'a, T: RealField + Copy, const N: usize, const M: usize> {
    /// Chi-square gate; `None` fuses every measurement with a valid S.
    pub gate: Option<&'a ChiSquareGate>,
    /// Fault-detection hook; `None` keeps every measurement as it is.
    pub fault_detector: Option<&'a mut dyn FaultDetector<T, N, M>>,
    /// A unit direction `c` of the state that the update must not move: a
    /// consider state (Schmidt, "Application of state-space methods to
    /// navigation problems", 1966). The gain becomes `K ← (I − c cᵀ) K` and the
    /// covariance the Joseph form's for that gain,
    /// `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, exact for any gain: the variance
    /// along `c` is left as it was, its correlations with the rest follow the
    /// update. `None`: the optimal gain.
    pub consider: Option<SVector<T, N>>,
}

impl<T: RealField + Copy, const N: usize, const M: usize> Default for UpdateOptions<'_, T, N, M> {
    fn default() -> Self {
        Self { gate: None, fault_detector: None, consider: None }
    }
}
