//! Discretisation of continuous-time linear models.
//!
//! For `ẋ = A x + B u + G w`, `E[w(t) w(τ)ᵀ] = Q_c δ(t − τ)`, sampled with period `T`:
//! `F = exp(A T)`, `Q_d = ∫₀ᵀ exp(A s) G Q_c Gᵀ exp(Aᵀ s) ds` (Van Loan 1978,
//! "Computing integrals involving the matrix exponential", IEEE TAC 23(3);
//! Simon 2006 §1.4 and §8.1.1), `B_d ≈ T B` (forward Euler).
//! These are set-up helpers, not hot-path code: the models use closed forms.

#![allow(non_snake_case)]

use nalgebra::{DMatrix, RealField, SMatrix};

/// `exp(A T)` (nalgebra's scaling-and-squaring Padé approximant).
pub fn expm<T: RealField + Copy, const N: usize>(A: &SMatrix<T, N, N>, dt: T) -> SMatrix<T, N, N> {
    // nalgebra implements `exp` for generic const sizes only on dynamic matrices.
    let E = DMatrix::from_iterator(N, N, (A * dt).iter().copied()).exp();
    SMatrix::from_iterator(E.iter().copied())
}

/// Van Loan's method: `(F, Q_d)` from the continuous `A` and `G Q_c Gᵀ`.
///
/// ```text
/// M = [ −A   G Q_c Gᵀ ] T,   exp(M) = [ ·   F⁻¹ Q_d ]
///     [  0   Aᵀ       ]              [ 0   Fᵀ      ]
/// F = (exp(M)₂₂)ᵀ,  Q_d = F · exp(M)₁₂
/// ```
pub fn van_loan<T: RealField + Copy, const N: usize, const W: usize>(
    A: &SMatrix<T, N, N>,
    G: &SMatrix<T, N, W>,
    Qc: &SMatrix<T, W, W>,
    dt: T,
) -> (SMatrix<T, N, N>, SMatrix<T, N, N>) {
    let GQG = G * Qc * G.transpose();
    let mut M = DMatrix::<T>::zeros(2 * N, 2 * N);
    M.view_mut((0, 0), (N, N)).copy_from(&(-A * dt));
    M.view_mut((0, N), (N, N)).copy_from(&(GQG * dt));
    M.view_mut((N, N), (N, N)).copy_from(&(A.transpose() * dt));
    let E = M.exp();
    let F: SMatrix<T, N, N> = E.view((N, N), (N, N)).transpose().fixed_view::<N, N>(0, 0).into_owned();
    let E12: SMatrix<T, N, N> = E.view((0, N), (N, N)).fixed_view::<N, N>(0, 0).into_owned();
    let Qd = F * E12;
    (F, (Qd + Qd.transpose()) * T::from_subset(&0.5))
}

/// Forward-Euler input matrix `B_d ≈ T B` (exact when `A B = 0`).
pub fn euler_input<T: RealField + Copy, const N: usize, const U: usize>(
    B: &SMatrix<T, N, U>,
    dt: T,
) -> SMatrix<T, N, U> {
    B * dt
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix1, Matrix2, Matrix2x1};

    #[test]
    fn van_loan_matches_the_closed_form_of_a_white_noise_acceleration_model() {
        // ẋ = [[0,1],[0,0]] x + [0,1] w, q: F = [[1,T],[0,1]],
        // Q_d = q [[T³/3, T²/2], [T²/2, T]] (Bar-Shalom et al. 2001, eq. 6.2.2-12).
        let A = Matrix2::new(0.0, 1.0, 0.0, 0.0);
        let (q, T) = (0.7, 0.3);
        let (F, Qd) = van_loan(&A, &Matrix2x1::new(0.0, 1.0), &Matrix1::new(q), T);
        assert!((F - Matrix2::new(1.0, T, 0.0, 1.0)).amax() < 1e-14);
        let expect = Matrix2::new(T * T * T / 3.0, T * T / 2.0, T * T / 2.0, T) * q;
        assert!((Qd - expect).amax() < 1e-14, "{Qd}");
        assert!((expm(&A, T) - F).amax() < 1e-14);
        assert_eq!(euler_input(&Matrix2x1::new(0.0, 1.0), T), Matrix2x1::new(0.0, T));
    }

    #[test]
    fn expm_of_a_rotation_generator() {
        let A = Matrix2::new(0.0, -1.0, 1.0, 0.0);
        let t = 0.4f64;
        let E = expm(&A, t);
        assert!((E - Matrix2::new(t.cos(), -t.sin(), t.sin(), t.cos())).amax() < 1e-14);
    }
}
