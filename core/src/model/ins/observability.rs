//! No heading from nowhere: the `ins` model's yaw held as a consider
//! direction for dead reckoning (an IMU with wheels, a twist, the motion
//! constraint, standstills, an AHRS's roll and pitch, a barometer: nothing
//! that gives a heading or a horizontal position).
//!
//! Such measurements do not change when the whole trajectory is turned about
//! world up: in the error state (`R_true = R Exp(δθ)`, δθ local) the turn is
//! the direction
//!
//! ```text
//! N(x̂) = [ e₃ × p̂ ;  e₃ × v̂ ;  R̂ᵀ e₃ ;  0 ;  0 ;  0 ]
//! ```
//!
//! and at the estimate it is linearised at, no such update sees it: `H N = 0`
//! (a body-frame velocity `Rᵀ v`: `Rᵀ (e₃ × v) + [Rᵀ v]× Rᵀ e₃ = 0`). But each
//! update moves the estimate, by metres per second of velocity while the
//! filter converges, and the direction nothing saw was the one of the
//! estimate before it. Seen from the estimate after it, the filter has learnt
//! something of the heading that nothing gave: the spurious information of
//! Huang, Mourikis and Roumeliotis, "Observability-based rules for designing
//! consistent EKF SLAM estimators" (IJRR 29(5), 2010). On simulated drives
//! without a heading it took the yaw σ to 0.56 of its start in the first
//! second while the yaw error did not fall; on robot_localization's Husky bag
//! with the AHRS's roll and pitch only, from 57° to 1.3°.
//!
//! Nothing of such a configuration can correct the heading, so no update moves
//! it: the world yaw error `ψ = uᵀ δθ`, `u = R̂ᵀ e₃`, is a *consider*
//! direction of every update (Schmidt, "Application of state-space methods to
//! navigation problems", 1966; Brink, "Partial-update Schmidt–Kalman filter",
//! J. Guid. Control Dyn. 40(9), 2017), as the standstill's updates already
//! hold it (the standstill module):
//!
//! ```text
//! c = [ 0 ; 0 ; u ; 0 ; 0 ; 0 ],   K ← (I − c cᵀ) K,   P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ
//! ```
//!
//! The Joseph form is exact for any gain, so the yaw's variance is what the
//! propagation made it (`cᵀ P⁺ c = cᵀ P c`) and its correlations with the
//! rest follow each update: the velocity, position and biases are corrected
//! as the yaw's uncertainty allows, and the yaw keeps its value and its σ.
//! (Bringing the information along the turn back to where it stood, by
//! variance added along `N` after each update, was tried first: the
//! information an update gives on the velocity shows along the shifted `N`
//! too, and on the Husky bag the yaw σ was pumped to 190° and the estimate
//! diverged.)
//!
//! The rule is on for a configuration whose sensors give neither a heading nor
//! a horizontal position: at least one `[[sensor]]`, and none that observes
//! either, as each kind declares it for its sensor's settings
//! ([`crate::frames::Observes`]; today an imu, odometry, twist, barometer,
//! attitude without its yaw, or pose fusing neither its yaw nor both `x` and
//! `y`). A kind that declares nothing gives no heading ([`gives_no_heading`]).

use nalgebra::{SVector, UnitQuaternion, Vector3};

use crate::frames::MountedSensor;

/// The consider direction `c` of the world yaw at attitude `q`: world up in
/// the body frame, in the attitude's rows of the error state (unit).
pub(crate) fn heading<const D: usize>(q: &UnitQuaternion<f64>) -> SVector<f64, D> {
    let mut c = SVector::<f64, D>::zeros();
    c.fixed_rows_mut::<3>(6).copy_from(&q.inverse_transform_vector(&Vector3::z()));
    c
}

/// A sensor that observes neither the heading nor the horizontal position
/// (as its kind declares).
pub fn gives_no_heading(m: &MountedSensor) -> bool {
    !(m.observes.heading || m.observes.horizontal_position)
}

/// A sensor that gives neither a horizontal position nor a velocity nor its
/// own attitude (as its kind declares: today an IMU, a magnetometer, a
/// barometer).
pub fn gives_no_position(m: &MountedSensor) -> bool {
    !m.observes.tilt
}

