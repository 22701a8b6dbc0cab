//! The land-vehicle motion constraint, a pseudo-measurement of the `ins` model.
//!
//! A wheeled vehicle does not slide sideways or lift off, so the lateral and
//! vertical components of the body-frame velocity `v_b = Rᵀ v` are zero up to a
//! noise `σ_nhc` (slip, suspension travel): `z = [0, 0] = [v_b,y, v_b,z] + n`
//! (Groves 2013, §15.4.1; Dissanayake et al., "The aiding of a low-cost strapdown
//! inertial measurement unit using vehicle model constraints for land vehicle
//! applications", IEEE T-RA 2001).
//!
//! With the local attitude error `q_true = q ⊗ Exp(δθ)`,
//! `v_b,true ≈ v_b + Rᵀ δv + [v_b]× δθ`, so the rows of `H` are rows 1 and 2 of
//! `Rᵀ` on δv and of `[v_b]×` on δθ; `R = σ_nhc² I₂`.
//!
//! It has no wire type: the `ins` model fuses it after an IMU sample, at most every
//! `interval`, above a minimum forward speed, and once the attitude is known to
//! [`MAX_ATTITUDE_SD`] (before, the linearisation is poor). It is gated like any
//! measurement; a refused one (the vehicle skids) changes nothing.

#![allow(non_snake_case)]

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

use crate::model::ins::{InsModel, InsState};

/// Innovation dimension: lateral and vertical body velocity.
pub const INNOVATION_DIM: usize = 2;

/// Attitude uncertainty (1σ, rad, any axis) above which the constraint waits:
/// 0.1 rad, where the small-angle error of its linearisation reaches 0.5 %.
pub const MAX_ATTITUDE_SD: f64 = 0.1;

/// The constraint's parameters (`[model.constraints]`, keys `nonholonomic_*`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nonholonomic {
    /// Standard deviation of the lateral and vertical body velocity, m/s.
    #[serde(rename = "nonholonomic_std_mps")]
    pub std_mps: f64,
    /// Least time between two constraint updates, ns (default 50 ms).
    #[serde(rename = "nonholonomic_interval_ns", default = "Nonholonomic::default_interval_ns")]
    pub interval_ns: u64,
    /// Forward speed below which the constraint is not applied, m/s (default 1).
    #[serde(rename = "nonholonomic_min_speed_mps", default = "Nonholonomic::default_min_speed")]
    pub min_speed_mps: f64,
}

impl Nonholonomic {
    fn default_interval_ns() -> u64 {
        50_000_000
    }
    fn default_min_speed() -> f64 {
        1.0
    }
}

/// Whether every axis of the attitude is known to [`MAX_ATTITUDE_SD`]: before,
/// a measurement through the attitude is linearised about a wrong body frame.
pub fn attitude_known<const D: usize>(s: &InsState<D>) -> bool {
    (6..9).all(|i| s.filter().variance(i) <= MAX_ATTITUDE_SD * MAX_ATTITUDE_SD)
}

/// Fuses `[v_b,y, v_b,z] = 0` into `s` and injects the correction, which it
/// returns. Below the minimum speed, with the attitude not yet known, or when
/// the gate refuses it, nothing changes.
pub fn fuse<const D: usize>(c: &Nonholonomic, model: &InsModel<D>, s: &mut InsState<D>) -> Option<SVector<f64, D>> {
    let R = s.q().to_rotation_matrix().into_inner();
    let v_b = R.transpose() * s.v();
    if v_b.x < c.min_speed_mps {
        return None;
    }
    // The constraint is linear in δθ only for small attitude errors: with the
    // heading still unknown (e.g. at start, before fixes have shown the track)
    // it would pull the estimate the wrong way.
    if !attitude_known(s) {
        return None;
    }
    let mut H = SMatrix::<f64, INNOVATION_DIM, D>::zeros();
    let vx = v_b.cross_matrix();
    for r in 0..2 {
        for k in 0..3 {
            H[(r, 3 + k)] = R[(k, r + 1)]; // (Rᵀ)[r+1][k]
            H[(r, 6 + k)] = vx[(r + 1, k)];
        }
    }
    let predicted = Vector2::new(v_b.y, v_b.z);
    let Rn = Matrix2::identity() * (c.std_mps * c.std_mps);
    model.update_residual(s, &(-predicted), &H, &Rn).1
}
