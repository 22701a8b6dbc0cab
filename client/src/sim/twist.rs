//! Simulated twist (visual or lidar odometry): the true linear and angular
//! velocity of the sensor's frame in its own axes plus white noise, with its
//! mounting (rotation and lever arm), random dropouts, arriving after a delay.

use fusion_shared::{Sample, TwistSample};
use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::arrival::{Arrival, schedule};
use super::trajectory::CarTrajectory;

/// Twist simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the linear velocity's white noise per axis, m/s.
    pub linear_noise_mps: f64,
    /// Standard deviation of the angular velocity's white noise per axis, rad/s.
    pub angular_noise_radps: f64,
    /// `C_bs`: the sensor's axes into the body frame (body ← sensor).
    pub rotation: Matrix3<f64>,
    /// The sensor's origin in the body frame, m.
    pub lever_arm_m: [f64; 3],
    /// Probability that a sample is lost.
    pub dropout_probability: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for TwistConfig {
    fn default() -> Self {
        Self {
            rate_hz: 20.0,
            linear_noise_mps: 0.05,
            angular_noise_radps: 0.01,
            rotation: Matrix3::identity(),
            lever_arm_m: [0.0; 3],
            dropout_probability: 0.0,
            delay_min_ns: 30_000_000,
            delay_max_ns: 80_000_000,
            sensor: 0,
        }
    }
}

/// Simulated twist samples (an endless iterator).
#[derive(Debug, Clone)]
pub struct TwistSim {
    trajectory: CarTrajectory,
    config: TwistConfig,
    start_ns: u64,
    index: u64,
    rng: ChaCha8Rng,
}

impl TwistSim {
    /// Samples on `trajectory`, the first at `start_ns` (trajectory time 0).
    pub fn new(trajectory: CarTrajectory, config: TwistConfig, start_ns: u64, seed: u64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7477_6900 ^ (u64::from(config.sensor) << 40));
        Self { trajectory, config, start_ns, index: 0, rng }
    }
}

impl Iterator for TwistSim {
    type Item = Arrival;

    fn next(&mut self) -> Option<Arrival> {
        loop {
            let c = &self.config;
            let (offset_ns, delay) = schedule(&mut self.rng, self.index, c.rate_hz, c.delay_min_ns, c.delay_max_ns);
            let mut normal = || Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(&mut self.rng));
            let (n_lin, n_ang) = (normal() * c.linear_noise_mps, normal() * c.angular_noise_radps);
            let lost = self.rng.random::<f64>() < c.dropout_probability;
            let seq = self.index;
            self.index += 1;
            if lost {
                continue;
            }
            let truth = self.trajectory.at(offset_ns as f64 * 1e-9);
            let w = truth.omega_body_radps;
            let v_b = truth.attitude.inverse_transform_vector(&truth.vel_mps) + w.cross(&Vector3::from(c.lever_arm_m));
            let c_sb = c.rotation.transpose();
            let (linear, angular) = (c_sb * v_b + n_lin, c_sb * w + n_ang);
            let cov = TwistSample::diagonal_cov([c.linear_noise_mps; 3], [c.angular_noise_radps; 3]);
            let t_ns = self.start_ns + offset_ns;
            let sample = TwistSample::new(t_ns, c.sensor, seq, linear.into(), angular.into(), cov);
            return Some(Arrival { arrival_ns: t_ns + delay, sample: Sample::Twist(sample), outlier: false });
        }
    }
}

super::aiding_sim!(TwistConfig, TwistSim, Twist);

#[cfg(test)]
mod tests {
    use super::*;

    /// Without noise the sensor reads the body's motion at its lever arm in its
    /// own axes.
    #[test]
    fn it_reads_the_motion_of_its_frame() {
        let trajectory = CarTrajectory::new(4);
        let rotation = nalgebra::Rotation3::from_euler_angles(0.2, 0.0, -1.0).into_inner();
        let arm = Vector3::new(0.5, 0.2, 1.1);
        let c = TwistConfig {
            linear_noise_mps: 0.0,
            angular_noise_radps: 0.0,
            rotation,
            lever_arm_m: arm.into(),
            ..Default::default()
        };
        for a in TwistSim::new(trajectory.clone(), c, 0, 1).take(50) {
            let Sample::Twist(s) = a.sample else { panic!() };
            let truth = trajectory.at(s.header.t_ns as f64 * 1e-9);
            let w = rotation * Vector3::from(s.angular_radps);
            assert!((w - truth.omega_body_radps).norm() < 1e-12);
            // The sensor's velocity in the world frame is the body's plus ω × l turned.
            let world = truth.attitude * (rotation * Vector3::from(s.linear_mps));
            let expected = truth.vel_mps + truth.attitude * truth.omega_body_radps.cross(&arm);
            assert!((world - expected).norm() < 1e-12, "{world} vs {expected}");
            assert!(a.arrival_ns >= s.header.t_ns + 30_000_000);
        }
    }
}
