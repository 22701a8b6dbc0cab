//! The simulated car of the vehicle Monte Carlo tests: two 200 Hz MEMS IMUs on
//! one clock, mounted differently (one publishing forward-right-down axes), with
//! turn-on biases, and their `[[sensor]]` entries.

use fusion_client::sim::ImuConfig;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The IMUs: id, forward-right-down axes, roll/pitch/yaw of the mount (degrees).
pub const IMUS: [(u32, bool, [f64; 3]); 2] = [(0, true, [3.0, -2.0, 90.0]), (1, false, [-1.5, 2.5, -90.0])];

/// IMU `spec` of [`IMUS`] (Kalibr densities 0.02, 0.001, 0.001, 1e-5 at 200 Hz),
/// with turn-on biases of `accel_bias_std` (m/s²) and `gyro_bias_std` (rad/s).
pub fn imu(&(id, frd, rpy): &(u32, bool, [f64; 3]), accel_bias_std: f64, gyro_bias_std: f64) -> ImuConfig {
    let [r, p, y] = rpy.map(f64::to_radians);
    let flip = if frd { Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)) } else { Matrix3::identity() };
    ImuConfig {
        accel_bias_std,
        gyro_bias_std,
        sensor: id,
        rotation: UnitQuaternion::from_euler_angles(r, p, y).to_rotation_matrix().into_inner() * flip,
        ..ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5)
    }
}

/// The `[[sensor]]` entries of [`IMUS`].
pub fn imu_sensors() -> String {
    IMUS.iter()
        .map(|(id, frd, [r, p, y])| {
            let axes = if *frd { "frd" } else { "flu" };
            format!(
                "[[sensor]]\nname = \"imu-{id}\"\nid = {id}\nkinds = [\"imu\"]\naxes = \"{axes}\"\n\
                 rotation_rpy_deg = [{r}, {p}, {y}]\n"
            )
        })
        .collect()
}

/// A drive of `duration_s` with [`IMUS`] (turn-on biases of `sigma0[3]`,
/// `sigma0[4]`, body specific force) and no aiding sensor yet.
pub fn drive(seed: u64, duration_s: f64, sigma0: [f64; 5]) -> fusion_client::sim::ScenarioConfig {
    let imu = |spec| imu(spec, sigma0[3], sigma0[4]);
    fusion_client::sim::ScenarioConfig {
        seed,
        duration_s,
        imu: imu(&IMUS[0]),
        extra_imus: vec![imu(&IMUS[1])],
        imu_output: fusion_client::sim::ImuOutput::BodySpecificForce,
        ..Default::default()
    }
}

/// The `ins` config of the car: [`IMUS`]' noise densities, the `[filter]`
/// lines `filter`, a 0.9999 gate, `datum`, the `[[sensor]]` entries `sensors`
/// and the IMUs'.
pub fn ins_config(filter: &str, datum: &fusion_shared::geodesy::Datum, sensors: &str) -> String {
    format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n\
         [filter]\n{filter}[gating]\nprobability = 0.9999\n\
         [datum]\nlatitude_deg = {}\nlongitude_deg = {}\nheight_m = {}\n{sensors}{}",
        datum.latitude_deg,
        datum.longitude_deg,
        datum.height_m,
        imu_sensors()
    )
}
