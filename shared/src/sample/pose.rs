//! Pose: the position and attitude a localiser (lidar SLAM, visual-inertial
//! odometry, a map matcher) gives in a map frame of its own.

pub mod progress;

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The pose of the sensor's frame in the localiser's map frame (a ROS
/// `PoseWithCovariance`): its origin's position and the rotation of its axes
/// into the map's, with their 6×6 covariance. The map frame's `z` is up; its
/// yaw and origin in the world are configuration or estimated
/// (`[sensor.pose]`). The sensor's mounting on the body is configuration
/// (`[[sensor]] axes`, `rotation_rpy_deg`, `lever_arm_m`).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "PoseLine", into = "PoseLine"))]
#[type_name("fusion.PoseSample.v1")]
#[repr(C)]
pub struct PoseSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Pose`].
    pub header: SampleHeader,
    /// Position of the sensor's origin in the map frame, m; |p| ≤ 10⁷ m.
    pub position_m: [f64; 3],
    /// Rotation of the sensor's axes into the map frame, `[w, x, y, z]`; unit
    /// norm (within 10⁻³).
    pub orientation_wxyz: [f64; 4],
    /// Covariance of `[position, attitude]`, row-major 6×6 (m², m·rad, rad²):
    /// the attitude error is a small rotation about the sensor's own axes
    /// (`q_true = q ⊗ Exp(δθ)`); symmetric positive definite.
    pub cov: [f64; 36],
    /// The localiser's re-initialisation counter: it changes when the map
    /// frame jumps (a relocalisation, a new map), and fusiond sets the frame
    /// anew instead of fighting the jump.
    pub reset_counter: u32,
    /// Zero.
    pub reserved: u32,
}

impl PoseSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 6;

    /// The map frame of a pose sensor whose frame is estimated (one such
    /// sensor): its yaw `ψ` in the world frame, rad, and its origin's east,
    /// north and up components, m.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind {
        what: "pose map frame",
        len: 4,
        states: &[
            (4, "pose_frame_yaw_rad"),
            (8, "pose_frame_east_m"),
            (16, "pose_frame_north_m"),
            (32, "pose_frame_up_m"),
        ],
    };

    /// A pose of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(
        t_ns: u64,
        sensor: u32,
        seq: u64,
        position_m: [f64; 3],
        orientation_wxyz: [f64; 4],
        cov: [f64; 36],
        reset_counter: u32,
    ) -> Self {
        Self {
            header: SampleHeader::new(SampleKind::Pose, t_ns, sensor, seq),
            position_m,
            orientation_wxyz,
            cov,
            reset_counter,
            reserved: 0,
        }
    }
}

impl Default for PoseSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [1.0, 0.0, 0.0, 0.0], [0.0; 36], 0)
    }
}

#[cfg(feature = "json")]
super::json_form!(PoseSample, PoseLine {
    /// m, map frame.
    position: [f64; 3] => position_m,
    /// `[w, x, y, z]`, sensor axes into the map frame.
    orientation: [f64; 4] => orientation_wxyz,
    /// row-major 6×6, position then attitude.
    #[serde(with = "super::twist::matrix6")]
    #[schemars(with = "Vec<f64>", length(equal = 36))]
    cov: [f64; 36] => cov,
    /// The localiser's re-initialisation counter.
    #[serde(default)]
    reset_counter: u32 => reset_counter,
    /// Zero.
    #[serde(default, skip_serializing_if = "is_zero")]
    reserved: u32 => reserved,
});

#[cfg(feature = "json")]
fn is_zero(v: &u32) -> bool {
    *v == 0
}

const _: () = {
    assert!(core::mem::size_of::<PoseSample>() == 384);
    assert!(core::mem::align_of::<PoseSample>() == 8);
};

#[cfg(all(test, feature = "json"))]
mod tests {
    use super::*;
    use crate::Sample;
    use crate::jsonl::{format_sample, parse_sample};

    #[test]
    fn json_lines_carry_the_pose_and_its_counter() {
        let cov = crate::sample::TwistSample::diagonal_cov([0.1; 3], [0.01; 3]);
        let s = Sample::Pose(PoseSample::new(5, 3, 9, [1.0, 2.0, 0.5], [0.6, 0.0, 0.0, 0.8], cov, 2));
        let line = format_sample(&s);
        assert!(line.starts_with("{\"pose\":{\"t_ns\":5,\"sensor\":3,\"seq\":9,\"position\":[1.0,2.0,0.5]"), "{line}");
        assert!(line.contains("\"reset_counter\":2") && !line.contains("reserved"), "{line}");
        assert_eq!(parse_sample(&line).unwrap(), s);
    }
}

/// A pose sensor keeps where its estimated map frame stands, and a relative
/// one its last pose ([`progress`]).
impl crate::sample::KindProgress for PoseSample {
    type Progress = progress::PoseProgress;
}

crate::wire_layout!(PoseSample, "A localiser's pose in its map frame: position (m), unit quaternion `[w, x, y, z]` of the sensor's axes into the map, covariance (row-major 6×6, position then attitude about the sensor's axes) and the localiser's reset counter.", { header, position_m, orientation_wxyz, cov, reset_counter, reserved });

/// The pose, an odometry's or a stamped one, its rotation covariance taken to the sensor's axes.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for PoseSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] =
        &[crate::ros_msgs::MessageType::Odometry, crate::ros_msgs::MessageType::PoseWithCovarianceStamped];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs as ros;
        let Some(pose) = m.pose() else { return Err(ros::not_read("pose")) };
        let t = m.t_ns()?;
        let p = &pose.pose;
        Ok(PoseSample::new(t, sensor, seq, p.position.array(), p.orientation.wxyz(), ros::pose_cov(pose), 0))
    }
}
