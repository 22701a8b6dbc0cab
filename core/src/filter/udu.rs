//! The covariance as UDU factors, `P = U D Uᵀ` (`U` unit upper-triangular, `D`
//! diagonal), and the algorithms that work on the factors only:
//!
//! - [`factorize`]: the modified Cholesky decomposition of a symmetric `P`
//!   (Bierman 1977, *Factorization Methods for Discrete Sequential Estimation*,
//!   §III.2; Grewal & Andrews 2015, *Kalman Filtering*, 4th ed., §6.4.1).
//! - [`thornton`]: the time update `U D Uᵀ ← F U D Uᵀ Fᵀ + G D_q Gᵀ` by Thornton's
//!   modified weighted Gram–Schmidt (MWGS) orthogonalisation of the rows of
//!   `W = [F U, G]` with the weights `diag(D, D_q)` (Thornton 1976; Bierman 1977,
//!   §VI.4; Grewal & Andrews 2015, §6.6.3.2).
//! - [`bierman`]: the measurement update of one scalar `z = h x + v`, `v ~ N(0, r)`,
//!   Bierman's algorithm (Bierman 1977, §V.3; Grewal & Andrews 2015, §6.5.3).
//!
//! The factors are stored packed in one `N × N` matrix: `D` on the diagonal and `U`
//! above it (`U`'s unit diagonal and zero lower triangle are implied), so a
//! factored filter state is exactly as large as a dense covariance.
//!
//! In exact arithmetic these give the same `P` as the dense forms; in floating
//! point the factors represent a `P` that is symmetric and positive semi-definite
//! by construction (`D ≥ 0`), and the factors span about the square root of `P`'s
//! dynamic range, which is what lets the UDU form run in single precision.

#![allow(non_snake_case)]

use nalgebra::{RealField, SMatrix, SVector};

/// `U D Uᵀ` of packed factors (`D` on the diagonal, `U` strictly above it),
/// exactly symmetric.
pub fn compose<T: RealField + Copy, const N: usize>(ud: &SMatrix<T, N, N>) -> SMatrix<T, N, N> {
    let mut P = SMatrix::<T, N, N>::zeros();
    // P_ij = Σ_{k ≥ max(i, j)} U_ik D_k U_jk (U_kk = 1), upper triangle, mirrored.
    for j in 0..N {
        for i in 0..=j {
            let mut v = ud[(j, j)] * if i == j { T::one() } else { ud[(i, j)] };
            for k in (j + 1)..N {
                v += ud[(i, k)] * ud[(k, k)] * ud[(j, k)];
            }
            P[(i, j)] = v;
            P[(j, i)] = v;
        }
    }
    P
}

/// Variance `P_ii = D_i + Σ_{k > i} U_ik² D_k` of packed factors.
pub fn variance<T: RealField + Copy, const N: usize>(ud: &SMatrix<T, N, N>, i: usize) -> T {
    let mut v = ud[(i, i)];
    for k in (i + 1)..N {
        v += ud[(i, k)] * ud[(i, k)] * ud[(k, k)];
    }
    v
}

/// `P Hᵀ = U (D (Uᵀ Hᵀ))` of packed factors, in O(N² M).
pub fn times_transpose<T: RealField + Copy, const N: usize, const M: usize>(
    ud: &SMatrix<T, N, N>,
    H: &SMatrix<T, M, N>,
) -> SMatrix<T, N, M> {
    let mut out = SMatrix::<T, N, M>::zeros();
    for m in 0..M {
        // f = Uᵀ hᵀ, then f ← D f, then U f.
        let mut f = [T::zero(); N];
        for (j, fj) in f.iter_mut().enumerate() {
            let mut v = H[(m, j)];
            for i in 0..j {
                v += ud[(i, j)] * H[(m, i)];
            }
            *fj = v * ud[(j, j)];
        }
        for i in 0..N {
            let mut v = f[i];
            for (k, fk) in f.iter().enumerate().skip(i + 1) {
                v += ud[(i, k)] * *fk;
            }
            out[(i, m)] = v;
        }
    }
    out
}

