//! Helpers for the tests of the measurement modules: a moving state and
//! numerical Jacobians with respect to the error state.

#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

use super::{ImuNoise, InsModel, InsState, N, error_state::inject};
use crate::frames::Frames;
use crate::model::Model;

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

/// A state driving at 12 m/s, tilted and turning at 0.4 rad/s, with biases.
pub fn moving_state() -> InsState {
    let m = model();
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
pub fn numeric_jacobian<const M: usize>(s: &InsState, h: impl Fn(&InsState) -> SVector<f64, M>) -> SMatrix<f64, M, N> {
    let eps = 1e-6;
    let mut J = SMatrix::<f64, M, N>::zeros();
    for j in 0..N {
        let mut dx = SVector::<f64, N>::zeros();
        dx[j] = eps;
        let (mut plus, mut minus) = (*s, *s);
        inject(&mut plus, &dx);
        inject(&mut minus, &(-dx));
        J.set_column(j, &((h(&plus) - h(&minus)) / (2.0 * eps)));
    }
    J
}
