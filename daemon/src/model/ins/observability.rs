//! No confidence from nowhere: the `ins` model's heading information, capped
//! for dead reckoning (an IMU with wheels, a twist, the motion constraint,
//! standstills, an AHRS's roll and pitch: nothing that gives a heading or a
//! position).
//!
//! Such measurements do not change when the whole trajectory is turned about
//! world up through the current position `p̂`: `v → R_z(ε) v`, `R → R_z(ε) R`,
//! the path ahead turned about `p̂` (biases, in the body frame, unchanged). In
//! the error state (`R_true = R Exp(δθ)`, δθ local) this is the direction
//!
//! ```text
//! N(x̂) = [ 0 ;  e₃ × v̂ ;  R̂ᵀ e₃ ;  0 ;  0 ;  0 ]
//! ```
//!
//! and at the estimate it is linearised at, no such update sees it: `H N = 0`
//! (a body-frame velocity `Rᵀ v`: `Rᵀ (e₃ × v) + [Rᵀ v]× Rᵀ e₃ = 0`). But the
//! update moves the estimate, by metres per second of velocity while the
//! filter converges, and the direction nothing saw was the one of the estimate
//! before it. Seen from the estimate after it, the filter has gained
//! information on the turn — on the yaw — that nothing gave: the spurious
//! information of Huang, Mourikis and Roumeliotis, "Observability-based rules
//! for designing consistent EKF SLAM estimators" (IJRR 29(5), 2010). On
//! simulated drives without a heading it took the yaw σ to half its start in
//! the first second, while the yaw error did not fall.
//!
//! The rule here: an update never adds information along the turn. With
//! `I(x̂, P) = Nᵀ P⁻¹ N` (the information along `N(x̂)`), `I⁻` before an update
//! (at the estimate it meets) and `I⁺` after it (at the estimate it leaves),
//! when `I⁺ > I⁻` the covariance grows along the turn by just what restores
//! `I⁻` (Sherman–Morrison: `Nᵀ (P + γ N Nᵀ)⁻¹ N = I / (1 + γ I)`):
//!
//! ```text
//! P⁺ ← P⁺ + γ N Nᵀ,    γ = 1/I⁻ − 1/I⁺,    N = N(x̂⁺)
//! ```
//!
//! that is, a turn of the whole state about world up of variance `γ` is added
//! back: the yaw's, and the velocity's along `e₃ × v̂` with it, correlated as
//! the turn makes them. Everything normal to `N` under `P⁻¹` is left as the
//! update made it. The propagation carries `N` onto the next state's exactly
//! (`Φ N(x̂ₖ) = N(x̂ₖ₊₁)`, as the mechanisation is linearised at the state
//! it starts from) and only adds noise, so the information on the turn
//! never grows: the yaw σ stays at least `1/√I₀` of the start (`I₀` from the
//! initial covariance: the yaw's σ, less the little that the start's world
//! velocity σ tells of the heading).
//!
//! It is on for a configuration whose sensors give neither a heading nor a
//! position: at least one `[[sensor]]`, and each an imu, odometry, twist,
//! barometer or attitude without its yaw ([`gives_no_heading`]).

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

use crate::frames::MountedSensor;
use fusion_shared::SampleKind;

/// The turn about world up through the current position of the state with
/// velocity `v` and attitude `q`: `N(x̂)` of the module docs.
pub(crate) fn turn<const D: usize>(v: &Vector3<f64>, q: &UnitQuaternion<f64>) -> SVector<f64, D> {
    let mut n = SVector::<f64, D>::zeros();
    n.fixed_rows_mut::<3>(3).copy_from(&Vector3::z().cross(v));
    n.fixed_rows_mut::<3>(6).copy_from(&q.inverse_transform_vector(&Vector3::z()));
    n
}

/// `Nᵀ P⁻¹ N`, the information along `n`; `None` if `P` is not positive
/// definite.
pub(crate) fn information<const D: usize>(P: &SMatrix<f64, D, D>, n: &SVector<f64, D>) -> Option<f64> {
    P.cholesky().map(|c| n.dot(&c.solve(n)))
}

/// The variance `γ` to add along `n` to bring the information along it from
/// `now` down to `entitled` (0 when it is not above).
pub(crate) fn excess(now: f64, entitled: f64) -> f64 {
    if now > entitled && entitled > 0.0 { 1.0 / entitled - 1.0 / now } else { 0.0 }
}

/// A sensor that observes neither the heading nor the horizontal position.
pub fn gives_no_heading(m: &MountedSensor) -> bool {
    match m.kind {
        SampleKind::Imu | SampleKind::Odometry | SampleKind::Twist | SampleKind::Barometer => true,
        SampleKind::Attitude => !m.attitude.unwrap_or_default().yaw,
        _ => false,
    }
}

/// Whether a configuration's sensors leave the yaw unobserved: some, and none
/// that gives a heading or a position.
pub fn yaw_unobserved(sensors: &[MountedSensor]) -> bool {
    !sensors.is_empty() && sensors.iter().all(gives_no_heading)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body velocity's `H` (the motion constraint's, the wheels') does not
    /// see the turn at the estimate it is linearised at.
    #[test]
    fn a_body_velocity_does_not_see_the_turn() {
        let q = UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7);
        let v = Vector3::new(3.0, 1.0, 0.1);
        let n: SVector<f64, 15> = turn(&v, &q);
        let R = q.to_rotation_matrix().into_inner();
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, 3).copy_from(&R.transpose());
        H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(R.transpose() * v).cross_matrix());
        assert!((H * n).norm() < 1e-12);
    }

    fn unobserved(sensors: &str) -> bool {
        let model = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
                     accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1e-5\n[filter]\n\
                     initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\ninitial_covariance_diagonal = [1,1,1, 1,1,1, \
                     1,1,1, 1,1,1, 1,1,1]\n";
        let c = crate::config::Config::parse(&format!("{model}{sensors}")).unwrap();
        let frames = crate::frames::Frames::from_config(c.datum, &c.sensors, c.imu).unwrap();
        yaw_unobserved(frames.sensors())
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
        assert!(!unobserved(""));
    }

    /// Adding `excess` along `n` brings the information along it to what is
    /// entitled, and leaves it where it is not above.
    #[test]
    fn the_excess_restores_the_entitled_information() {
        let n: SVector<f64, 15> =
            turn(&Vector3::new(3.0, 1.0, 0.1), &UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7));
        let A =
            SMatrix::<f64, 15, 15>::from_fn(|r, c| ((r * 7 + c * 3) % 5) as f64 * 0.1 + if r == c { 1.0 } else { 0.0 });
        let P = A * A.transpose() * 0.01;
        let now = information(&P, &n).unwrap();
        let g = excess(now, now / 3.0);
        assert!(g > 0.0);
        let after = information(&(P + n * n.transpose() * g), &n).unwrap();
        assert!((after - now / 3.0).abs() < 1e-9 * now, "{after} against {}", now / 3.0);
        assert_eq!(excess(now, now * 2.0), 0.0);
    }
}
