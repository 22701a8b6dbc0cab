//! Gravity reference: where no sensor gives a position or a velocity (an IMU
//! alone, or with a magnetometer or a barometer: a handheld device, an indoor
//! drone, an AHRS), nothing else keeps the tilt observable, and the
//! accelerometer is taken as a measurement of gravity while the body does not
//! accelerate, as every AHRS does (PX4 EKF2's gravity fusion, Madgwick's and
//! Mahony's filters). A pseudo-measurement of the `ins` model.
//!
//! Over windows of `window_ns`, each IMU sample `k` (body specific force `f_k`,
//! attitude `R_k` after its step) gives the acceleration it implies in the
//! world frame, `a_k = R_k (f_k − b_a) + g` (zero at rest), summed with
//! `|a_k|²`. At the end of a window of `n` samples at a per-IMU rate `r`, with
//! `ā` their mean, `s_a²` their per-axis sample variance, `σ_a² r` the
//! variance of one sample at rest (density² × rate) and
//! `d = |f̄ − b_a| − |g|` the deviation of the mean specific force from gravity:
//!
//! ```text
//! fused when |d| ≤ max_deviation_mps2 and s_a² ≤ variance_threshold · σ_a² r
//!
//! 0 = ā + n_a      y = −ā      H = [0  0  [g]× R  −R  0]    (on δp δv δθ δb_a δb_g)
//! R_y = (σ_a² r / n + σ_u² + max(s_a² − σ_a² r, 0) + d²) I
//! ```
//!
//! (`a(δ) = R Exp(δθ)(f − b_a − δb_a) + g ≈ ā − R [φ]× δθ − R δb_a` with
//! `φ = f − b_a`, linearised at the specific force of a body at rest,
//! `φ = Rᵀ(−g)`, as the standstill's `F` is: `−R [Rᵀ(−g)]× = [g]× R`. Its
//! vertical row is zero on `δθ`, and no row sees a rotation about world up:
//! the heading is neither corrected nor made more certain.) `R_y` is the noise
//! of the mean of `n` white samples and an unmodelled mean acceleration: the
//! configured floor `σ_u` (`acceleration_std_mps2`), the variation seen within
//! the window beyond the noise, and the magnitude's deviation from gravity
//! (the motion inflates it). A horizontal acceleration changes the magnitude
//! little (3 m/s² across gravity makes `d` 0.45 m/s²), so the update is gated
//! besides, always, at χ²₃(1 − 10⁻⁶) with its own innovation covariance: an
//! acceleration far beyond what the tilt's uncertainty explains is motion,
//! not a tilt error, and is not fused. While the vehicle stands
//! ([`super::standstill`], if configured) the standstill's updates hold the
//! tilt instead.
//!
//! Everything it keeps is in the filter state ([`Window`]), so a rewind
//! replays it exactly.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::filter::ChiSquareGate;
use crate::model::StepOutcome;
use crate::model::ins::{InsModel, InsState};

/// The probability of the gravity update's own gate: χ²₃(1 − 10⁻⁶).
pub const GATE_PROBABILITY: f64 = 1.0 - 1e-6;

/// `[model.gravity]`: the gravity reference's parameters. On where every
/// configured sensor is an IMU, a magnetometer or a barometer (the
/// observability module's `unaided`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GravityReference {
    /// Length of a window, ns (default 100 ms).
    #[serde(default = "GravityReference::default_window_ns")]
    pub window_ns: u64,
    /// The most the mean specific force's magnitude may differ from gravity,
    /// m/s² (default 0.5: 5 % of g).
    #[serde(default = "GravityReference::default_max_deviation")]
    pub max_deviation_mps2: f64,
    /// The most the window's variance may be, as a multiple of the variance
    /// the noise density gives at rest (default 10).
    #[serde(default = "GravityReference::default_variance_threshold")]
    pub variance_threshold: f64,
    /// `σ_u`: the unmodelled mean acceleration always allowed for, m/s²
    /// (default 0.02).
    #[serde(default = "GravityReference::default_acceleration_std")]
    pub acceleration_std_mps2: f64,
}

