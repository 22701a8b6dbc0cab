//! Error-state algebra of the INS: the covariance propagation exploiting the
//! sparsity of `F`, and the injection and reset after an update.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use super::{InsState, MAX_AUX, N};
use crate::filter::kalman::{Symmetrize, symmetrize_leading};

/// The entries of a 3×3 matrix as rows: `m[(r, c)]` is `row_major(m)[r][c]`.
/// (nalgebra stores columns, so the columns of `mᵀ` are the rows of `m`.)
fn row_major(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    m.transpose().data.0
}

/// The error-state transition over one step, `F = I + E`, by its blocks (3×3,
/// block rows and columns in the order δp, δv, δθ, δb_a, δb_g; see the model docs):
///
/// ```text
/// E₀₁ = dt I     E₀₂ = ½dt² A   E₀₃ = ½dt² B
///                E₁₂ = dt A     E₁₃ = dt B
///                E₂₂ = C − I                   E₂₄ = −dt I
/// A = −R [f]×,  B = −R,  C = Exp(ω dt)ᵀ
/// ```
#[derive(Debug, Clone, Copy)]
pub(super) struct Transition {
    pub dt: f64,
    /// The `δθ`–`δb_g` coupling `G` of `F` (block `−G I`): `dt`, or 0 while the
    /// attitude is held at a standstill (the standstill module's held step).
    pub gyro_dt: f64,
    pub A: Matrix3<f64>,
    pub B: Matrix3<f64>,
    pub C: Matrix3<f64>,
}

/// The diagonal blocks (each a multiple of `I₃`) of the discrete process noise `Q`,
/// with the δp–δv coupling.
#[derive(Debug, Clone, Copy)]
pub(super) struct ProcessNoise {
    pub pp: f64,
    pub pv: f64,
    pub vv: f64,
    pub theta: f64,
    pub ba: f64,
    pub bg: f64,
    /// The auxiliary states' (error-state index `N + i`), each a random walk.
    pub aux: [f64; MAX_AUX],
}

impl ProcessNoise {
    /// `Q` as a dense matrix (for the UDU form and the tests).
    pub fn dense<const D: usize>(&self) -> SMatrix<f64, D, D> {
        let mut Q = SMatrix::<f64, D, D>::zeros();
        for i in N..D {
            Q[(i, i)] = self.aux[i - N];
        }
        for i in 0..3 {
            Q[(i, i)] = self.pp;
            Q[(i, i + 3)] = self.pv;
            Q[(i + 3, i)] = self.pv;
            Q[(i + 3, i + 3)] = self.vv;
            Q[(i + 6, i + 6)] = self.theta;
            Q[(i + 9, i + 9)] = self.ba;
            Q[(i + 12, i + 12)] = self.bg;
        }
        Q
    }

    /// `P += Q`.
    pub fn add_to<const D: usize>(&self, P: &mut SMatrix<f64, D, D>) {
        for i in N..D {
            P[(i, i)] += self.aux[i - N];
        }
        for i in 0..3 {
            P[(i, i)] += self.pp;
            P[(i, i + 3)] += self.pv;
            P[(i + 3, i)] += self.pv;
            P[(i + 3, i + 3)] += self.vv;
            P[(i + 6, i + 6)] += self.theta;
            P[(i + 9, i + 9)] += self.ba;
            P[(i + 12, i + 12)] += self.bg;
        }
    }
}

impl Transition {
    /// `F` as a dense matrix (for the smoother's log and the tests); the
    /// auxiliary states are constant over a step (identity rows).
    pub fn dense<const D: usize>(&self) -> SMatrix<f64, D, D> {
        let dt = self.dt;
        let hdt2 = 0.5 * dt * dt;
        let mut F = SMatrix::<f64, D, D>::identity();
        F.fixed_view_mut::<3, 3>(0, 3).copy_from(&(Matrix3::identity() * dt));
        F.fixed_view_mut::<3, 3>(0, 6).copy_from(&(self.A * hdt2));
        F.fixed_view_mut::<3, 3>(0, 9).copy_from(&(self.B * hdt2));
        F.fixed_view_mut::<3, 3>(3, 6).copy_from(&(self.A * dt));
        F.fixed_view_mut::<3, 3>(3, 9).copy_from(&(self.B * dt));
        F.fixed_view_mut::<3, 3>(6, 6).copy_from(&self.C);
        F.fixed_view_mut::<3, 3>(6, 12).copy_from(&(-Matrix3::identity() * self.gyro_dt));
        F
    }

