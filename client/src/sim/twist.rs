//! Simulated twist (visual or lidar odometry): the true linear and angular
//! velocity of the sensor's frame in its own axes plus white noise, with its
//! mounting (rotation and lever arm), random dropouts, arriving after a delay.

use fusion_shared::{SampleKind, Sample, TwistSample};
use nalgebra::{Matrix3, Vector3};

use super::arrival::{Reading, Sensor, SensorSim};

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
pub type TwistSim = SensorSim<TwistConfig>;

impl Sensor for TwistConfig {
    const KIND: SampleKind = SampleKind::Twist;
    const SALT: u64 = 0x7477_6900;
    type Memory = ();

    super::arrival::usual_timing!();

    fn read(&self, mut r: Reading<'_, ()>) -> Option<Sample> {
        let c = self;
        let (n_lin, n_ang) = (r.normal3() * c.linear_noise_mps, r.normal3() * c.angular_noise_radps);
        if r.lost(c.dropout_probability) {
            return None;
        }
        let truth = r.truth;
        let w = truth.omega_body_radps;
        let v_b = truth.attitude.inverse_transform_vector(&truth.vel_mps) + w.cross(&Vector3::from(c.lever_arm_m));
        let c_sb = c.rotation.transpose();
        let (linear, angular) = (c_sb * v_b + n_lin, c_sb * w + n_ang);
        let cov = TwistSample::diagonal_cov([c.linear_noise_mps; 3], [c.angular_noise_radps; 3]);
        Some(Sample::Twist(TwistSample::new(r.t_ns, c.sensor, r.seq, linear.into(), angular.into(), cov)))
    }
}



/// `fusion-sim`'s flags of the twist (visual or lidar odometry).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct TwistFlags {
    /// Twist (visual or lidar odometry) rate, Hz; 0: none (sensor id 0;
    /// `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    pub twist_rate: f64,
    /// Twist noise per axis: linear m/s, angular rad/s.
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.01")]
    pub twist_noise: Vec<f64>,
    /// The twist sensor's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    pub twist_mount: String,
    /// The twist sensor's origin in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub twist_lever_arm: Option<Vec<f64>>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::TwistSample {
    type Flags = TwistFlags;

    fn apply(
        f: &TwistFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.twist_rate <= 0.0 {
            return Ok(());
        }
        let [linear, angular] = super::flags::pair("--twist-noise", &f.twist_noise, "LINEAR,ANGULAR, e.g. 0.05,0.01")?;
        c.aiding.push(Arc::new(TwistConfig {
            rate_hz: f.twist_rate,
            linear_noise_mps: linear,
            angular_noise_radps: angular,
            rotation: super::flags::parse_mount("--twist-mount", &f.twist_mount)?,
            lever_arm_m: super::flags::triple("--twist-lever-arm", f.twist_lever_arm.as_deref())?.unwrap_or([0.0; 3]),
            dropout_probability: drive.dropouts,
            ..Default::default()
        }));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::CarTrajectory;

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
