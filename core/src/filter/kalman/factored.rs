//! What the filter does differently in the UDU form ([`Form::Udu`]): choosing the
//! form, reading `P` from the factors, Thornton's predict and Bierman's update.

#![allow(non_snake_case)]

use nalgebra::{RealField, SMatrix, SVector};

use super::{FilterError, Form, KalmanFilter, SmallCholesky, all_finite};
use crate::filter::udu;

impl<T: RealField + Copy, const N: usize> KalmanFilter<T, N> {
    /// The same estimate held in `form`: a Joseph filter factorises its `P`
    /// (positive definite, as [`new`](Self::new) checked), a UDU filter composes
    /// its factors.
    pub fn with_form(self, form: Form) -> Result<Self, FilterError> {
        let P = self.P();
        let mut out = Self { x: self.x, c: P, form };
        out.c = out.stored(P)?;
        Ok(out)
    }

    /// How the covariance is held.
    pub fn form(&self) -> Form {
        self.form
    }

    /// The packed UDU factors of `P` (`D` on the diagonal, `U` above it), in the
    /// UDU form.
    pub fn factors(&self) -> Option<&SMatrix<T, N, N>> {
        (self.form == Form::Udu).then_some(&self.c)
    }

    /// Variance `P_ii` of state `i`.
    pub fn variance(&self, i: usize) -> T {
        match self.form {
            Form::Joseph => self.c[(i, i)],
            Form::Udu => udu::variance(&self.c, i),
        }
    }

    /// Writes `P` into `out` (`N²` entries; row- and column-major alike, `P` being
    /// symmetric).
    pub fn write_covariance(&self, out: &mut [T]) {
        match self.form {
            Form::Joseph => out.copy_from_slice(self.c.as_slice()),
            Form::Udu => out.copy_from_slice(udu::compose(&self.c).as_slice()),
        }
    }

    /// Error-state reset by a linear transform: `x ← 0`, `P ← G P Gᵀ` (e.g. the
    /// reset Jacobian after an injection; Solà 2017, §7.2). In the Joseph form
    /// `joseph(P)` does it in place (a model exploits `G`'s structure); in the UDU
    /// form `G()` is applied to the factors by MWGS ([`udu::transform`]). `G`
    /// derives from an accepted, finite correction, so the result is finite.
    pub fn reset_transform(
        &mut self,
        joseph: impl FnOnce(&mut SMatrix<T, N, N>),
        G: impl FnOnce() -> SMatrix<T, N, N>,
    ) {
        self.x = SVector::zeros();
        match self.form {
            Form::Joseph => joseph(&mut self.c),
            Form::Udu => udu::transform(&mut self.c, &G()),
        }
    }

    /// `P` as this form stores it: itself, or its factors (`P` must then be
    /// positive definite).
    pub(super) fn stored(&self, P: SMatrix<T, N, N>) -> Result<SMatrix<T, N, N>, FilterError> {
        match self.form {
            Form::Joseph => Ok(P),
            Form::Udu => udu::factorize(&P, T::zero()).ok_or(FilterError::CovarianceNotPositiveDefinite),
        }
    }

    /// `P Hᵀ` in either form.
    pub(super) fn times_transpose<const M: usize>(&self, H: &SMatrix<T, M, N>) -> SMatrix<T, N, M> {
        match self.form {
            Form::Joseph => self.c * H.transpose(),
            Form::Udu => udu::times_transpose(&self.c, H),
        }
    }

    /// The UDU predict: `x ← propagate_x(x)`, and the factors by Thornton's MWGS
    /// with `Q` factorised as `U_q D_q U_qᵀ` (`G = U_q`; zero pivots of a
    /// rank-deficient `Q` carry no weight).
    pub(super) fn predict_factored(
        &mut self,
        propagate_x: impl FnOnce(&mut SVector<T, N>),
        F: &SMatrix<T, N, N>,
        Q: &SMatrix<T, N, N>,
    ) -> Result<(), FilterError> {
        if !all_finite(F) || !all_finite(Q) {
            return Err(FilterError::NonFinite("transition"));
        }
        // Pivots below 1e3 ε of their diagonal entry are the rounding of a rank
        // deficiency (e.g. ¼dt⁴ − (½dt)²·dt² for white acceleration), not noise.
        let tol = T::default_epsilon() * T::from_subset(&1e3);
        let Uq = udu::factorize(Q, tol).ok_or(FilterError::ProcessNoiseNotPositiveSemiDefinite)?;
        let dq = Uq.diagonal();
        let mut G = Uq;
        for k in 0..N {
            G[(k, k)] = T::one();
        }
        self.change_or_keep("predicted state", |x, ud| {
            propagate_x(x);
            udu::thornton(ud, F, &G, &dq);
        })
    }

    /// The UDU measurement update with residual `y`, Jacobian `H` and noise `R`:
    /// with a diagonal `R`, one Bierman update per component; otherwise the
    /// components are decorrelated first, `R = L Lᵀ`, `ȳ = L⁻¹ y`, `H̄ = L⁻¹ H`,
    /// `R̄ = I` (Grewal & Andrews 2015, §6.5.2). Each component's residual is taken
    /// about the estimate the previous ones left, `ȳᵢ − h̄ᵢ (x − x⁻)`, so the
    /// sequence equals the vector update.
    pub(super) fn update_factors<const M: usize>(
        &mut self,
        y: &SVector<T, M>,
        H: &SMatrix<T, M, N>,
        R: &SMatrix<T, M, M>,
    ) -> Result<(), FilterError> {
        let diagonal = (0..M).all(|i| (0..M).all(|j| i == j || R[(i, j)] == T::zero()));
        let (yb, Hb, r) = if diagonal {
            (*y, *H, SVector::<T, M>::from_fn(|i, _| R[(i, i)]))
        } else {
            let L = SmallCholesky::new(*R).ok_or(FilterError::MeasurementNoiseNotPositiveDefinite)?;
            let mut Hb = *H;
            for j in 0..N {
                let col = L.whiten(&H.column(j).into_owned());
                Hb.set_column(j, &col);
            }
            (L.whiten(y), Hb, SVector::<T, M>::repeat(T::one()))
        };
        if r.iter().any(|v| *v < T::zero()) {
            return Err(FilterError::MeasurementNoiseNotPositiveDefinite);
        }
        self.change_or_keep("updated state", |x, ud| {
            let prior = *x;
            for i in 0..M {
                let h: [T; N] = std::array::from_fn(|k| Hb[(i, k)]);
                let mut yi = yb[i];
                for k in 0..N {
                    yi -= h[k] * (x[k] - prior[k]);
                }
                udu::bierman(ud, x, &h, r[i], yi);
            }
        })
    }
}
