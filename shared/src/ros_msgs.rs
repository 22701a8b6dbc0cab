//! The ROS messages a bag's or a live topic's messages are read as (REP-103
//! axes, REP-105 frames, REP-145 covariances), and how a kind is read from
//! them: each kind declares it beside its wire type ([`FromRos`]), with the
//! helpers here; `ros::messages` dispatches a message to the kinds.
//!
//! One set of types serves both encodings: ROS 1's serialisation (read by
//! `serde_rosmsg`) and ROS 2's CDR (read by `cdr`); only the header differs
//! (ROS 1 has a sequence number and unsigned seconds).

use serde::{Deserialize, Serialize};

/// A ROS 1 `std_msgs/Header`.
#[derive(Debug, Deserialize)]
pub struct Ros1Header {
    /// Sequence number (not used: fusiond numbers each topic's samples).
    pub seq: u32,
    /// Seconds.
    pub sec: u32,
    /// Nanoseconds.
    pub nsec: u32,
    /// Frame.
    pub frame_id: String,
}

/// A ROS 2 `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct Ros2Header {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
    /// Frame.
    pub frame_id: String,
}

/// A header's stamp: the time of validity of its message.
pub trait Stamp {
    /// The stamp in ns, or why it is none.
    fn t_ns(&self) -> Result<u64, String>;
}

fn stamp(sec: i64, nsec: u32) -> Result<u64, String> {
    if sec < 0 || nsec >= 1_000_000_000 {
        return Err(format!("header stamp {sec} s {nsec} ns is not a time"));
    }
    Ok(sec as u64 * 1_000_000_000 + u64::from(nsec))
}

impl Stamp for Ros1Header {
    fn t_ns(&self) -> Result<u64, String> {
        stamp(i64::from(self.sec), self.nsec)
    }
}

impl Stamp for Ros2Header {
    fn t_ns(&self) -> Result<u64, String> {
        stamp(i64::from(self.sec), self.nanosec)
    }
}

/// `geometry_msgs/Vector3` (and `Point`).
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Serialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vector3 {
    pub(crate) fn array(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Serialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    pub(crate) fn wxyz(&self) -> [f64; 4] {
        [self.w, self.x, self.y, self.z]
    }

    /// The rotation matrix, row-major (normalised).
    pub(crate) fn matrix(&self) -> [[f64; 3]; 3] {
        let n = (self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z).sqrt();
        let (w, x, y, z) = (self.w / n, self.x / n, self.y / n, self.z / n);
        [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
            [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
            [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
        ]
    }
}

/// A row-major 6×6 covariance (a fixed array: no length on the wire).
pub type Cov6 = [[f64; 6]; 6];

/// `sensor_msgs/Imu`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct Imu<H> {
    /// Header.
    pub header: H,
    /// Orientation of the sensor's axes in the world frame.
    pub orientation: Quaternion,
    /// Its covariance (about the world's axes); element 0 = −1: not given.
    pub orientation_covariance: [f64; 9],
    /// Angular rate, rad/s.
    pub angular_velocity: Vector3,
    /// Its covariance; element 0 = −1: not given.
    pub angular_velocity_covariance: [f64; 9],
    /// Specific force, m/s².
    pub linear_acceleration: Vector3,
    /// Its covariance; element 0 = −1: not given.
    pub linear_acceleration_covariance: [f64; 9],
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Deserialize, Serialize, Clone)]
pub struct Pose {
    /// Position.
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Debug, Deserialize, Serialize, Clone)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// `[x, y, z, rot x, rot y, rot z]`, the rotation about the fixed axes.
    pub covariance: Cov6,
}

/// `geometry_msgs/Twist`.
#[derive(Debug, Deserialize, Serialize, Clone)]
pub struct Twist {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Debug, Deserialize, Serialize, Clone)]
pub struct TwistWithCovariance {
    /// Twist.
    pub twist: Twist,
    /// Linear then angular.
    pub covariance: Cov6,
}

/// `nav_msgs/Odometry`.
#[derive(Debug, Deserialize, Serialize, Clone)]
pub struct Odometry<H> {
    /// Header (the pose's frame).
    pub header: H,
    /// The twist's frame (the robot's `base_link`).
    pub child_frame_id: String,
    /// Pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Twist in `child_frame_id`.
    pub twist: TwistWithCovariance,
}

/// `sensor_msgs/NavSatStatus`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct NavSatStatus {
    /// −1 no fix, 0 fix, 1 SBAS, 2 GBAS.
    pub status: i8,
    /// Constellations.
    pub service: u16,
}

