//! The Joseph-form covariance update in O(N² M), for every update of the filter.

#![allow(non_snake_case)]

use nalgebra::{RealField, SMatrix};

use super::{Symmetrize, symmetrize_leading};

/// `P ← P⁺`, the Joseph form `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ` for any `H`,
/// in O(N² M), from `B = P Hᵀ` and `S = H P Hᵀ + R`: expanding the product,
///
/// ```text
/// P⁺ = P − K Bᵀ − B Kᵀ + K S Kᵀ = P − K Bᵀ − G Kᵀ,   G = B − K S
/// ```
///
/// (`G` is the residual of the gain equation `K S = P Hᵀ`: zero but for rounding,
/// which is what the Joseph form corrects for). These are the terms of the
/// textbook product (Simon 2006, eq. 5.19) without forming the N×N matrix
/// `I − K H`: 2 N² M multiply-adds instead of about 2 N³.
pub(crate) fn joseph_low_rank<T: RealField + Copy, const N: usize, const M: usize>(
    P: &mut SMatrix<T, N, N>,
    K: &SMatrix<T, N, M>,
    B: &SMatrix<T, N, M>,
    S: &SMatrix<T, M, M>,
) {
    joseph_columns(&mut P.data.0, &K.data.0, &B.data.0, &S.data.0);
}

/// `p ← p − K Bᵀ − G Kᵀ` with `G = B − K S` on column-major arrays
/// (`p[column][row]`), upper triangle mirrored to the lower one, so the result is
/// exactly symmetric. Column `j` is `p`'s minus `2M` scaled columns of `K` and
/// `G`, in blocks of four rows that vectorise (whole columns: the few entries
/// below the diagonal cost less than loops of varying length). Compiled for AVX2
/// as well, chosen at run time: the same operations in the same order, so the
/// same bits either way.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn joseph_columns<T: RealField + Copy, const N: usize, const M: usize>(
    p: &mut [[T; N]; N],
    k: &[[T; N]; M],
    b: &[[T; N]; M],
    s: &[[T; M]; M],
) {
    let mut g = *b;
    for (gm, sm) in g.iter_mut().zip(s) {
        for (l, kl) in k.iter().enumerate() {
            for i in 0..N {
                gm[i] -= kl[i] * sm[l];
            }
        }
    }
    for (j, col) in p.iter_mut().enumerate() {
        let src = *col;
        let (bj, kj): ([T; M], [T; M]) = (std::array::from_fn(|m| b[m][j]), std::array::from_fn(|m| k[m][j]));
        let row = |i: usize| {
            let mut v = src[i];
            for m in 0..M {
                v -= k[m][i] * bj[m] + g[m][i] * kj[m];
            }
            v
        };
        if N < 4 {
            for (i, v) in col.iter_mut().enumerate() {
                *v = row(i);
            }
            continue;
        }
        // Rows in fours, the last four ending at row N − 1 (overlapping the one
        // before when 4 does not divide N: computed from `src`, the rows written
        // twice get the same value twice). Fours of constant length vectorise
        // whole; a remainder of 1–3 rows would cost as much as the rest.
        for c in 0..N.div_ceil(4) {
            let base = (4 * c).min(N - 4);
            for r in 0..4 {
                col[base + r] = row(base + r);
            }
        }
    }
    symmetrize_leading(p, N, Symmetrize::MirrorUpper);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, SMatrix};

    #[test]
    fn low_rank_form_equals_the_textbook_product_for_any_gain() {
        // Dense H, a gain that is not the optimal one: the identity behind the
        // low-rank form holds for every K, which is what the Joseph form is for.
        let L =
            SMatrix::<f64, 7, 7>::from_fn(|i, j| if i >= j { 0.3 + ((i * 5 + j * 3) % 7) as f64 * 0.2 } else { 0.0 });
        let P = L * L.transpose();
        let H = SMatrix::<f64, 2, 7>::from_fn(|i, j| ((i * 3 + j * 5) % 4) as f64 * 0.5 - 0.7);
        let R = Matrix2::new(0.4, 0.1, 0.1, 0.3);
        let K = SMatrix::<f64, 7, 2>::from_fn(|i, j| ((i + 2 * j) % 5) as f64 * 0.1 - 0.2);
        let I_KH = SMatrix::<f64, 7, 7>::identity() - K * H;
        let textbook = I_KH * P * I_KH.transpose() + K * R * K.transpose();
        let mut low_rank = P;
        joseph_low_rank(&mut low_rank, &K, &(P * H.transpose()), &(H * P * H.transpose() + R));
        assert!((low_rank - textbook).amax() < 1e-12 * textbook.amax(), "{low_rank} against {textbook}");
        assert_eq!(low_rank, low_rank.transpose(), "exactly symmetric");
    }
}
