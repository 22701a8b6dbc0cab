//! Rauch–Tung–Striebel fixed-interval smoother over a logged filter history.
//!
//! Särkkä, *Bayesian Filtering and Smoothing* (2013), Theorem 8.2; Simon 2006 §9.4.2.
//! For steps `k = 0 … n−1` with filter prior `(x⁻ₖ, P⁻ₖ)`, posterior `(x⁺ₖ, P⁺ₖ)` and
//! transition `Fₖ` from step `k−1` to `k`, the backward pass is
//!
//! ```text
//! xˢₙ₋₁ = x⁺ₙ₋₁,  Pˢₙ₋₁ = P⁺ₙ₋₁
//! Cₖ  = P⁺ₖ Fₖ₊₁ᵀ (P⁻ₖ₊₁)⁻¹
//! xˢₖ = x⁺ₖ + Cₖ (xˢₖ₊₁ − x⁻ₖ₊₁)
//! Pˢₖ = P⁺ₖ + Cₖ (Pˢₖ₊₁ − P⁻ₖ₊₁) Cₖᵀ
//! ```
//!
//! This is the smoother of a linear(ised) model; for an error-state filter the
//! model maps its own history onto these terms.

#![allow(non_snake_case)]

use nalgebra::{Cholesky, RealField, SMatrix, SVector};

use super::kalman::KalmanFilter;

/// One logged filter step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtsStep<T: RealField + Copy, const N: usize> {
    /// Prior mean `x⁻ₖ`.
    pub x_prior: SVector<T, N>,
    /// Prior covariance `P⁻ₖ`.
    pub P_prior: SMatrix<T, N, N>,
    /// Posterior mean `x⁺ₖ`.
    pub x_post: SVector<T, N>,
    /// Posterior covariance `P⁺ₖ`.
    pub P_post: SMatrix<T, N, N>,
    /// Transition `Fₖ` from the previous step's posterior to this prior.
    pub F: SMatrix<T, N, N>,
}

/// Builds the [`RtsStep`] of one filter step around the calls that make it: any
/// number of predicts (their `F` compose the step's transition) and then at most
/// one update.
///
/// ```text
/// let mut log = StepLog::begin(&kf);      // x⁻ = x⁺ = x, F = I
/// kf.predict(&F, &Q)?; log.predicted(&kf, &F);
/// kf.update(..)?;
/// let step = log.finish(&kf);             // x⁺, P⁺ = the filter's
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLog<T: RealField + Copy, const N: usize> {
    step: RtsStep<T, N>,
}

impl<T: RealField + Copy, const N: usize> StepLog<T, N> {
    /// Starts a step at the filter's current estimate, with transition `I`.
    pub fn begin(kf: &KalmanFilter<T, N>) -> Self {
        let (x, P) = (*kf.x(), kf.P());
        Self { step: RtsStep { x_prior: x, P_prior: P, x_post: x, P_post: P, F: SMatrix::identity() } }
    }

    /// Records a predict with transition `F` that the filter has just made: the
    /// prior becomes its estimate and the step's transition `F · F_step`.
    pub fn predicted(&mut self, kf: &KalmanFilter<T, N>, F: &SMatrix<T, N, N>) {
        self.step.x_prior = *kf.x();
        self.step.P_prior = kf.P();
        self.step.F = F * self.step.F;
    }

    /// The step's record, with the filter's current estimate as its posterior.
    pub fn finish(mut self, kf: &KalmanFilter<T, N>) -> RtsStep<T, N> {
        self.step.x_post = *kf.x();
        self.step.P_post = kf.P();
        self.step
    }
}

