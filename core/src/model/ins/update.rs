//! The `ins` model's measurement updates: a residual with its Jacobian, or a
//! block of the state selected (Joseph form, gated as configured), the
//! correction injected into the nominal state and the error reset
//! ([`super::error_state`]).

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::{InsModel, InsState, inject_and_reset, observability};
use crate::filter::{ChiSquareGate, FaultDecision, FaultDetector, MeasurementView, UpdateDecision, UpdateOptions};
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

    /// [`update_residual`](Self::update_residual) of the components `keep`
    /// selects only (`[sensor.twist] fuse`, `[sensor.pose] fuse`): the others
    /// are dropped from the update (their rows of `H` and `y` zero, decorrelated
    /// in `R`), and the gate counts the kept ones.
    pub(crate) fn update_residual_selected<const M: usize>(
        &self,
        s: &mut InsState<D>,
        y: &SVector<f64, M>,
        H: &SMatrix<f64, M, D>,
        R: &SMatrix<f64, M, M>,
        keep: &[bool; M],
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        if keep.iter().all(|k| *k) {
            return self.update_residual(s, y, H, R);
        }
        // The components not selected are left out before anything reads
        // them: what a driver sent there (NaN, garbage) is never looked at,
        // and the update is the same whatever it was.
        let mut view = MeasurementView::new(*y, *H, *R, *R);
        Select(keep).inspect(&mut view);
        self.update_with(s, &view.residual, &view.H, &view.R, self.gate.as_ref(), Some(keep))
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
        self.update_with(s, y, H, R, gate, None)
    }

    fn update_with<const M: usize>(
        &self,
        s: &mut InsState<D>,
        y: &SVector<f64, M>,
        H: &SMatrix<f64, M, D>,
        R: &SMatrix<f64, M, M>,
        gate: Option<&ChiSquareGate>,
        keep: Option<&[bool; M]>,
    ) -> (StepOutcome, Option<SVector<f64, D>>) {
        let gate = if s.kind_runs.resetting() {
            let mut view = MeasurementView::new(*y, *H, *R, *R);
            if let Some(keep) = keep {
                Select(keep).inspect(&mut view);
            }
            forget_observed(s, &view.residual, &view.H, &view.R, keep);
            None
        } else {
            gate
        };
        let mut select = keep.map(Select);
        let fault_detector = select.as_mut().map(|s| s as &mut dyn FaultDetector<f64, D, M>);
        let options = UpdateOptions { gate, fault_detector, consider: self.heading_considered(s) };
        match s.kf.update_nonlinear(y, &SVector::zeros(), H, R, options) {
            Ok(d) if d.decision == UpdateDecision::Accepted => {
                (StepOutcome::Fused { nis: d.nis }, Some(inject_and_reset(s)))
            }
            Ok(d) => (StepOutcome::Gated { nis: d.nis }, None),
            Err(_) => (StepOutcome::Refused, None),
        }
    }

    /// The heading as a consider direction of every update while nothing
    /// configured observes it ([`super::observability`]); `None` otherwise.
    fn heading_considered(&self, s: &InsState<D>) -> Option<SVector<f64, D>> {
        self.yaw_unobserved.then(|| observability::heading(&s.q()))
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

/// The components a selection leaves out, dropped from an update (the
/// filter's hook, [`MeasurementView::drop_component`]).
struct Select<'a, const M: usize>(&'a [bool; M]);

impl<const D: usize, const M: usize> FaultDetector<f64, D, M> for Select<'_, M> {
    fn inspect(&mut self, m: &mut MeasurementView<f64, D, M>) -> FaultDecision {
        for (i, keep) in self.0.iter().enumerate() {
            if !keep {
                m.drop_component(i);
            }
        }
        FaultDecision::Modified
    }
}

/// A reset after a lock-out ([`crate::model::lockout`]): the prior forgotten
/// along what the measurement observes, `P ← P + A (y yᵀ + S) Aᵀ` with
/// `A = Hᵀ (H Hᵀ)⁻¹` and `S = H P Hᵀ + R`, so that `H P Hᵀ` grows by
/// `y yᵀ + S`; of a selection, its kept rows (the dropped ones are zero in
/// `y`, `H`, and unit in `(H Hᵀ)` so that they add nothing). Nothing is
/// forgotten where `H Hᵀ` is singular.
fn forget_observed<const D: usize, const M: usize>(
    s: &mut InsState<D>,
    y: &SVector<f64, M>,
    H: &SMatrix<f64, M, D>,
    R: &SMatrix<f64, M, M>,
    keep: Option<&[bool; M]>,
) {
    let mut HHt = H * H.transpose();
    for (i, k) in keep.into_iter().flatten().enumerate() {
        if !k {
            HHt[(i, i)] = 1.0;
        }
    }
    let Some(G) = HHt.try_inverse() else { return };
    let A = H.transpose() * G;
    s.kf.reset_error(|P| {
        let W = y * y.transpose() + *H * *P * H.transpose() + R;
        *P += A * W * A.transpose();
    });
}
