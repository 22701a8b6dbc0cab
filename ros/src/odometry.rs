//! fusiond's estimate as a ROS user expects it (REP-105): `nav_msgs/msg/Odometry`
//! of `base_link` in `odom`, and TF `odom → base_link`.
//!
//! fusiond estimates its body frame (the IMU's axes and origin); `base_link`
//! is configured once as a pose in it: origin `t` and axes `M` (body ←
//! base_link). With the estimate's position `p`, velocity `v` (world), attitude
//! `R` (world ← body), gyro bias `b_g` and the last IMU rate `g` (body):
//!
//! ```text
//! p_b = p + R t                     position of base_link
//! R_b = R M                         its attitude
//! ω   = g − b_g                     body rate
//! v_b = Mᵀ (Rᵀ v + ω × t)           its velocity, in its own axes (the twist's frame)
//! ω_b = Mᵀ ω                        its rate, in its own axes
//! ```
//!
//! The covariances are the estimate's mapped to first order, `J Σ Jᵀ`, over
//! the error state `[δp, δv, δθ, δb_g]` (δθ local: `R_true = R Exp(δθ)`) and the
//! IMU's rate noise `n_g` (the message's `angular_velocity_covariance`):
//!
//! ```text
//! δp_b = δp − R [t]× δθ              δθ_b = R δθ   (about the fixed axes, as ROS writes a pose's)
//! δv_b = Mᵀ (Rᵀ δv + [Rᵀv]× δθ + [t]× δb_g − [t]× n_g)
//! δω_b = Mᵀ (n_g − δb_g)
//! ```
//!
//! The `linear` model has no attitude: the odometry's orientation is the
//! identity with a variance of [`UNKNOWN_VARIANCE`] (REP-145's "large"), its
//! twist the world velocity, its rate unknown likewise.

use fusion_shared::StateSnapshot;
use fusion_shared::ros::messages::{
    Odometry, Pose, PoseWithCovariance, Quaternion, Ros2Header, Twist, TwistWithCovariance, Vector3,
};
use fusion_shared::ros::ros2::{Transform, TransformStamped};
use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3 as V3};

/// The variance written for what the estimate does not have.
pub const UNKNOWN_VARIANCE: f64 = 1e6;

/// `base_link` in fusiond's body frame.
#[derive(Debug, Clone, Copy)]
pub struct BaseLink {
    /// Its origin, m.
    pub t: V3<f64>,
    /// body ← base_link.
    pub m: UnitQuaternion<f64>,
}

impl BaseLink {
    /// `base_link` at `position_m` with axes `rpy_deg` (body ← base_link,
    /// Rz(yaw) Ry(pitch) Rx(roll)).
    pub fn new(position_m: [f64; 3], rpy_deg: [f64; 3]) -> Self {
        let [r, p, y] = rpy_deg.map(f64::to_radians);
        Self { t: V3::from(position_m), m: UnitQuaternion::from_euler_angles(r, p, y) }
    }
}

/// The IMU's last rate, body axes, and its covariance (row-major; zeros:
/// not given).
#[derive(Debug, Clone, Copy, Default)]
pub struct Rate {
    /// rad/s.
    pub radps: [f64; 3],
    /// (rad/s)².
    pub cov: [f64; 9],
}

fn skew(v: &V3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

fn vector(v: &V3<f64>) -> Vector3 {
    Vector3 { x: v.x, y: v.y, z: v.z }
}

fn quaternion(q: &UnitQuaternion<f64>) -> Quaternion {
    Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }
}

fn cov6(m: &SMatrix<f64, 6, 6>) -> [[f64; 6]; 6] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// The error state `[δp, δv, δθ, δb_g]` and the rate noise: 15 entries.
type Errors = SMatrix<f64, 15, 15>;

/// The estimate's covariance over [`Errors`] (its `δb_g` block where the model
/// has one), with the rate noise `Σ_g` last.
fn errors(s: &StateSnapshot, rate: &Rate, ins: bool) -> Errors {
    let n = s.cov_dim as usize;
    let at = |i: usize, j: usize| s.cov.get(i * n + j).copied().unwrap_or(0.0);
    // Rows of the snapshot's covariance: δp δv δθ then δb_g at 12.
    let rows: [Option<usize>; 12] = std::array::from_fn(|i| match i {
        0..6 => Some(i),
        6..9 if ins => Some(i),
        9..12 if ins => Some(i + 3),
        _ => None,
    });
    let mut e = Errors::zeros();
    for (i, ri) in rows.iter().enumerate() {
        for (j, rj) in rows.iter().enumerate() {
            if let (Some(a), Some(b)) = (ri, rj)
                && *a < n
                && *b < n
            {
                e[(i, j)] = at(*a, *b);
            }
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            e[(12 + i, 12 + j)] = rate.cov[i * 3 + j];
        }
    }
    e
}