/// `sensor_msgs/NavSatFix`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct NavSatFix<H> {
    /// Header.
    pub header: H,
    /// Fix status.
    pub status: NavSatStatus,
    /// Degrees.
    pub latitude: f64,
    /// Degrees.
    pub longitude: f64,
    /// Metres above the WGS-84 ellipsoid.
    pub altitude: f64,
    /// ENU, m², row-major.
    pub position_covariance: [f64; 9],
    /// 0 unknown, 1 approximated, 2 diagonal known, 3 known.
    pub position_covariance_type: u8,
}

/// `geometry_msgs/TwistWithCovarianceStamped`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct TwistWithCovarianceStamped<H> {
    /// Header (the twist's frame).
    pub header: H,
    /// Twist.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/PoseWithCovarianceStamped`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct PoseWithCovarianceStamped<H> {
    /// Header (the map frame).
    pub header: H,
    /// Pose.
    pub pose: PoseWithCovariance,
}

/// `sensor_msgs/FluidPressure`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct FluidPressure<H> {
    /// Header.
    pub header: H,
    /// Pa.
    pub fluid_pressure: f64,
    /// Pa²; 0: unknown.
    pub variance: f64,
}

/// `sensor_msgs/MagneticField`.
#[derive(Debug, Deserialize, Clone, Serialize)]
pub struct MagneticField<H> {
    /// Header.
    pub header: H,
    /// Tesla, sensor axes.
    pub magnetic_field: Vector3,
    /// T², row-major; all zero: unknown.
    pub magnetic_field_covariance: [f64; 9],
}

/// A message type fusiond reads, by its ROS name (`sensor_msgs/Imu`; ROS 2's
/// `sensor_msgs/msg/Imu` is the same).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageType {
    /// `sensor_msgs/Imu`.
    Imu,
    /// `nav_msgs/Odometry`.
    Odometry,
    /// `sensor_msgs/NavSatFix`.
    NavSatFix,
    /// `geometry_msgs/TwistWithCovarianceStamped`.
    TwistWithCovarianceStamped,
    /// `geometry_msgs/PoseWithCovarianceStamped`.
    PoseWithCovarianceStamped,
    /// `sensor_msgs/FluidPressure`.
    FluidPressure,
    /// `sensor_msgs/MagneticField`.
    MagneticField,
}

impl MessageType {
    /// Every type read, with its ROS name.
    pub const ALL: [(MessageType, &'static str); 7] = [
        (MessageType::Imu, "sensor_msgs/Imu"),
        (MessageType::Odometry, "nav_msgs/Odometry"),
        (MessageType::NavSatFix, "sensor_msgs/NavSatFix"),
        (MessageType::TwistWithCovarianceStamped, "geometry_msgs/TwistWithCovarianceStamped"),
        (MessageType::PoseWithCovarianceStamped, "geometry_msgs/PoseWithCovarianceStamped"),
        (MessageType::FluidPressure, "sensor_msgs/FluidPressure"),
        (MessageType::MagneticField, "sensor_msgs/MagneticField"),
    ];

    /// The type of a ROS name (ROS 1 or ROS 2 spelling).
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.replacen("/msg/", "/", 1);
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(t, _)| *t)
    }
}

/// `−1` in a covariance's first element: the value is not given (REP-145 for
/// `sensor_msgs/Imu`).
pub(crate) fn not_given(cov: &[f64]) -> bool {
    cov[0] == -1.0
}

/// A covariance with nothing in it: unknown (REP-145).
pub(crate) fn unknown(cov: &[f64]) -> bool {
    cov.iter().all(|v| *v == 0.0)
}

pub(crate) fn flat6(c: &Cov6) -> [f64; 36] {
    let mut out = [0.0; 36];
    for (r, row) in c.iter().enumerate() {
        out[r * 6..r * 6 + 6].copy_from_slice(row);
    }
    out
}

/// `Mᵀ Σ M` of a 3×3 block: a covariance about the world's axes taken to the
/// axes of the rotation `M` (world ← sensor).
pub(crate) fn to_sensor_axes(m: &[[f64; 3]; 3], cov: &[f64; 9]) -> [f64; 9] {
    let mut out = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            out[i * 3 + j] =
                (0..3).flat_map(|a| (0..3).map(move |b| (a, b))).map(|(a, b)| m[a][i] * cov[a * 3 + b] * m[b][j]).sum();
        }
    }
    out
}

/// A pose's 6×6 covariance with its rotation block (about the fixed axes in
/// ROS) taken to the sensor's axes, the cross blocks with it.
pub(crate) fn pose_cov(p: &PoseWithCovariance) -> [f64; 36] {
    let m = p.pose.orientation.matrix();
    let c = flat6(&p.covariance);
    let mut out = c;
    // [Σ_pp, Σ_pθ M; Mᵀ Σ_θp, Mᵀ Σ_θθ M]
    for i in 0..6 {
        for j in 0..6 {
            let (ri, rj) = (i >= 3, j >= 3);
            out[i * 6 + j] = match (ri, rj) {
                (false, false) => c[i * 6 + j],
                (false, true) => (0..3).map(|b| c[i * 6 + 3 + b] * m[b][j - 3]).sum(),
                (true, false) => (0..3).map(|a| m[a][i - 3] * c[(3 + a) * 6 + j]).sum(),
                (true, true) => (0..3)
                    .flat_map(|a| (0..3).map(move |b| (a, b)))
                    .map(|(a, b)| m[a][i - 3] * c[(3 + a) * 6 + 3 + b] * m[b][j - 3])
                    .sum(),
            };
        }
    }
    out
}

