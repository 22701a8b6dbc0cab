//! Error-state algebra of the INS: the covariance propagation exploiting the
//! sparsity of `F`, and the injection and reset after an update.

#![allow(non_snake_case)]

use std::ops::AddAssign;

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use super::{InsState, N};

fn block(m: &SMatrix<f64, N, N>, r: usize, c: usize) -> Matrix3<f64> {
    m.fixed_view::<3, 3>(3 * r, 3 * c).into_owned()
}

/// `F P Fᵀ` for `F = I + E` with `E` nonzero only in the blocks (row, column)
/// (0,1) (0,2) (0,3) (1,2) (1,3) (2,2) (2,4) (3×3 blocks): `F P Fᵀ = FP + FP Eᵀ`
/// with `FP = P + E P`, where `E P` has only three nonzero block rows and `FP Eᵀ`
/// three nonzero block columns. About a tenth of the work of two dense products.
pub(super) fn structured_fpft(P: &SMatrix<f64, N, N>, F: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let e = |r, c| {
        let mut b = block(F, r, c);
        if r == c {
            b -= Matrix3::identity();
        }
        b
    };
    let (e01, e02, e03, e12, e13, e22, e24) = (e(0, 1), e(0, 2), e(0, 3), e(1, 2), e(1, 3), e(2, 2), e(2, 4));
    let rows = |P: &SMatrix<f64, N, N>, r: usize| P.fixed_view::<3, N>(3 * r, 0).into_owned();
    let mut FP = *P;
    let (p1, p2, p3, p4) = (rows(P, 1), rows(P, 2), rows(P, 3), rows(P, 4));
    let r0 = e01 * p1 + e02 * p2 + e03 * p3;
    let r1 = e12 * p2 + e13 * p3;
    let r2 = e22 * p2 + e24 * p4;
    FP.fixed_view_mut::<3, N>(0, 0).add_assign(&r0);
    FP.fixed_view_mut::<3, N>(3, 0).add_assign(&r1);
    FP.fixed_view_mut::<3, N>(6, 0).add_assign(&r2);
    let cols = |M: &SMatrix<f64, N, N>, c: usize| M.fixed_view::<N, 3>(0, 3 * c).into_owned();
    let (c1, c2, c3, c4) = (cols(&FP, 1), cols(&FP, 2), cols(&FP, 3), cols(&FP, 4));
    let k0 = c1 * e01.transpose() + c2 * e02.transpose() + c3 * e03.transpose();
    let k1 = c2 * e12.transpose() + c3 * e13.transpose();
    let k2 = c2 * e22.transpose() + c4 * e24.transpose();
    let mut out = FP;
    out.fixed_view_mut::<N, 3>(0, 0).add_assign(&k0);
    out.fixed_view_mut::<N, 3>(0, 3).add_assign(&k1);
    out.fixed_view_mut::<N, 3>(0, 6).add_assign(&k2);
    out
}

/// Injects the error into the nominal state and resets it (Solà eq. 282–287):
/// `p += δp, v += δv, q ← q ⊗ Exp(δθ), b += δb`, `δx ← 0`, `P ← G P Gᵀ` with
/// `G = diag(I, I, I − [½δθ]×, I, I)`.
pub(super) fn inject_and_reset(s: &mut InsState) {
    let dx = *s.kf.x();
    let dp = Vector3::new(dx[0], dx[1], dx[2]);
    let dv = Vector3::new(dx[3], dx[4], dx[5]);
    let dtheta = Vector3::new(dx[6], dx[7], dx[8]);
    let dba = Vector3::new(dx[9], dx[10], dx[11]);
    let dbg = Vector3::new(dx[12], dx[13], dx[14]);
    let mut q = s.q() * UnitQuaternion::from_scaled_axis(dtheta);
    q.renormalize();
    let (p, v, b_a, b_g) = (s.p() + dp, s.v() + dv, s.b_a() + dba, s.b_g() + dbg);
    s.set(p, v, q, b_a, b_g);
    let Gt = Matrix3::identity() - (dtheta * 0.5).cross_matrix();
    let mut P = *s.kf.P();
    // Only block row and column 2 change: P₂ⱼ ← Gθ P₂ⱼ, Pᵢ₂ ← Pᵢ₂ Gθᵀ.
    let row = Gt * P.fixed_view::<3, N>(6, 0);
    P.fixed_view_mut::<3, N>(6, 0).copy_from(&row);
    let col = P.fixed_view::<N, 3>(0, 6) * Gt.transpose();
    P.fixed_view_mut::<N, 3>(0, 6).copy_from(&col);
    // The reset cannot introduce a non-finite number when P and δθ are finite,
    // both of which the filter guarantees.
    let _ = s.kf.set_state(SVector::zeros(), P);
}
