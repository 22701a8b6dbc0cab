//! The `ins` model's error-state step as plain matrices, for running an
//! error-state filter outside the model: in another scalar type or form, as the
//! numerical study of `fusion-benches` does (`precision`). The model itself
//! propagates the covariance from the blocks of `F` ([`super::error_state`]).

#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

use super::error_state::{Transition, attitude_reset, inject, reset_jacobian};
use super::{InsModel, InsState, N, NOMINAL, pad};
use crate::filter::KalmanFilter;

impl<const D: usize> InsModel<D> {
    /// The nominal state's strapdown step over `dt` with the IMU values `f_m`,
    /// `w_m` (see the model docs), and the error-state transition of that step:
    /// `(p, v, q)` after it and `F`.
    #[inline(always)]
    pub(super) fn mechanise(
        &self,
        s: &InsState<D>,
        f_m: Vector3<f64>,
        w_m: Vector3<f64>,
        dt: f64,
    ) -> (Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>, Transition) {
        let (p, v, q) = (s.p(), s.v(), s.q());
        let f = f_m - s.b_a();
        let w = w_m - s.b_g();
        let R = q.to_rotation_matrix().into_inner();
        let a = R * f + self.g();
        let dq = UnitQuaternion::from_scaled_axis(w * dt);
        let p_new = p + v * dt + a * (0.5 * dt * dt);
        let v_new = v + a * dt;
        let mut q_new = q * dq;
        q_new.renormalize();
        let C = dq.to_rotation_matrix().into_inner().transpose();
        let F = Transition { dt, gyro_dt: dt, A: -R * f.cross_matrix(), B: -R, C };
        (p_new, v_new, q_new, F)
    }
}

impl InsModel {
    /// The strapdown step of `nominal` over `dt` seconds with one IMU's specific
    /// force `f_m` and rate `w_m` (body frame), exactly as the model makes it:
    /// the nominal state after it, and the step's error-state transition `F` and
    /// process noise `Q` (see the model docs).
    pub fn error_step(
        &self,
        nominal: &[f64; NOMINAL],
        f_m: Vector3<f64>,
        w_m: Vector3<f64>,
        dt: f64,
    ) -> ([f64; NOMINAL], SMatrix<f64, N, N>, SMatrix<f64, N, N>) {
        let mut s = InsState::new(pad(*nominal), placeholder(), 0);
        let (p, v, q, F) = self.mechanise(&s, f_m, w_m, dt);
        let (b_a, b_g) = (s.b_a(), s.b_g());
        s.put(p, v, q, b_a, b_g);
        (core(&s.nominal), F.dense(), self.process_noise(dt, 1).dense())
    }

    /// Injects the error-state correction `dx` into `nominal` as the model does
    /// after an update, and returns the reset Jacobian `G` (`P ← G P Gᵀ`).
    pub fn inject_error(nominal: &mut [f64; NOMINAL], dx: &SVector<f64, N>) -> SMatrix<f64, N, N> {
        let mut s = InsState::new(pad(*nominal), placeholder(), 0);
        inject(&mut s, dx);
        *nominal = core(&s.nominal);
        reset_jacobian(&attitude_reset(dx))
    }

    /// The error-state filter the model starts from (P₀, form).
    pub fn initial_filter(&self) -> &KalmanFilter<f64, N> {
        &self.initial
    }

    /// The model's initial nominal state `x₀`.
    pub fn initial_nominal(&self) -> [f64; NOMINAL] {
        core(&self.x0)
    }
}

/// The core part of a nominal state.
fn core(x: &[f64]) -> [f64; NOMINAL] {
    x[..NOMINAL].try_into().expect("a nominal state holds the core")
}

/// A filter for states used only for their nominal part.
pub(super) fn placeholder<const D: usize>() -> KalmanFilter<f64, D> {
    KalmanFilter::new(SVector::zeros(), SMatrix::identity()).expect("I is a valid covariance")
}