/// Smooths `steps` in place: each posterior is replaced by the smoothed estimate
/// `(xˢₖ, Pˢₖ)`; the priors are left as they were.
///
/// Where the recursion cannot pass from step `k+1` back to step `k` (a prior
/// `P⁻ₖ₊₁` without a Cholesky factor, so `Cₖ` is undefined, or a smoothed
/// result that is not finite or has a negative variance), step `k` keeps its
/// filtered estimate and the recursion starts again from it: `Cₖ = 0`, the
/// run is smoothed as two stretches that end at `k` and start at `k+1`
/// (each exact given its own data). Returns those `k`, in order.
pub fn rts_smooth<T: RealField + Copy, const N: usize>(steps: &mut [RtsStep<T, N>]) -> Vec<usize> {
    let half = T::from_subset(&0.5);
    let mut breaks = Vec::new();
    for k in (0..steps.len().saturating_sub(1)).rev() {
        let next = steps[k + 1];
        let cur = &mut steps[k];
        let Some(chol) = Cholesky::new(next.P_prior) else {
            breaks.push(k);
            continue;
        };
        // Cₖ = P⁺ₖ Fᵀ (P⁻)⁻¹  ⇔  Cₖᵀ = (P⁻)⁻¹ F P⁺ₖ  (both covariances symmetric).
        let C = chol.solve(&(next.F * cur.P_post)).transpose();
        let x = cur.x_post + C * (next.x_post - next.x_prior);
        let P = cur.P_post + C * (next.P_post - next.P_prior) * C.transpose();
        let P = (P + P.transpose()) * half;
        let usable = x.iter().chain(P.iter()).all(|v| v.is_finite()) && (0..N).all(|i| P[(i, i)] >= T::zero());
        if !usable {
            breaks.push(k);
            continue;
        }
        (cur.x_post, cur.P_post) = (x, P);
    }
    breaks.reverse();
    breaks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::kalman::UpdateOptions;
    use nalgebra::{DMatrix, DVector, Matrix1x2, Matrix2, Vector1, Vector2};

    /// Batch MAP solution of the linear-Gaussian problem: minimise
    /// ‖x₀ − m₀‖²_{P₀⁻¹} + Σ ‖xₖ − F xₖ₋₁‖²_{Q⁻¹} + Σ ‖zₖ − H xₖ‖²_{R⁻¹}.
    /// Its mean and the diagonal blocks of the inverse information matrix are the
    /// smoothed means and covariances (Särkkä 2013, §8.1).
    #[test]
    fn rts_equals_batch_least_squares() {
        let n = 8;
        let F = Matrix2::new(1.0, 0.1, 0.0, 1.0);
        let Q = Matrix2::new(0.02, 0.005, 0.005, 0.1);
        let H = Matrix1x2::new(1.0, 0.0);
        let R = 0.3;
        let m0 = Vector2::new(0.5, -1.0);
        let P0 = Matrix2::new(2.0, 0.1, 0.1, 1.0);
        let z: Vec<f64> = (0..n).map(|k| (k as f64 * 0.7).sin() * 2.0 + 0.1 * k as f64).collect();

        let mut kf = KalmanFilter::new(m0, P0).unwrap();
        let mut steps = Vec::new();
        for (k, zk) in z.iter().enumerate() {
            let mut log = StepLog::begin(&kf);
            if k > 0 {
                kf.predict(&F, &Q).unwrap();
                log.predicted(&kf, &F);
            }
            kf.update(&Vector1::new(*zk), &H, &nalgebra::Matrix1::new(R), UpdateOptions::default()).unwrap();
            steps.push(log.finish(&kf));
        }
        assert!(rts_smooth(&mut steps).is_empty());

        let dim = 2 * n;
        let mut info = DMatrix::<f64>::zeros(dim, dim);
        let mut rhs = DVector::<f64>::zeros(dim);
        let add = |info: &mut DMatrix<f64>, r: usize, c: usize, m: &Matrix2<f64>| {
            for i in 0..2 {
                for j in 0..2 {
                    info[(r + i, c + j)] += m[(i, j)];
                }
            }
        };
        let P0i = P0.try_inverse().unwrap();
        add(&mut info, 0, 0, &P0i);
        let v = P0i * m0;
        rhs[0] += v[0];
        rhs[1] += v[1];
        let Qi = Q.try_inverse().unwrap();
        for k in 1..n {
            let (a, b) = (2 * (k - 1), 2 * k);
            add(&mut info, a, a, &(F.transpose() * Qi * F));
            add(&mut info, a, b, &(-(F.transpose() * Qi)));
            add(&mut info, b, a, &(-(Qi * F)));
            add(&mut info, b, b, &Qi);
        }
        for (k, zk) in z.iter().enumerate() {
            add(&mut info, 2 * k, 2 * k, &(H.transpose() * H / R));
            let v = H.transpose() * (zk / R);
            rhs[2 * k] += v[0];
            rhs[2 * k + 1] += v[1];
        }
        let cov = info.clone().try_inverse().unwrap();
        let mean = &cov * rhs;
        for (k, s) in steps.iter().enumerate() {
            for i in 0..2 {
                assert!((s.x_post[i] - mean[2 * k + i]).abs() < 1e-10, "step {k} x[{i}]");
                for j in 0..2 {
                    assert!((s.P_post[(i, j)] - cov[(2 * k + i, 2 * k + j)]).abs() < 1e-10, "step {k} P[{i},{j}]");
                }
            }
        }
        // The last step is the filter's own posterior; earlier ones must have changed.
        assert!((steps[0].P_post[(0, 0)] - P0[(0, 0)]).abs() > 1e-3);
    }

    /// A prior without a Cholesky factor in the middle of a run: the run is
    /// smoothed as the two stretches on either side of it, each as it would be
    /// alone, and the step before it keeps its filtered estimate.
    #[test]
    fn a_singular_prior_splits_the_run_into_stretches_smoothed_apart() {
        let F = Matrix2::new(1.0, 0.1, 0.0, 1.0);
        let Q = Matrix2::new(0.02, 0.005, 0.005, 0.1);
        let H = Matrix1x2::new(1.0, 0.0);
        let mut kf = KalmanFilter::new(Vector2::new(0.5, -1.0), Matrix2::new(2.0, 0.1, 0.1, 1.0)).unwrap();
        let mut steps = Vec::new();
        for k in 0..10 {
            let mut log = StepLog::begin(&kf);
            if k > 0 {
                kf.predict(&F, &Q).unwrap();
                log.predicted(&kf, &F);
            }
            let z = Vector1::new((k as f64 * 0.7).sin());
            kf.update(&z, &H, &nalgebra::Matrix1::new(0.3), UpdateOptions::default()).unwrap();
            steps.push(log.finish(&kf));
        }
        let filtered = steps.clone();
        steps[6].P_prior = Matrix2::new(1.0, 2.0, 2.0, 1.0); // indefinite
        let (mut first, mut second) = (steps[..6].to_vec(), steps[6..].to_vec());
        assert_eq!(rts_smooth(&mut steps), vec![5]);
        assert!(rts_smooth(&mut first).is_empty() && rts_smooth(&mut second).is_empty());
        assert_eq!(steps[..6], first[..]);
        assert_eq!(steps[6..], second[..]);
        assert_eq!(steps[5].x_post, filtered[5].x_post, "the step before the break keeps its filtered estimate");
        assert_ne!(steps[4].x_post, filtered[4].x_post, "the stretch before it is smoothed");
        // Every prior singular: nothing can be smoothed, nothing fails.
        let zero: RtsStep<f64, 2> = RtsStep { P_prior: Matrix2::zeros(), ..filtered[1] };
        let mut all = [zero, zero, zero];
        assert_eq!(rts_smooth(&mut all), vec![0, 1]);
        assert_eq!(all[0], zero);
    }
}