/// The odometry and TF of `s`, stamped `stamp_ns` (ROS time), or `None` when
/// the snapshot has no estimate.
pub fn odometry(
    s: &StateSnapshot,
    base: &BaseLink,
    rate: &Rate,
    stamp_ns: u64,
    world_frame: &str,
    base_frame: &str,
) -> Option<(Odometry<Ros2Header>, TransformStamped)> {
    let p = V3::from(s.position()?);
    let v = V3::from(s.velocity()?);
    let attitude = s.attitude();
    let ins = attitude.is_some();
    let r = attitude.map_or(UnitQuaternion::identity(), |[w, x, y, z]| {
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    });
    let bg = V3::from(s.gyro_bias().unwrap_or([0.0; 3]));
    let omega = if ins { V3::from(rate.radps) - bg } else { V3::zeros() };
    let (rm, mt) = (*r.to_rotation_matrix().matrix(), base.m.to_rotation_matrix().matrix().transpose());
    let t = base.t;
    let v_body = rm.transpose() * v;
    let p_b = p + rm * t;
    let r_b = r * base.m;
    let v_b = mt * (v_body + omega.cross(&t));
    let w_b = mt * omega;

    // J: rows [δp_b, δθ_b, δv_b, δω_b], columns [δp, δv, δθ, δb_g, n_g].
    let mut j = SMatrix::<f64, 12, 15>::zeros();
    let i3 = Matrix3::identity();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&i3);
    j.fixed_view_mut::<3, 3>(0, 6).copy_from(&(-rm * skew(&t)));
    j.fixed_view_mut::<3, 3>(3, 6).copy_from(&rm);
    j.fixed_view_mut::<3, 3>(6, 3).copy_from(&(mt * rm.transpose()));
    j.fixed_view_mut::<3, 3>(6, 6).copy_from(&(mt * skew(&v_body)));
    j.fixed_view_mut::<3, 3>(6, 9).copy_from(&(mt * skew(&t)));
    j.fixed_view_mut::<3, 3>(6, 12).copy_from(&(-mt * skew(&t)));
    j.fixed_view_mut::<3, 3>(9, 9).copy_from(&(-mt));
    j.fixed_view_mut::<3, 3>(9, 12).copy_from(&mt);
    let c = j * errors(s, rate, ins) * j.transpose();
    let mut pose_cov: SMatrix<f64, 6, 6> = c.fixed_view::<6, 6>(0, 0).into();
    let mut twist_cov = SMatrix::<f64, 6, 6>::zeros();
    twist_cov.fixed_view_mut::<3, 3>(0, 0).copy_from(&c.fixed_view::<3, 3>(6, 6));
    twist_cov.fixed_view_mut::<3, 3>(3, 3).copy_from(&c.fixed_view::<3, 3>(9, 9));
    twist_cov.fixed_view_mut::<3, 3>(0, 3).copy_from(&c.fixed_view::<3, 3>(6, 9));
    twist_cov.fixed_view_mut::<3, 3>(3, 0).copy_from(&c.fixed_view::<3, 3>(9, 6));
    if !ins {
        for i in 3..6 {
            pose_cov[(i, i)] = UNKNOWN_VARIANCE;
            twist_cov[(i, i)] = UNKNOWN_VARIANCE;
        }
    }
    let header = Ros2Header::at(stamp_ns, world_frame);
    let odometry = Odometry {
        header: header.clone(),
        child_frame_id: base_frame.into(),
        pose: PoseWithCovariance {
            pose: Pose { position: vector(&p_b), orientation: quaternion(&r_b) },
            covariance: cov6(&pose_cov),
        },
        twist: TwistWithCovariance {
            twist: Twist { linear: vector(&v_b), angular: vector(&w_b) },
            covariance: cov6(&twist_cov),
        },
    };
    let tf = TransformStamped {
        header,
        child_frame_id: base_frame.into(),
        transform: Transform { translation: vector(&p_b), rotation: quaternion(&r_b) },
    };
    Some((odometry, tf))
}

#[cfg(test)]
mod tests;
