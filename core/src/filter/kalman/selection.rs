//! The update for a measurement that selects consecutive states (`H = [0 I 0]`).

#![allow(non_snake_case)]

use nalgebra::{RealField, SMatrix, SVector};

use super::joseph::joseph_low_rank;
use super::{
    FilterError, Form, KalmanFilter, SmallCholesky, UpdateDecision, UpdateDiagnostics, UpdateOptions, all_finite,
    symmetrize,
};
use crate::filter::gate::ChiSquareGate;

impl<T: RealField + Copy, const N: usize> KalmanFilter<T, N> {
    /// Update for a measurement of `M` consecutive states starting at `offset`
    /// (`H = [0 I 0]`, e.g. a position fix), `z = x[offset..offset+M] + v`, or of
    /// their nonlinear function with `predicted = h(x⁻)` and that same selection as
    /// its Jacobian. Same equations, gate and results as
    /// [`update_nonlinear`](Self::update_nonlinear), exploiting the selection:
    /// `P Hᵀ` is `M` columns of `P`, `S = P_sel + R`, and the Joseph form
    /// `(I − K H) P (I − K H)ᵀ + K R Kᵀ = A − A_sel Kᵀ + K R Kᵀ` with
    /// `A = P − K P_sel,rows`: O(N² M) instead of O(N³). Without a fault hook
    /// only: a hook may edit `H`, so the general path serves it.
    pub fn update_selection<const M: usize>(
        &mut self,
        z: &SVector<T, M>,
        predicted: &SVector<T, M>,
        offset: usize,
        R: &SMatrix<T, M, M>,
        gate: Option<&ChiSquareGate>,
    ) -> Result<UpdateDiagnostics<T, N, M>, FilterError> {
        let c = self.selection_core(z, predicted, offset, R, gate)?;
        let mut H = SMatrix::<T, M, N>::zeros();
        H.fixed_view_mut::<M, M>(0, offset).fill_with_identity();
        Ok(UpdateDiagnostics {
            decision: c.decision,
            z: *z,
            predicted: *predicted,
            residual: z - predicted,
            H,
            R: *R,
            S: c.S,
            K: c.K,
            dx: c.K * (z - predicted),
            nis: c.nis,
            dims: M,
            gate_threshold: c.gate_threshold,
        })
    }

    /// [`update_selection`](Self::update_selection) returning only the decision
    /// and the NIS: the same update, without assembling the diagnostics (a
    /// measurable share of a 15-state update).
    pub fn update_selection_lean<const M: usize>(
        &mut self,
        z: &SVector<T, M>,
        predicted: &SVector<T, M>,
        offset: usize,
        R: &SMatrix<T, M, M>,
        gate: Option<&ChiSquareGate>,
    ) -> Result<(UpdateDecision, T), FilterError> {
        self.selection_core(z, predicted, offset, R, gate).map(|c| (c.decision, c.nis))
    }

    fn selection_core<const M: usize>(
        &mut self,
        z: &SVector<T, M>,
        predicted: &SVector<T, M>,
        offset: usize,
        R: &SMatrix<T, M, M>,
        gate: Option<&ChiSquareGate>,
    ) -> Result<SelectionCore<T, N, M>, FilterError> {
        assert!(offset + M <= N, "selection out of the state");
        if self.form == Form::Udu {
            // The factors have no cheap selection: the general update serves.
            let mut H = SMatrix::<T, M, N>::zeros();
            H.fixed_view_mut::<M, M>(0, offset).fill_with_identity();
            let options = UpdateOptions { gate, fault_detector: None, consider: None };
            let d = self.update_nonlinear(z, predicted, &H, R, options)?;
            let (decision, nis, gate_threshold, S, K) = (d.decision, d.nis, d.gate_threshold, d.S, d.K);
            return Ok(SelectionCore { decision, nis, gate_threshold, S, K });
        }
        if !all_finite(z) || !all_finite(predicted) || !all_finite(R) {
            return Err(FilterError::NonFinite("measurement"));
        }
        // P Hᵀ: columns `offset..offset + M` of P; S = H P Hᵀ + R: their rows there.
        // (Plain array copies: nalgebra's strided views cost more than the copy.)
        let mut PHt = SMatrix::<T, N, M>::zeros();
        PHt.data.0.copy_from_slice(&self.c.data.0[offset..offset + M]);
        let mut S = *R;
        for (s, b) in S.data.0.iter_mut().zip(&PHt.data.0) {
            for (v, p) in s.iter_mut().zip(&b[offset..offset + M]) {
                *v += *p;
            }
        }
        symmetrize(&mut S);
        let chol = SmallCholesky::new(S).ok_or(FilterError::InnovationNotPositiveDefinite)?;
        let y = z - predicted;
        let K = chol.gain(&PHt);
        let w = chol.whiten(&y);
        let nis = w.dot(&w);
        let gate_threshold = gate.map(|g| T::from_subset(&g.threshold(M)));
        let decision =
            if gate_threshold.is_some_and(|th| nis > th) { UpdateDecision::Gated } else { UpdateDecision::Accepted };
        let core = SelectionCore { decision, nis, gate_threshold, S, K };
        if decision != UpdateDecision::Accepted {
            return Ok(core);
        }
        self.change_or_keep("updated state", |x, P| {
            for (k, y) in K.data.0.iter().zip(y.iter()) {
                for (x, k) in x.iter_mut().zip(k) {
                    *x += *k * *y;
                }
            }
            joseph_low_rank(P, &K, &PHt, &S);
        })?;
        Ok(core)
    }
}

/// What [`KalmanFilter::selection_core`] decided and computed.
struct SelectionCore<T: RealField + Copy, const N: usize, const M: usize> {
    decision: UpdateDecision,
    nis: T,
    gate_threshold: Option<T>,
    S: SMatrix<T, M, M>,
    K: SMatrix<T, N, M>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::UpdateOptions;

    #[test]
    fn selection_update_equals_the_general_one() {
        let gate = ChiSquareGate::new(0.999).unwrap();
        let L =
            SMatrix::<f64, 6, 6>::from_fn(|i, j| if i >= j { 0.5 + ((i * 5 + j * 3) % 7) as f64 * 0.1 } else { 0.0 });
        let P = L * L.transpose();
        let x = nalgebra::Vector6::new(1.0, -2.0, 0.5, 3.0, 0.0, -1.0);
        let mut a = KalmanFilter::new(x, P).unwrap();
        let mut b = a;
        let z = nalgebra::Vector3::new(0.4, 3.2, -0.9);
        let R = nalgebra::Matrix3::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.05, 0.0, 0.05, 0.6);
        let mut H = SMatrix::<f64, 3, 6>::zeros();
        H.fixed_view_mut::<3, 3>(0, 2).fill_with_identity();
        let da =
            a.update(&z, &H, &R, UpdateOptions { gate: Some(&gate), fault_detector: None, consider: None }).unwrap();
        let predicted = H * x;
        let db = b.update_selection(&z, &predicted, 2, &R, Some(&gate)).unwrap();
        assert_eq!(da.decision, db.decision);
        assert!((da.nis - db.nis).abs() < 1e-12 && (da.K - db.K).amax() < 1e-12);
        assert!((a.x() - b.x()).amax() < 1e-12 && (a.P() - b.P()).amax() < 1e-12);
    }
}