    /// `P ← F P Fᵀ + Q` for symmetric `P`, from the blocks of `F`, exactly symmetric.
    ///
    /// Rows first: `T = F P` changes only block rows 0–2 of `P` (`Pₖ` is block row k):
    ///
    /// ```text
    /// W = A P₂ + B P₃,  T₀ = P₀ + dt P₁ + ½dt² W,  T₁ = P₁ + dt W,  T₂ = C P₂ − dt P₄
    /// ```
    ///
    /// then columns: `F P Fᵀ = T Fᵀ` changes only block columns 0–2 of `T`, and by
    /// symmetry only its upper-left 9×9 corner has to be computed (`Tₖ` is now block
    /// column k of rows 0–8 of `T`):
    ///
    /// ```text
    /// W' = T₂ Aᵀ + T₃ Bᵀ,  O₀ = T₀ + dt T₁ + ½dt² W',  O₁ = T₁ + dt W',  O₂ = T₂ Cᵀ − dt T₄
    /// ```
    ///
    /// The rest is copied: rows 0–8, columns 9–14 from `T`, their transpose below,
    /// and the bias blocks from `P`. About 800 multiply-adds against 6750 for the
    /// dense `F P Fᵀ`. Auxiliary states (index ≥ 15) are constant over a step,
    /// so their rows and columns are copied as the biases' are.
    pub fn propagate_covariance<const D: usize>(&self, P: &mut SMatrix<f64, D, D>, Q: &ProcessNoise) {
        let (a, b, c) = (row_major(&self.A), row_major(&self.B), row_major(&self.C));
        propagate_dispatch(&mut P.data.0, self.dt, self.gyro_dt, &a, &b, &c);
        Q.add_to(P);
    }
}

/// [`propagate_blocks`] for each state size the `ins` model has (the core's
/// [`N`] and each number of auxiliary states up to [`MAX_AUX`]), compiled for
/// AVX2 as well and chosen at run time: the same operations in the same order,
/// so the same bits. One compiled dispatcher per size: a generic function's
/// dispatcher would detect the CPU's features on every call (multiversion's
/// direct dispatch), a non-generic one caches the choice.
macro_rules! per_size {
    ($($name:ident = $aux:literal;)*) => {
        $(
            #[multiversion::multiversion(targets("x86_64+avx2"))]
            fn $name(
                p: &mut [[f64; N + $aux]; N + $aux],
                dt: f64,
                gyro_dt: f64,
                a: &[[f64; 3]; 3],
                b: &[[f64; 3]; 3],
                c: &[[f64; 3]; 3],
            ) {
                propagate_blocks(p, dt, gyro_dt, a, b, c);
            }
        )*

        /// [`propagate_blocks`] through the kernel of `p`'s size.
        fn propagate_dispatch<const D: usize>(
            p: &mut [[f64; D]; D],
            dt: f64,
            gyro_dt: f64,
            a: &[[f64; 3]; 3],
            b: &[[f64; 3]; 3],
            c: &[[f64; 3]; 3],
        ) {
            let any: &mut dyn std::any::Any = p;
            $(
                if let Some(p) = any.downcast_mut::<[[f64; N + $aux]; N + $aux]>() {
                    return $name(p, dt, gyro_dt, a, b, c);
                }
            )*
            propagate_blocks(any.downcast_mut::<[[f64; D]; D]>().expect("the array of P"), dt, gyro_dt, a, b, c);
        }

        const _: () = {
            let sizes: [usize; MAX_AUX + 1] = [$($aux),*];
            let mut i = 0;
            while i < sizes.len() {
                assert!(sizes[i] == i, "a kernel for every number of auxiliary states, in order");
                i += 1;
            }
        };
    };
}

per_size! {
    propagate_blocks_15 = 0;
    propagate_blocks_16 = 1;
    propagate_blocks_17 = 2;
    propagate_blocks_18 = 3;
    propagate_blocks_19 = 4;
    propagate_blocks_20 = 5;
    propagate_blocks_21 = 6;
}

