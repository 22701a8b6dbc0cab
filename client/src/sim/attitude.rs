//! Simulated attitude (an AHRS: an IMU with its own attitude filter): the
//! sensor's true orientation in the world frame with its mounting, plus white
//! noise about the sensor's axes and a constant yaw error (a magnetic yaw
//! disturbed indoors), arriving after a delay.

use fusion_shared::{SampleKind, AttitudeSample, Sample};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::arrival::{Reading, Sensor, SensorSim};

/// Attitude simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct AttitudeConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the white noise about each of the sensor's axes,
    /// rad (reported in the covariance).
    pub noise_std_rad: f64,
    /// A constant error of the reported yaw about world up, rad (not in the
    /// reported covariance: what `[sensor.attitude] yaw = false` is for).
    pub yaw_error_rad: f64,
    /// `C_bs`: the sensor's axes into the body frame (body ← sensor).
    pub rotation: Matrix3<f64>,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for AttitudeConfig {
    fn default() -> Self {
        Self {
            rate_hz: 50.0,
            noise_std_rad: 0.5f64.to_radians(),
            yaw_error_rad: 0.0,
            rotation: Matrix3::identity(),
            delay_min_ns: 2_000_000,
            delay_max_ns: 10_000_000,
            sensor: 0,
        }
    }
}

/// Simulated attitude samples (an endless iterator).
pub type AttitudeSim = SensorSim<AttitudeConfig>;

impl Sensor for AttitudeConfig {
    const KIND: SampleKind = SampleKind::Attitude;
    const SALT: u64 = 0x6168_7273;
    type Memory = ();

    super::arrival::usual_timing!();

    fn read(&self, mut r: Reading<'_, ()>) -> Option<Sample> {
        let c = self;
        let noise = r.normal3() * c.noise_std_rad;
        let yaw_error = Rotation3::from_axis_angle(&Vector3::z_axis(), c.yaw_error_rad).into_inner();
        let body = r.truth.attitude.to_rotation_matrix().into_inner();
        // Z = Z_true Exp(−ε): q_true = q ⊗ Exp(ε).
        let sensor = yaw_error * body * c.rotation * Rotation3::new(-noise).into_inner();
        let q = UnitQuaternion::from_matrix(&sensor);
        let sample = AttitudeSample::with_std(r.t_ns, c.sensor, r.seq, [q.w, q.i, q.j, q.k], c.noise_std_rad);
        Some(Sample::Attitude(sample))
    }
}



/// `fusion-sim`'s flags of the attitude (an AHRS).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct AttitudeFlags {
    /// Attitude (an AHRS's orientation) rate, Hz; 0: none (sensor id 0).
    #[arg(long, default_value_t = 0.0)]
    pub attitude_rate: f64,
    /// Attitude noise per axis, degrees.
    #[arg(long, default_value_t = 0.5)]
    pub attitude_noise_deg: f64,
    /// A constant error of the AHRS's yaw, degrees (a magnetic yaw indoors).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub attitude_yaw_error_deg: f64,
    /// The AHRS's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    pub attitude_mount: String,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::AttitudeSample {
    type Flags = AttitudeFlags;

    fn apply(
        f: &AttitudeFlags,
        _drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.attitude_rate > 0.0 {
            c.aiding.push(Arc::new(AttitudeConfig {
                rate_hz: f.attitude_rate,
                noise_std_rad: f.attitude_noise_deg.to_radians(),
                yaw_error_rad: f.attitude_yaw_error_deg.to_radians(),
                rotation: super::flags::parse_mount("--attitude-mount", &f.attitude_mount)?,
                ..Default::default()
            }));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::CarTrajectory;

    /// Without noise, the reading taken back through the mount is the true
    /// body attitude, turned by the configured yaw error about world up.
    #[test]
    fn it_reads_the_mounted_sensors_orientation() {
        let trajectory = CarTrajectory::new(4);
        let rotation = Rotation3::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, -0.3).into_inner();
        let c = AttitudeConfig { noise_std_rad: 0.0, yaw_error_rad: 0.2, rotation, ..Default::default() };
        for a in AttitudeSim::new(trajectory.clone(), c, 0, 1).take(20) {
            let Sample::Attitude(s) = a.sample else { panic!() };
            let truth = trajectory.at(s.header.t_ns as f64 * 1e-9);
            let [w, x, y, z] = s.orientation_wxyz;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            let body = q.to_rotation_matrix().into_inner() * rotation.transpose();
            let expected = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.2) * truth.attitude.to_rotation_matrix();
            assert!((body - expected.matrix()).amax() < 1e-9);
        }
    }
}