/// The packed UDU factors of a symmetric positive semi-definite `P` (its upper
/// triangle is read), or `None` if a pivot is negative beyond rounding or
/// anything is not finite. From the last column back (Bierman 1977, §III.2):
///
/// ```text
/// D_j  = P_jj − Σ_{k>j} U_jk² D_k
/// U_ij = (P_ij − Σ_{k>j} U_ik U_jk D_k) / D_j      i < j
/// ```
///
/// A pivot `D_j ≤ tol · P_jj` (the rounding of a rank-deficient `P`, e.g. a
/// process noise `G Q Gᵀ` with fewer inputs than states) is set to 0 with its
/// column of `U` (the column has no weight). `tol = 0` asks for a positive
/// definite `P`: any pivot ≤ 0 refuses it.
pub fn factorize<T: RealField + Copy, const N: usize>(P: &SMatrix<T, N, N>, tol: T) -> Option<SMatrix<T, N, N>> {
    let mut ud = SMatrix::<T, N, N>::zeros();
    for j in (0..N).rev() {
        let mut d = P[(j, j)];
        for k in (j + 1)..N {
            d -= ud[(j, k)] * ud[(j, k)] * ud[(k, k)];
        }
        let floor = tol * P[(j, j)];
        if !d.is_finite() || d < -floor || (tol == T::zero() && d <= T::zero()) {
            return None;
        }
        if d <= floor {
            continue; // D_j = 0, U column j = 0
        }
        ud[(j, j)] = d;
        for i in 0..j {
            let mut v = P[(i, j)];
            for k in (j + 1)..N {
                v -= ud[(i, k)] * ud[(j, k)] * ud[(k, k)];
            }
            ud[(i, j)] = v / d;
        }
    }
    Some(ud)
}

/// Thornton's time update on packed factors: afterwards `U D Uᵀ = F P Fᵀ + G D_q Gᵀ`
/// with `P` the factors before. `dq ≥ 0` are the variances of the `K` independent
/// noise inputs, `G` their mapping into the state.
///
/// MWGS (Bierman 1977, §VI.4, eq. 4.4–4.6): with the rows `wᵢ` of `W = [F U, G]`
/// and the weights `D̃ = diag(D, D_q)`, for `j = N−1, …, 0`:
///
/// ```text
/// D_j  = wⱼ D̃ wⱼᵀ
/// U_ij = wᵢ D̃ wⱼᵀ / D_j,   wᵢ ← wᵢ − U_ij wⱼ      i < j
/// ```
///
/// so that `W D̃ Wᵀ = U D Uᵀ`. `D_j` is a weighted sum of squares, never negative;
/// a zero `D_j` (a row of `W` with no weight) leaves column `j` of `U` zero.
pub fn thornton<T: RealField + Copy, const N: usize, const K: usize>(
    ud: &mut SMatrix<T, N, N>,
    F: &SMatrix<T, N, N>,
    G: &SMatrix<T, N, K>,
    dq: &SVector<T, K>,
) {
    let d: [T; N] = std::array::from_fn(|k| ud[(k, k)]);
    // Rows of W as columns (contiguous): A = (F U)ᵀ, B = Gᵀ.
    let mut A = SMatrix::<T, N, N>::zeros();
    for i in 0..N {
        for k in 0..N {
            // (F U)_ik = F_ik + Σ_{l<k} F_il U_lk
            let mut v = F[(i, k)];
            for l in 0..k {
                v += F[(i, l)] * ud[(l, k)];
            }
            A[(k, i)] = v;
        }
    }
    let mut B = G.transpose();
    mwgs(ud, &mut A, &d, &mut B, dq);
}

/// `U D Uᵀ ← G U D Uᵀ Gᵀ` on packed factors (a linear transform without added
/// noise, e.g. an error-state reset), by MWGS of `W = G U` with the weights `D`.
pub fn transform<T: RealField + Copy, const N: usize>(ud: &mut SMatrix<T, N, N>, G: &SMatrix<T, N, N>) {
    thornton::<T, N, 0>(ud, G, &SMatrix::zeros(), &SVector::zeros());
}

