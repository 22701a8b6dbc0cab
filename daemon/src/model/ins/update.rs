//! The `ins` model's measurement updates: a residual with its Jacobian, or a
//! block of the state selected (Joseph form, gated as configured), the
//! correction injected into the nominal state and the error reset
//! ([`super::error_state`]).

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::{InsModel, InsState, inject_and_reset};
use crate::filter::{ChiSquareGate, UpdateDecision, UpdateOptions};
use crate::model::StepOutcome;

impl<const D: usize> InsModel<D> {
    /// Fuses a measurement with residual `y = z − h(x)` (given, so a caller can
    /// wrap angles) and Jacobian `H` with respect to the error state: Joseph
    /// form, gated as configured; a fused correction is injected into the
    /// nominal state and the error reset, and returned.
    pub(crate) fn update_residual<const M: usize>(
        &self,
        s: &mut InsState<D>,
        y: &SVector<f64, M>,
        H: &SMatrix<f64, M, D>,
        R: &SMatrix<f64, M, M>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        self.update_residual_gated(s, y, H, R, self.gate.as_ref())
    }

    /// [`update_residual`](Self::update_residual) with `gate` instead of the
    /// configured one (`None`: not gated).
    pub(crate) fn update_residual_gated<const M: usize>(
        &self,
        s: &mut InsState<D>,
        y: &SVector<f64, M>,
        H: &SMatrix<f64, M, D>,
        R: &SMatrix<f64, M, M>,
        gate: Option<&ChiSquareGate>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        let gate = if s.lockout.kinds.resetting() {
            forget_observed(s, y, H, R);
            None
        } else {
            gate
        };
        let options = UpdateOptions { gate, fault_detector: None };
        match s.kf.update_nonlinear(y, &SVector::zeros(), H, R, options) {
            Ok(d) if d.decision == UpdateDecision::Accepted => {
                (StepOutcome::Fused { nis: d.nis }, Some(inject_and_reset(s)))
            }
            Ok(d) => (StepOutcome::Gated { nis: d.nis }, None),
            Err(_) => (StepOutcome::Refused, None),
        }
    }

    /// Fuses `z = x[offset..offset+3] + n`, `n ~ N(0, R)`, a measurement of three
    /// consecutive nominal states that are also error states (δp at 0, δv at 3):
    /// `H` selects them, `h(x) = predicted` (the nominal value: the error is zero
    /// before the update). Joseph form, gated as configured; a fused correction is
    /// injected into the nominal state and the error reset, and returned.
    pub(crate) fn update_block(
        &self,
        s: &mut InsState<D>,
        z: &Vector3<f64>,
        predicted: &Vector3<f64>,
        offset: usize,
        R: &Matrix3<f64>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        let (decision, nis) = match s.kf.update_selection_lean(z, predicted, offset, R, self.gate.as_ref()) {
            Ok(d) => d,
            Err(_) => return (StepOutcome::Refused, None),
        };
        if decision != UpdateDecision::Accepted {
            return (StepOutcome::Gated { nis }, None);
        }
        (StepOutcome::Fused { nis }, Some(inject_and_reset(s)))
    }
}

/// A reset after a lock-out ([`crate::model::lockout`]): the prior forgotten
/// along what the measurement observes, `P ← P + A (y yᵀ + S) Aᵀ` with
/// `A = Hᵀ (H Hᵀ)⁻¹` and `S = H P Hᵀ + R`, so that `H P Hᵀ` grows by
/// `y yᵀ + S`. Nothing is forgotten where `H Hᵀ` is singular.
fn forget_observed<const D: usize, const M: usize>(
    s: &mut InsState<D>,
    y: &SVector<f64, M>,
    H: &SMatrix<f64, M, D>,
    R: &SMatrix<f64, M, M>,
) {
    let Some(G) = (H * H.transpose()).try_inverse() else { return };
    let A = H.transpose() * G;
    s.kf.reset_error(|P| {
        let W = y * y.transpose() + *H * *P * H.transpose() + R;
        *P += A * W * A.transpose();
    });
}
