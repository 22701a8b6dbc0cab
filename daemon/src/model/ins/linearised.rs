//! The `ins` model's error-state step as plain matrices, for running an
//! error-state filter outside the model: in another scalar type or form, as the
//! numerical study of `fusion-benches` does (`precision`). The model itself
//! propagates the covariance from the blocks of `F` ([`super::error_state`]).

#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector, Vector3};

use super::error_state::{attitude_reset, inject, reset_jacobian};
use super::{InsModel, InsState, N, NOMINAL};
use crate::filter::KalmanFilter;

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
        let mut s = InsState::new(*nominal, placeholder());
        let (p, v, q, F) = self.mechanise(&s, f_m, w_m, dt);
        let (b_a, b_g) = (s.b_a(), s.b_g());
        s.set(p, v, q, b_a, b_g);
        (s.nominal, F.dense(), self.process_noise(dt, 1).dense())
    }

    /// Injects the error-state correction `dx` into `nominal` as the model does
    /// after an update, and returns the reset Jacobian `G` (`P ← G P Gᵀ`).
    pub fn inject_error(nominal: &mut [f64; NOMINAL], dx: &SVector<f64, N>) -> SMatrix<f64, N, N> {
        let mut s = InsState::new(*nominal, placeholder());
        inject(&mut s, dx);
        *nominal = s.nominal;
        reset_jacobian(&attitude_reset(dx))
    }

    /// The error-state filter the model starts from (P₀, form).
    pub fn initial_filter(&self) -> &KalmanFilter<f64, N> {
        &self.initial
    }

    /// The model's initial nominal state `x₀`.
    pub fn initial_nominal(&self) -> [f64; NOMINAL] {
        self.x0
    }
}

/// A filter for states used only for their nominal part.
pub(super) fn placeholder() -> KalmanFilter<f64, N> {
    KalmanFilter::new(SVector::zeros(), SMatrix::identity()).expect("I is a valid covariance")
}