/// The MWGS orthogonalisation of [`thornton`] on the rows of `[A, B]`, given as
/// the columns of `a` and `b`, with weights `(da, db)`; writes the packed factors.
fn mwgs<T: RealField + Copy, const N: usize, const K: usize>(
    ud: &mut SMatrix<T, N, N>,
    a: &mut SMatrix<T, N, N>,
    da: &[T; N],
    b: &mut SMatrix<T, K, N>,
    db: &SVector<T, K>,
) {
    for j in (0..N).rev() {
        // c = D̃ wⱼ
        let ca: [T; N] = std::array::from_fn(|k| da[k] * a[(k, j)]);
        let cb: [T; K] = std::array::from_fn(|k| db[k] * b[(k, j)]);
        let mut dj = T::zero();
        for k in 0..N {
            dj += a[(k, j)] * ca[k];
        }
        for k in 0..K {
            dj += b[(k, j)] * cb[k];
        }
        ud[(j, j)] = dj;
        for i in 0..j {
            if dj <= T::zero() {
                ud[(i, j)] = T::zero();
                continue;
            }
            let mut v = T::zero();
            for k in 0..N {
                v += a[(k, i)] * ca[k];
            }
            for k in 0..K {
                v += b[(k, i)] * cb[k];
            }
            let u = v / dj;
            ud[(i, j)] = u;
            for k in 0..N {
                let w = a[(k, j)];
                a[(k, i)] -= u * w;
            }
            for k in 0..K {
                let w = b[(k, j)];
                b[(k, i)] -= u * w;
            }
        }
    }
}

/// Bierman's update of packed factors and the state `x` with one scalar
/// measurement: row `h` of the measurement matrix, noise variance `r ≥ 0`,
/// residual `y = z − h x`. Returns the innovation variance `α = h P hᵀ + r`.
///
/// With `f = Uᵀ hᵀ`, `v = D f`, `α₋₁ = r`, for `j = 0 … N−1` (Bierman 1977, §V.3):
///
/// ```text
/// αⱼ = αⱼ₋₁ + fⱼ vⱼ        D_j ← D_j αⱼ₋₁ / αⱼ        λ = −fⱼ / αⱼ₋₁
/// U_ij ← U_ij + bᵢ λ,   bᵢ ← bᵢ + vⱼ U_ij (old)     i < j,    bⱼ = vⱼ
/// ```
///
/// and finally `K = b / α_{N−1}`, `x ← x + K y`. The new `D_j` is the old times a
/// ratio in (0, 1]: the factors stay positive.
pub fn bierman<T: RealField + Copy, const N: usize>(
    ud: &mut SMatrix<T, N, N>,
    x: &mut SVector<T, N>,
    h: &[T; N],
    r: T,
    y: T,
) -> T {
    let mut f = [T::zero(); N];
    for (j, fj) in f.iter_mut().enumerate() {
        let mut v = h[j];
        for i in 0..j {
            v += ud[(i, j)] * h[i];
        }
        *fj = v;
    }
    let mut b: [T; N] = std::array::from_fn(|j| ud[(j, j)] * f[j]);
    let mut alpha = r;
    for j in 0..N {
        let before = alpha;
        alpha += f[j] * b[j];
        if alpha <= T::zero() {
            // h P hᵀ + r = 0 so far: nothing observed yet, nothing to change.
            continue;
        }
        ud[(j, j)] = ud[(j, j)] * before / alpha;
        if before > T::zero() {
            let lambda = -f[j] / before;
            for i in 0..j {
                let u = ud[(i, j)];
                ud[(i, j)] = u + b[i] * lambda;
                b[i] += b[j] * u;
            }
        } else {
            // The first observed component with r = 0: its new D_j is 0, so
            // column j of U carries no weight and is left as it is.
            for i in 0..j {
                b[i] += b[j] * ud[(i, j)];
            }
        }
    }
    if alpha > T::zero() {
        let s = y / alpha;
        for (xi, bi) in x.iter_mut().zip(&b) {
            *xi += *bi * s;
        }
    }
    alpha
}

#[cfg(test)]
mod tests;
