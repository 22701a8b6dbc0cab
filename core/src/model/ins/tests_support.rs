//! Helpers for the tests of the measurement modules: a moving state and
//! numerical Jacobians with respect to the error state.

#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

use super::{ImuNoise, InsModel, InsState, N, OdometryScale, error_state::inject};

/// The error-state dimension with the odometry scale factor.
pub const SCALED: usize = N + 1;
use crate::frames::Frames;
use crate::model::Model;

/// `aux` with barometer `sensor`'s bias (σ 100 m, 0.05 m/√s: the
/// barometer's defaults).
pub fn barometer(aux: super::AuxStates, sensor: u32) -> super::AuxStates {
    let prior = super::AuxPrior { initial: 0.0, std: 100.0, random_walk: 0.05 };
    aux.with_sensor(fusion_shared::SampleKind::Barometer, sensor, &[prior])
}

/// `aux` with pose sensor `sensor`'s estimated map frame (σ π, 1 km; the
/// pose sensor's default random walks).
pub fn estimated_frame(aux: super::AuxStates, sensor: u32) -> super::AuxStates {
    let origin = super::AuxPrior { initial: 0.0, std: 1000.0, random_walk: 0.01 };
    let yaw = super::AuxPrior { initial: 0.0, std: std::f64::consts::PI, random_walk: 0.01_f64.to_radians() };
    aux.with_sensor(fusion_shared::SampleKind::Pose, sensor, &[yaw, origin, origin, origin])
}

/// Usual MEMS IMU noise.
pub const NOISE: ImuNoise = ImuNoise {
    accelerometer_noise_density: 0.02,
    gyroscope_noise_density: 0.001,
    accelerometer_random_walk: 0.001,
    gyroscope_random_walk: 1e-5,
};

/// An `ins` model with [`NOISE`], no gate.
pub fn model() -> InsModel {
    let mut x0 = [0.0; 16];
    x0[6] = 1.0;
    InsModel::new(NOISE, 9.80665, x0, [1.0; N], None, 0).unwrap()
}

/// [`model`] with the odometry scale factor as a state (k₀ = 1, σ 0.02).
pub fn scaled_model() -> InsModel<SCALED> {
    model().with_odometry_scale(OdometryScale::default()).unwrap()
}

/// A state driving at 12 m/s, tilted and turning at 0.4 rad/s, with biases.
pub fn moving_state() -> InsState {
    moving(&model())
}

/// [`moving_state`] of [`scaled_model`], with an odometry scale factor of 1.03.
pub fn moving_scaled_state() -> InsState<SCALED> {
    let mut s = moving(&scaled_model());
    set_scale(&mut s, 1.03);
    s
}

/// Sets the nominal odometry scale factor of `s`.
pub fn set_scale(s: &mut InsState<SCALED>, k: f64) {
    s.nominal[super::NOMINAL] = k;
}

/// Marks `s` ready: IMU values held, the alignment done.
pub fn set_ready<const D: usize>(s: &mut InsState<D>) {
    s.ready = true;
}

/// Holds IMU 0's values `f`, `w` at `t_ns` in `s`.
pub fn hold_imu<const D: usize>(s: &mut InsState<D>, t_ns: u64, f: Vector3<f64>, w: Vector3<f64>) {
    s.imu.hold(Frames::default().imus(), 0, t_ns, f, w);
}

/// Sets the nominal value of auxiliary error state `i` of `s`.
pub fn set_aux_value<const D: usize>(s: &mut InsState<D>, i: usize, v: f64) {
    s.nominal[i + 1] = v;
}

/// [`moving_state`] of model `m` (with its auxiliary states at their initial values).
pub fn moving<const D: usize>(m: &InsModel<D>) -> InsState<D> {
    let mut s = m.initial_state();
    let q = UnitQuaternion::from_euler_angles(0.05, -0.08, 2.3);
    let v = q * Vector3::new(12.0, 0.2, 0.0);
    s.set(Vector3::new(5.0, -3.0, 1.0), v, q, Vector3::new(0.02, -0.01, 0.03), Vector3::new(0.002, -0.001, 0.003));
    let frames = Frames::default();
    s.imu.hold(frames.imus(), 0, 0, Vector3::new(0.3, 4.8, 9.8), Vector3::new(0.01, -0.02, 0.4));
    s.ready = true;
    s
}

/// `∂h/∂δx` by central differences of `h` at the state with `±ε eⱼ` injected.
pub fn numeric_jacobian<const M: usize, const D: usize>(
    s: &InsState<D>,
    h: impl Fn(&InsState<D>) -> SVector<f64, M>,
) -> SMatrix<f64, M, D> {
    let eps = 1e-6;
    let mut J = SMatrix::<f64, M, D>::zeros();
    for j in 0..D {
        let mut dx = SVector::<f64, D>::zeros();
        dx[j] = eps;
        let (mut plus, mut minus) = (*s, *s);
        inject(&mut plus, &dx);
        inject(&mut minus, &(-dx));
        J.set_column(j, &((h(&plus) - h(&minus)) / (2.0 * eps)));
    }
    J
}
