//! The Cholesky factor of a small innovation covariance and the solves an update
//! needs with it.

#![allow(non_snake_case)]

use nalgebra::{RealField, SMatrix, SVector};

/// `L` of `S = L Lᵀ` and the solves an update needs, on fixed sizes with constant
/// bounds (nalgebra's generic triangular solvers iterate dynamic ranges, several
/// times slower at M = 3).
pub(super) struct SmallCholesky<T: RealField + Copy, const M: usize> {
    l: SMatrix<T, M, M>,
}

impl<T: RealField + Copy, const M: usize> SmallCholesky<T, M> {
    /// The factor of a symmetric `S`, or `None` if `S` is not positive definite
    /// (or not finite). Cholesky–Banachiewicz, row by row (Golub & Van Loan 2013,
    /// alg. 4.2.1), on the lower triangle of `S`.
    pub(super) fn new(S: SMatrix<T, M, M>) -> Option<Self> {
        let mut l = SMatrix::<T, M, M>::zeros();
        for j in 0..M {
            let mut d = S[(j, j)];
            for k in 0..j {
                d -= l[(j, k)] * l[(j, k)];
            }
            // Refuses d ≤ 0 and NaN alike.
            if d.partial_cmp(&T::zero()) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let ljj = d.sqrt();
            l[(j, j)] = ljj;
            for i in (j + 1)..M {
                let mut v = S[(i, j)];
                for k in 0..j {
                    v -= l[(i, k)] * l[(j, k)];
                }
                l[(i, j)] = v / ljj;
            }
        }
        Some(Self { l })
    }

    /// `w` with `L w = y`, so that `wᵀ w = yᵀ S⁻¹ y`.
    pub(super) fn whiten(&self, y: &SVector<T, M>) -> SVector<T, M> {
        let mut w = *y;
        for m in 0..M {
            for k in 0..m {
                w[m] = w[m] - self.l[(m, k)] * w[k];
            }
            w[m] /= self.l[(m, m)];
        }
        w
    }

    /// The gain `K = B S⁻¹` for `B = P Hᵀ` (`N × M`): `K L Lᵀ = B`, solved for all
    /// rows at once, one column at a time (forward for `Y = K L`, then backward).
    pub(super) fn gain<const N: usize>(&self, B: &SMatrix<T, N, M>) -> SMatrix<T, N, M> {
        let mut K = *B;
        let x = &mut K.data.0; // x[column][row]
        let l = &self.l;
        for m in 0..M {
            for k in 0..m {
                let c = l[(m, k)];
                let (done, rest) = x.split_at_mut(m);
                for (v, d) in rest[0].iter_mut().zip(&done[k]) {
                    *v -= c * *d;
                }
            }
            let d = T::one() / l[(m, m)];
            x[m].iter_mut().for_each(|v| *v *= d);
        }
        for m in (0..M).rev() {
            for j in (m + 1)..M {
                let c = l[(j, m)];
                let (head, tail) = x.split_at_mut(j);
                for (v, d) in head[m].iter_mut().zip(&tail[0]) {
                    *v -= c * *d;
                }
            }
            let d = T::one() / l[(m, m)];
            x[m].iter_mut().for_each(|v| *v *= d);
        }
        K
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_cholesky_matches_nalgebra_and_refuses_what_is_not_positive_definite() {
        let S = nalgebra::Matrix3::new(4.0, 1.2, -0.6, 1.2, 3.0, 0.5, -0.6, 0.5, 2.0);
        let ours = SmallCholesky::new(S).unwrap().l;
        let reference = nalgebra::Cholesky::new(S).unwrap().unpack();
        assert!((ours - reference).amax() < 1e-15, "{ours} against {reference}");
        // Positive leading minors but the last pivot negative; a zero pivot; NaN.
        let indefinite = nalgebra::Matrix3::new(1.0, 0.9, 0.9, 0.9, 1.0, -0.9, 0.9, -0.9, 1.0);
        assert!(SmallCholesky::new(indefinite).is_none());
        assert!(SmallCholesky::new(nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)).is_none());
        let mut nan = S;
        nan[(2, 2)] = f64::NAN;
        assert!(SmallCholesky::new(nan).is_none());
    }
}