/// The body of [`Transition::propagate_covariance`] on the column-major array
/// `p` (`p[c][r]`), in place; `a`, `b`, `c` row-major.
#[inline(always)]
fn propagate_blocks<const D: usize>(
    p: &mut [[f64; D]; D],
    dt: f64,
    gyro_dt: f64,
    a: &[[f64; 3]; 3],
    b: &[[f64; 3]; 3],
    c: &[[f64; 3]; 3],
) {
    let hdt2 = 0.5 * dt * dt;
    // T = rows 0–8 of F P, column by column.
    let mut t = [[0.0; 9]; D];
    for (tc, pc) in t.iter_mut().zip(p.iter()) {
        for r in 0..3 {
            let mut w = 0.0;
            let mut cr = 0.0;
            for k in 0..3 {
                w += a[r][k] * pc[6 + k] + b[r][k] * pc[9 + k];
                cr += c[r][k] * pc[6 + k];
            }
            tc[r] = pc[r] + dt * pc[3 + r] + hdt2 * w;
            tc[3 + r] = pc[3 + r] + dt * w;
            tc[6 + r] = cr - gyro_dt * pc[12 + r];
        }
    }

    // Upper-left 9×9 of T Fᵀ, column by column (column j of T Fᵀ is T times row j of F).
    for r in 0..3 {
        let mut w = [0.0; 9];
        let mut cr = [0.0; 9];
        for k in 0..3 {
            for i in 0..9 {
                w[i] += t[6 + k][i] * a[r][k] + t[9 + k][i] * b[r][k];
                cr[i] += t[6 + k][i] * c[r][k];
            }
        }
        for i in 0..9 {
            p[r][i] = t[r][i] + dt * t[3 + r][i] + hdt2 * w[i];
            p[3 + r][i] = t[3 + r][i] + dt * w[i];
            p[6 + r][i] = cr[i] - gyro_dt * t[12 + r][i];
        }
    }
    symmetrize_leading(p, 9, Symmetrize::Average);
    // Block columns 3 and 4 are unchanged by the column pass: rows 0–8 come
    // from T, and their mirror fills rows 9–14 of columns 0–8.
    for j in 9..D {
        for i in 0..9 {
            p[j][i] = t[j][i];
            p[i][j] = t[j][i];
        }
    }
}

/// Adds an error-state correction to the nominal state:
/// `p += δp, v += δv, q ← q ⊗ Exp(δθ), b += δb` (Solà eq. 282–286), and
/// `a += δa` for each auxiliary state (nominal index one above its error's).
pub(super) fn inject<const D: usize>(s: &mut InsState<D>, dx: &SVector<f64, D>) {
    let dp = Vector3::new(dx[0], dx[1], dx[2]);
    let dv = Vector3::new(dx[3], dx[4], dx[5]);
    let dtheta = Vector3::new(dx[6], dx[7], dx[8]);
    let dba = Vector3::new(dx[9], dx[10], dx[11]);
    let dbg = Vector3::new(dx[12], dx[13], dx[14]);
    let mut q = s.q() * UnitQuaternion::from_scaled_axis(dtheta);
    q.renormalize();
    let (p, v, b_a, b_g) = (s.p() + dp, s.v() + dv, s.b_a() + dba, s.b_g() + dbg);
    s.put(p, v, q, b_a, b_g);
    for i in N..D {
        s.nominal[i + 1] += dx[i];
    }
}

/// Injects the error into the nominal state and resets it (Solà eq. 282–287):
/// [`inject`], `δx ← 0`, `P ← G P Gᵀ` with `G = diag(I, I, I − [½δθ]×, I, I)`.
/// Returns the injected error.
pub(crate) fn inject_and_reset<const D: usize>(s: &mut InsState<D>) -> SVector<f64, D> {
    let dx = *s.kf.x();
    inject(s, &dx);
    let Gt = attitude_reset(&dx);
    s.kf.reset_transform(|P| reset_attitude_block(P, &row_major(&Gt)), || reset_jacobian(&Gt));
    dx
}

