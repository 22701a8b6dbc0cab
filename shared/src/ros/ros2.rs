//! The ROS 2 messages fusiond writes (`nav_msgs/msg/Odometry`,
//! `tf2_msgs/msg/TFMessage`, `diagnostic_msgs/msg/DiagnosticArray`), the sim
//! clock it reads (`rosgraph_msgs/msg/Clock`), and their CDR: XCDR1, little
//! endian, after the 4-byte encapsulation header `00 01 00 00`, as every
//! ROS 2 middleware writes it (rmw_cyclonedds allows only XCDR1; rmw_fastrtps
//! and rmw_zenoh write it).

use serde::{Deserialize, Serialize};

use super::messages::{Quaternion, Ros2Header, Vector3};

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Transform {
    /// The child frame's origin in the parent frame, m.
    pub translation: Vector3,
    /// The child frame's axes in the parent frame.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Ros2Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Child in parent.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage` (what `/tf` carries).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct KeyValue {
    /// Name.
    pub key: String,
    /// Value, as text.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus` levels.
pub mod level {
    /// OK.
    pub const OK: u8 = 0;
    /// WARN.
    pub const WARN: u8 = 1;
    /// ERROR.
    pub const ERROR: u8 = 2;
    /// STALE.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DiagnosticStatus {
    /// One of [`level`].
    pub level: u8,
    /// What is reported on (`fusiond: imu0`).
    pub name: String,
    /// Its state in words.
    pub message: String,
    /// The hardware's name.
    pub hardware_id: String,
    /// Counters and values.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/msg/DiagnosticArray` (what `/diagnostics` carries).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Ros2Header,
    /// One status per thing reported on.
    pub status: Vec<DiagnosticStatus>,
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
}

/// `rosgraph_msgs/msg/Clock` (what `/clock` carries under sim time).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Clock {
    /// The sim time.
    pub clock: Time,
}

impl Time {
    /// ns since the epoch (sim or wall), or `None` before it.
    pub fn ns(&self) -> Option<u64> {
        let sec = u64::try_from(self.sec).ok()?;
        (self.nanosec < 1_000_000_000).then(|| sec * 1_000_000_000 + u64::from(self.nanosec))
    }

    /// The time of `ns` (saturating at `i32::MAX` s, in 2038).
    pub fn of_ns(ns: u64) -> Self {
        let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
        Self { sec, nanosec: (ns % 1_000_000_000) as u32 }
    }
}

impl Ros2Header {
    /// A header stamped `ns` (ROS time) in `frame_id`.
    pub fn at(ns: u64, frame_id: &str) -> Self {
        let t = Time::of_ns(ns);
        Self { sec: t.sec, nanosec: t.nanosec, frame_id: frame_id.into() }
    }
}

/// The CDR encapsulation header of little-endian plain CDR (XCDR1).
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// A message in CDR, as ROS 2 sends it: [`CDR_LE`], then the message,
/// aligned from there.
pub fn to_cdr<T: Serialize>(message: &T) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    // Serialising fusiond's own message types cannot fail: no map, no
    // unsized sequence of unknown length.
    let body = cdr_encoding::to_vec::<T, byteorder::LittleEndian>(message).expect("a ROS message serialises");
    out.extend_from_slice(&body);
    out
}

/// A CDR message of type `T` (either byte order), with the checks of a bag's
/// messages: see [`super::decode_cdr`].
pub fn from_cdr<T: serde::de::DeserializeOwned>(data: &[u8]) -> Result<T, String> {
    super::decode_cdr(data)
}
