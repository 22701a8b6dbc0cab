//! The land-vehicle motion constraint, a pseudo-measurement of the `ins` model.
//!
//! A wheeled vehicle does not slide sideways or lift off, so the lateral and
//! vertical components of the body-frame velocity of the point that does not
//! slide (the middle of the rear axle on the ground for a car, the centre of a
//! skid-steer robot's wheel contacts), `v_p = Rᵀ v + ω × l` with `l` its lever
//! arm from the IMU and `ω = ω_m − b_g` the body rate, are zero up to a noise
//! `σ_nhc` (slip, suspension travel): `z = [0, 0] = [v_p,y, v_p,z] + n`
//! (Groves 2013, §15.4.1 and eq. 14.121 for the lever arm; Dissanayake et al.,
//! "The aiding of a low-cost strapdown inertial measurement unit using vehicle
//! model constraints for land vehicle applications", IEEE T-RA 2001).
//!
//! With the local attitude error `q_true = q ⊗ Exp(δθ)` and `ω_true = ω − δb_g`,
//! `v_p,true ≈ v_p + Rᵀ δv + [Rᵀ v]× δθ + [l]× δb_g` ([`point_velocity`]), so the
//! rows of `H` are rows 1 and 2 of `Rᵀ` on δv, of `[Rᵀ v]×` on δθ and of `[l]×`
//! on δb_g; `R = σ_nhc² I₂`.
//!
//! It has no wire type: the `ins` model fuses it after an IMU sample, at most every
//! `interval`, at every speed (forward, reversing and at rest) unless a minimum
//! is configured, and once the attitude is known to [`MAX_ATTITUDE_SD`] (before,
//! the linearisation is poor). It is gated like any measurement; a refused one
//! (the vehicle skids) changes nothing.

#![allow(non_snake_case)]

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

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
    /// Forward speed, either way, below which the constraint is not applied,
    /// m/s (default 0: at every speed, reversing and at rest too; a vehicle
    /// that slides at low speed, a tracked one turning on the spot, sets one).
    #[serde(rename = "nonholonomic_min_speed_mps", default)]
    pub min_speed_mps: f64,
    /// The point that does not slide, from the IMU in the body frame (FLU), m
    /// (default the IMU itself): the middle of the rear axle on the ground for
    /// a car, the centre of the wheel contacts for a skid-steer robot.
    #[serde(rename = "nonholonomic_lever_arm_m", default)]
    pub lever_arm_m: [f64; 3],
}

impl Nonholonomic {
    fn default_interval_ns() -> u64 {
        50_000_000
    }
}

/// Whether every axis of the attitude is known to [`MAX_ATTITUDE_SD`]: before,
/// a measurement through the attitude is linearised about a wrong body frame.
pub fn attitude_known<const D: usize>(s: &InsState<D>) -> bool {
    (6..9).all(|i| s.filter().variance(i) <= MAX_ATTITUDE_SD * MAX_ATTITUDE_SD)
}

/// Whether roll and pitch are known to [`MAX_ATTITUDE_SD`], whatever the yaw:
/// the world-frame horizontal components of the attitude error `R δθ`
/// (`R P_θθ Rᵀ`, east and north). A body-frame speed needs the tilt (to take
/// gravity's part out of it), not the heading.
pub fn tilt_known<const D: usize>(s: &InsState<D>) -> bool {
    attitude_known(s) || tilt_variance(s) <= MAX_ATTITUDE_SD * MAX_ATTITUDE_SD
}

/// The larger variance of the attitude error about the world's east and north
/// axes (`R P_θθ Rᵀ`): the tilt's, rad².
pub fn tilt_variance<const D: usize>(s: &InsState<D>) -> f64 {
    let R = s.q().to_rotation_matrix().into_inner();
    let P = s.filter().P();
    let world = R * P.fixed_view::<3, 3>(6, 6) * R.transpose();
    world[(0, 0)].max(world[(1, 1)])
}

/// The body-frame velocity of the point at lever arm `l` from the IMU,
/// `v_p = Rᵀ v + ω × l`, and its Jacobian in the error state: `Rᵀ` on δv,
/// `[Rᵀ v]×` on δθ, `[l]×` on δb_g (none while standing, when `ω` is 0
/// whatever `b_g` is: `InsModel::body_rate`).
pub fn point_velocity<const D: usize>(s: &InsState<D>, l: &Vector3<f64>) -> (Vector3<f64>, SMatrix<f64, 3, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let v_b = R.transpose() * s.v();
    let w = InsModel::<D>::body_rate(s);
    let (vx, lx) = (v_b.cross_matrix(), l.cross_matrix());
    let mut H = SMatrix::<f64, 3, D>::zeros();
    for r in 0..3 {
        for k in 0..3 {
            H[(r, 3 + k)] = R[(k, r)]; // (Rᵀ)[r][k]
            H[(r, 6 + k)] = vx[(r, k)];
            if !s.standing() {
                H[(r, 12 + k)] = lx[(r, k)];
            }
        }
    }
    (v_b + w.cross(l), H)
}

/// Fuses `[v_p,y, v_p,z] = 0` into `s` and injects the correction, which it
/// returns. Below the minimum speed, with the attitude not yet known, or when
/// the gate refuses it, nothing changes.
pub fn fuse<const D: usize>(c: &Nonholonomic, model: &InsModel<D>, s: &mut InsState<D>) -> Option<SVector<f64, D>> {
    let (v_p, H_p) = point_velocity(s, &Vector3::from(c.lever_arm_m));
    if v_p.x.abs() < c.min_speed_mps {
        return None;
    }
    // The constraint is linear in δθ only for small attitude errors: with the
    // heading still unknown (e.g. at start, before fixes have shown the track)
    // it would pull the estimate the wrong way. Where nothing observes the
    // heading, no update moves it (the observability module) and the velocity
    // is the body's turned by the estimated heading: the tilt is enough.
    if !(attitude_known(s) || (model.yaw_unobserved() && tilt_known(s))) {
        return None;
    }
    let mut H: SMatrix<f64, INNOVATION_DIM, D> = H_p.fixed_rows::<2>(1).into_owned();
    if c.lever_arm_m == [0.0; 3] {
        // At the IMU the bias columns are zero: exactly zero (`[0]×` has −0 entries).
        H.fixed_columns_mut::<3>(12).fill(0.0);
    }
    let predicted = Vector2::new(v_p.y, v_p.z);
    let Rn = Matrix2::identity() * (c.std_mps * c.std_mps);
    model.update_residual(s, &(-predicted), &H, &Rn).1
}