impl Default for GravityReference {
    fn default() -> Self {
        Self {
            window_ns: Self::default_window_ns(),
            max_deviation_mps2: Self::default_max_deviation(),
            variance_threshold: Self::default_variance_threshold(),
            acceleration_std_mps2: Self::default_acceleration_std(),
        }
    }
}

impl GravityReference {
    fn default_window_ns() -> u64 {
        100_000_000
    }
    fn default_max_deviation() -> f64 {
        0.5
    }
    fn default_variance_threshold() -> f64 {
        10.0
    }
    fn default_acceleration_std() -> f64 {
        0.005
    }
}

/// The sums of the current window. Part of [`InsState`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Window {
    start_ns: Option<u64>,
    last_ns: u64,
    n: u32,
    /// Σ a_k (world), Σ |a_k|², Σ f_k − b_a (body).
    sum_a: [f64; 3],
    sum_aa: f64,
    sum_f: [f64; 3],
    /// Gravity updates fused.
    pub(crate) updates: u64,
}

impl Window {
    fn clear(&mut self) {
        *self = Self { updates: self.updates, ..Self::default() };
    }
}

/// Takes one IMU sample (body specific force `f`, already held and
/// propagated) at `t_ns`; at the end of a window fuses the gravity update if
/// the window allows it (see the module docs), and returns its correction.
pub fn observe<const D: usize>(
    c: &GravityReference,
    gate: &ChiSquareGate,
    model: &InsModel<D>,
    s: &mut InsState<D>,
    t_ns: u64,
    f: Vector3<f64>,
) -> Option<SVector<f64, D>> {
    if s.standing() {
        s.gravity.clear();
        return None;
    }
    let phi = f - s.b_a();
    let a = s.q() * phi + model.g();
    let w = &mut s.gravity;
    let start = *w.start_ns.get_or_insert(t_ns);
    w.last_ns = t_ns;
    w.n += 1;
    for i in 0..3 {
        w.sum_a[i] += a[i];
        w.sum_f[i] += phi[i];
    }
    w.sum_aa += a.norm_squared();
    if t_ns.saturating_sub(start) < c.window_ns {
        return None;
    }
    let window = *w;
    w.clear();
    let imus = s.imu.mean().map_or(1, |(_, _, k)| k);
    let (y, R) = innovation(c, model, &window, imus)?;
    let Rot = s.q().to_rotation_matrix().into_inner();
    let mut H = SMatrix::<f64, 3, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(model.g().cross_matrix() * Rot));
    H.fixed_view_mut::<3, 3>(0, 9).copy_from(&(-Rot));
    let (outcome, injected) = model.update_residual_gated(s, &y, &H, &R, Some(gate));
    if matches!(outcome, StepOutcome::Fused { .. }) {
        s.gravity.updates += 1;
    }
    injected
}