/// A message decoded, by reference: what a kind's [`FromRos`] reads.
#[derive(Debug, Clone, Copy)]
pub enum Message<'a, H> {
    /// `sensor_msgs/Imu`.
    Imu(&'a Imu<H>),
    /// `nav_msgs/Odometry`.
    Odometry(&'a Odometry<H>),
    /// `sensor_msgs/NavSatFix`.
    NavSatFix(&'a NavSatFix<H>),
    /// `geometry_msgs/TwistWithCovarianceStamped`.
    TwistWithCovarianceStamped(&'a TwistWithCovarianceStamped<H>),
    /// `geometry_msgs/PoseWithCovarianceStamped`.
    PoseWithCovarianceStamped(&'a PoseWithCovarianceStamped<H>),
    /// `sensor_msgs/FluidPressure`.
    FluidPressure(&'a FluidPressure<H>),
    /// `sensor_msgs/MagneticField`.
    MagneticField(&'a MagneticField<H>),
}

impl<H: Stamp> Message<'_, H> {
    /// The message's stamp, ns.
    pub fn t_ns(&self) -> Result<u64, String> {
        match self {
            Message::Imu(m) => m.header.t_ns(),
            Message::Odometry(m) => m.header.t_ns(),
            Message::NavSatFix(m) => m.header.t_ns(),
            Message::TwistWithCovarianceStamped(m) => m.header.t_ns(),
            Message::PoseWithCovarianceStamped(m) => m.header.t_ns(),
            Message::FluidPressure(m) => m.header.t_ns(),
            Message::MagneticField(m) => m.header.t_ns(),
        }
    }

    /// The twist a message holds (an odometry's, a twist's), if it holds one.
    pub fn twist(&self) -> Option<&TwistWithCovariance> {
        match self {
            Message::Odometry(m) => Some(&m.twist),
            Message::TwistWithCovarianceStamped(m) => Some(&m.twist),
            _ => None,
        }
    }

    /// The pose a message holds (an odometry's, a pose's), if it holds one.
    pub fn pose(&self) -> Option<&PoseWithCovariance> {
        match self {
            Message::Odometry(m) => Some(&m.pose),
            Message::PoseWithCovarianceStamped(m) => Some(&m.pose),
            _ => None,
        }
    }
}

/// How a sample kind is read from ROS messages: each kind declares it beside
/// its wire type (`shared/src/sample/<kind>.rs`), and the readers of bags and
/// live topics take it from there. A kind that declares nothing is not read
/// from ROS (its `MESSAGES` are none).
pub trait FromRos: Sized {
    /// The message types a sample of this kind is read from.
    const MESSAGES: &'static [MessageType] = &[];

    /// The sample of this kind in `message` (of one of [`MESSAGES`](Self::MESSAGES)),
    /// numbered `seq` of sensor `sensor`, or why it gives none.
    fn from_ros<H: Stamp>(_message: Message<'_, H>, _sensor: u32, _seq: u64) -> Result<Self, String> {
        Err("this kind is not read from ROS messages".into())
    }
}

/// Why a message gives no sample of a kind that does not read its type (a
/// kind's [`FromRos::from_ros`] says it of a message it does not take).
pub fn not_read(kind: &str) -> String {
    format!("a message of this type gives no {kind} sample")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros1_and_ros2_names_are_one_type() {
        assert_eq!(MessageType::from_name("sensor_msgs/Imu"), Some(MessageType::Imu));
        assert_eq!(MessageType::from_name("sensor_msgs/msg/Imu"), Some(MessageType::Imu));
        assert_eq!(MessageType::from_name("nav_msgs/msg/Odometry"), Some(MessageType::Odometry));
        assert_eq!(MessageType::from_name("sensor_msgs/Image"), None);
    }

    /// A rotation's covariance about the world's axes, taken to the sensor's:
    /// a sensor yawed 90° sees the world's x variance on its y axis.
    #[test]
    fn covariances_turn_into_the_sensors_axes() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = Quaternion { x: 0.0, y: 0.0, z: h, w: h };
        let cov = to_sensor_axes(&q.matrix(), &[1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0]);
        let expected = [2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 3.0];
        assert!(cov.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12), "{cov:?}");
    }
}