/// The attitude block `Gθ = I − [½δθ]×` of the reset Jacobian after injecting `dx`.
pub(super) fn attitude_reset<const D: usize>(dx: &SVector<f64, D>) -> Matrix3<f64> {
    let dtheta = Vector3::new(dx[6], dx[7], dx[8]);
    Matrix3::identity() - (dtheta * 0.5).cross_matrix()
}

/// The reset Jacobian `G = diag(I, I, Gθ, I, I)` (`I` for the auxiliary
/// states) as a dense matrix.
pub(super) fn reset_jacobian<const D: usize>(Gt: &Matrix3<f64>) -> SMatrix<f64, D, D> {
    let mut G = SMatrix::<f64, D, D>::identity();
    G.fixed_view_mut::<3, 3>(6, 6).copy_from(Gt);
    G
}

/// `P ← G P Gᵀ` for `G = diag(I, I, Gθ, I, I)`, `g` = Gθ row-major.
fn reset_attitude_block<const D: usize>(P: &mut SMatrix<f64, D, D>, g: &[[f64; 3]; 3]) {
    // Only block row and column 2 change: P₂ⱼ ← Gθ P₂ⱼ (j ≠ 2), Pᵢ₂ ← its mirror,
    // P₂₂ ← Gθ P₂₂ Gθᵀ. Columns of the array are matrix columns: p[c][r].
    let p = &mut P.data.0;
    for c in (0..D).filter(|c| !(6..9).contains(c)) {
        let col = [p[c][6], p[c][7], p[c][8]];
        for r in 0..3 {
            let v = g[r][0] * col[0] + g[r][1] * col[1] + g[r][2] * col[2];
            p[c][6 + r] = v;
            p[6 + r][c] = v;
        }
    }
    let mut gp = [[0.0; 3]; 3]; // Gθ P₂₂, row-major
    for (r, row) in gp.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = g[r][0] * p[6 + k][6] + g[r][1] * p[6 + k][7] + g[r][2] * p[6 + k][8];
        }
    }
    for r in 0..3 {
        for k in r..3 {
            let v = gp[r][0] * g[k][0] + gp[r][1] * g[k][1] + gp[r][2] * g[k][2];
            p[6 + k][6 + r] = v;
            p[6 + r][6 + k] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::*;

    /// A transition of 10 ms with full blocks, and a covariance with every
    /// entry set (correlated, positive definite).
    fn case<const D: usize>() -> (Transition, SMatrix<f64, D, D>) {
        let m = |s: f64| Matrix3::from_fn(|r, c| s * (1.0 + r as f64 - 0.5 * c as f64));
        let t = Transition { dt: 0.01, gyro_dt: 0.01, A: m(0.3), B: m(-0.2), C: Matrix3::identity() + m(0.001) };
        let L = SMatrix::<f64, D, D>::from_fn(|r, c| if c <= r { 1.0 / (1.0 + (r + c) as f64) } else { 0.0 });
        (t, L * L.transpose())
    }

    /// Each size's kernel (AVX2 where the CPU has it) gives the generic body's
    /// bits, and `F P Fᵀ` of the dense `F`.
    fn every_size_gives_the_generic_bits<const D: usize>() {
        let (t, P0) = case::<D>();
        let (a, b, c) = (row_major(&t.A), row_major(&t.B), row_major(&t.C));
        let mut dispatched = P0;
        propagate_dispatch(&mut dispatched.data.0, t.dt, t.gyro_dt, &a, &b, &c);
        let mut generic = P0;
        propagate_blocks(&mut generic.data.0, t.dt, t.gyro_dt, &a, &b, &c);
        assert_eq!(dispatched, generic, "{D} states");
        let F = t.dense::<D>();
        let dense = F * P0 * F.transpose();
        assert!((dispatched - dense).amax() < 1e-12 * dense.amax(), "{D} states");
    }

    #[test]
    fn every_state_size_has_its_kernel_with_the_same_bits() {
        every_size_gives_the_generic_bits::<{ N }>();
        every_size_gives_the_generic_bits::<{ N + 1 }>();
        every_size_gives_the_generic_bits::<{ N + 2 }>();
        every_size_gives_the_generic_bits::<{ N + 3 }>();
        every_size_gives_the_generic_bits::<{ N + 4 }>();
        every_size_gives_the_generic_bits::<{ N + 5 }>();
        every_size_gives_the_generic_bits::<{ N + 6 }>();
    }
}