/// `y = −ā` and `R_y` of a finished window of samples from `imus` IMUs, if
/// its tests pass (see the module docs).
fn innovation<const D: usize>(
    c: &GravityReference,
    model: &InsModel<D>,
    w: &Window,
    imus: u32,
) -> Option<(Vector3<f64>, Matrix3<f64>)> {
    let span_s = w.last_ns.saturating_sub(w.start_ns?) as f64 * 1e-9;
    if w.n < 3 || span_s <= 0.0 {
        return None;
    }
    let n = f64::from(w.n);
    let rate = f64::from(w.n - 1) / (f64::from(imus.max(1)) * span_s);
    let sample_var = model.noise().accelerometer_noise_density.powi(2) * rate;
    let mean = |v: &[f64; 3]| Vector3::new(v[0], v[1], v[2]) / n;
    let (a, phi) = (mean(&w.sum_a), mean(&w.sum_f));
    let var = ((w.sum_aa - n * a.norm_squared()) / (3.0 * (n - 1.0))).max(0.0);
    let d = phi.norm() - model.g().norm();
    if d.abs() > c.max_deviation_mps2 || var > c.variance_threshold * sample_var {
        return None;
    }
    let motion = (var - sample_var).max(0.0) + d * d;
    let R = Matrix3::identity() * (sample_var / n + c.acceleration_std_mps2.powi(2) + motion);
    Some((-a, R))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::model::ins::tests_support::{model, set_ready};
    use nalgebra::UnitQuaternion;

    /// A level body at heading 0.7 rad, believed tilted by `tilt` rad about
    /// the world's x axis with attitude σ `sd` (accelerometer bias σ 0.01
    /// m/s²); the result of one window of
    /// samples of its specific force plus `acceleration` (world), the
    /// estimate before it, and whether the window was fused.
    fn window(tilt: f64, sd: f64, acceleration: Vector3<f64>) -> (InsState, InsState, bool) {
        let m = model().with_gravity_reference(Some(GravityReference::default()));
        let (c, gate) = m.gravity_reference().unwrap().clone();
        let truth = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.7);
        let believed = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt) * truth;
        let mut s = m.initial_state();
        set_ready(&mut s);
        s.set(s.p(), s.v(), believed, s.b_a(), s.b_g());
        s.filter_mut().reset_error(|P| {
            for i in 6..9 {
                (P[(i, i)], P[(i + 3, i + 3)]) = (sd * sd, 1e-4);
            }
        });
        let before = s;
        let f = truth.inverse_transform_vector(&(acceleration + Vector3::new(0.0, 0.0, 9.80665)));
        for k in 0..=10u64 {
            observe(&c, &gate, &m, &mut s, k * 10_000_000, f);
        }
        (before, s, s.gravity.updates == 1)
    }

    fn tilt(q: &UnitQuaternion<f64>) -> f64 {
        q.inverse_transform_vector(&Vector3::z()).angle(&Vector3::z())
    }

    /// At rest, a window corrects a tilt of 2° known to 5°, and leaves the
    /// heading where it was.
    #[test]
    fn a_window_at_rest_corrects_the_tilt_not_the_heading() {
        let (before, after, fused) = window(2f64.to_radians(), 5f64.to_radians(), Vector3::zeros());
        assert!(fused);
        assert!(tilt(&after.q()) < 0.05 * tilt(&before.q()), "{} {}", tilt(&after.q()), tilt(&before.q()));
        // The correction turns about a horizontal axis of the world.
        let turn = (after.q() * before.q().inverse()).scaled_axis();
        assert!(turn.z.abs() < 1e-9 * turn.norm(), "{turn}");
        assert!(after.filter().P()[(6, 6)] < before.filter().P()[(6, 6)]);
    }

    /// A steady acceleration across gravity (1.5 m/s²: the magnitude moves by
    /// 0.11 m/s² only) with the tilt known to 0.5° is motion, not a tilt
    /// error: gated, nothing moves. With the tilt known to 10° it would be
    /// within the gate: the tilt's own uncertainty explains it.
    #[test]
    fn an_acceleration_across_gravity_is_not_taken_for_a_tilt() {
        let east = Vector3::new(1.5, 0.0, 0.0);
        let (before, after, fused) = window(0.0, 0.5f64.to_radians(), east);
        assert!(!fused, "gated");
        assert_eq!((after.q(), after.filter().P()), (before.q(), before.filter().P()));
        let (_, _, fused) = window(0.0, 10f64.to_radians(), east);
        assert!(fused);
        // A window that moves (its variance) is not fused at all.
        let m = model().with_gravity_reference(Some(GravityReference::default()));
        let (c, gate) = m.gravity_reference().unwrap().clone();
        let mut s = m.initial_state();
        set_ready(&mut s);
        for k in 0..=10u64 {
            let f = Vector3::new(2.0 * (k as f64).sin(), 0.0, 9.80665);
            assert!(observe(&c, &gate, &m, &mut s, k * 10_000_000, f).is_none());
        }
        assert_eq!(s.gravity.updates, 0);
    }
}