/// Whether nothing configured keeps the tilt observable but the accelerometer
/// (some sensors, none that gives a position, a velocity or an attitude): the
/// gravity reference is then on ([`super::gravity`]).
pub fn unaided(sensors: &[MountedSensor]) -> bool {
    !sensors.is_empty() && sensors.iter().all(gives_no_position)
}

/// Whether a configuration's sensors leave the yaw unobserved: some, and none
/// that gives a heading or a horizontal position.
pub fn yaw_unobserved(sensors: &[MountedSensor]) -> bool {
    !sensors.is_empty() && sensors.iter().all(gives_no_heading)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    /// A body velocity's `H` (the motion constraint's, the wheels') does not
    /// see the turn at the estimate it is linearised at.
    #[test]
    fn a_body_velocity_does_not_see_the_turn() {
        let q = UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7);
        let (p, v) = (Vector3::new(10.0, -4.0, 1.0), Vector3::new(3.0, 1.0, 0.1));
        let mut n = SVector::<f64, 15>::zeros();
        n.fixed_rows_mut::<3>(0).copy_from(&Vector3::z().cross(&p));
        n.fixed_rows_mut::<3>(3).copy_from(&Vector3::z().cross(&v));
        n += heading::<15>(&q);
        let R = q.to_rotation_matrix().into_inner();
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, 3).copy_from(&R.transpose());
        H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(R.transpose() * v).cross_matrix());
        assert!((H * n).norm() < 1e-12);
        assert!((heading::<15>(&q).norm() - 1.0).abs() < 1e-15);
    }

    fn sensors_of(sensors: &str) -> crate::frames::Frames {
        let model = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
                     accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1e-5\n[filter]\n\
                     initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\ninitial_covariance_diagonal = [1,1,1, 1,1,1, \
                     1,1,1, 1,1,1, 1,1,1]\n";
        let c = crate::config::Config::parse(&format!("{model}{sensors}")).unwrap();
        crate::frames::Frames::from_config(c.datum, &c.sensors, c.imu, &crate::measurement::Kinds).unwrap()
    }

    fn unobserved(sensors: &str) -> bool {
        yaw_unobserved(sensors_of(sensors).sensors())
    }

    /// The gravity reference is on for an IMU with a magnetometer or a
    /// barometer, and off with anything that gives a position, a velocity or
    /// an attitude (or with no sensors configured: any may come).
    #[test]
    fn unaided_only_without_a_position_a_velocity_or_an_attitude() {
        let on = |s: &str| unaided(sensors_of(s).sensors());
        let imu = "[[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\n";
        let others = "[[sensor]]\nname = \"x\"\nid = 1\nkinds = [";
        assert!(on(imu));
        assert!(on(&format!("{imu}{others}\"barometer\"]\n")));
        for kind in ["odometry", "twist", "attitude", "position", "velocity"] {
            assert!(!on(&format!("{imu}{others}\"{kind}\"]\n")), "{kind}");
        }
        assert!(!on(""));
    }

    /// The rule is on for sensors that give neither a heading nor a position,
    /// and off for anything else (or no sensors configured: any may come).
    #[test]
    fn on_only_without_a_heading_or_a_position() {
        let imu = "[[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\n";
        let wheels = "[[sensor]]\nname = \"wheels\"\nid = 1\nkinds = [\"odometry\", \"twist\"]\n";
        let ahrs = "[[sensor]]\nname = \"ahrs\"\nid = 2\nkinds = [\"attitude\"]\n";
        let tilt = format!("{ahrs}[sensor.attitude]\nyaw = false\n");
        let gnss = "[[sensor]]\nname = \"gnss\"\nid = 3\nkinds = [\"position\"]\n";
        assert!(unobserved(&format!("{imu}{wheels}")));
        assert!(unobserved(&format!("{imu}{wheels}{tilt}")));
        assert!(!unobserved(&format!("{imu}{wheels}{ahrs}")));
        assert!(!unobserved(&format!("{imu}{wheels}{gnss}")));
        let pose = "[[sensor]]\nname = \"slam\"\nid = 4\nkinds = [\"pose\"]\n";
        assert!(!unobserved(&format!("{imu}{pose}")));
        assert!(unobserved(&format!("{imu}{pose}[sensor.pose]\nfuse = [\"z\", \"roll\"]\n")));
        assert!(!unobserved(&format!("{imu}{pose}[sensor.pose]\nfuse = [\"z\", \"yaw\"]\n")));
        assert!(!unobserved(""));
    }
}
