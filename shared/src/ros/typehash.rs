//! ROS 2 type descriptions and their hashes (REP-2011, `RIHS01`), computed
//! from the message definitions, as `rosidl_generator_type_description` does:
//!
//! 1. A type's description is its name and its fields in order, each field a
//!    name and a type (`type_id`, `capacity`, `string_capacity`,
//!    `nested_type_name`); default values and constants are not part of it.
//! 2. The hashed text is the JSON object `{"type_description": D,
//!    "referenced_type_descriptions": [R…]}`, where `R…` are the descriptions
//!    of every type `D` refers to, directly or not, sorted by name. It is
//!    written as Python's `json.dumps(…, separators=(", ", ": "))` writes it:
//!    keys in the order above, `", "` between items and `": "` after a key.
//! 3. The hash is `RIHS01_` and the lowercase hex SHA-256 of that text.
//!
//! The field type codes are `type_description_interfaces/msg/FieldType`'s:
//! a scalar's code, plus 48 for a fixed-size array (its size the capacity)
//! and 144 for an unbounded sequence.
//!
//! The definitions are ROS 2 Jazzy's (the same in Kilted and Rolling); Humble
//! has no type hashes.

use sha2::{Digest, Sha256};

/// A field's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldType {
    /// `int8`.
    Int8,
    /// `uint8`.
    UInt8,
    /// `byte`.
    Byte,
    /// `uint16`.
    UInt16,
    /// `int32`.
    Int32,
    /// `uint32`.
    UInt32,
    /// `float64`.
    Float64,
    /// `string` (unbounded).
    String,
    /// A message type, by its ROS 2 name (`std_msgs/msg/Header`).
    Nested(&'static str),
    /// `float64[N]`.
    Float64Array(u32),
    /// An unbounded sequence of a message type (`TransformStamped[]`).
    NestedSequence(&'static str),
}

impl FieldType {
    /// `(type_id, capacity, nested_type_name)` of
    /// `type_description_interfaces/msg/FieldType`.
    fn code(self) -> (u32, u32, &'static str) {
        const NESTED: u32 = 1;
        const ARRAY: u32 = 48;
        const UNBOUNDED_SEQUENCE: u32 = 144;
        const FLOAT64: u32 = 11;
        match self {
            FieldType::Int8 => (2, 0, ""),
            FieldType::UInt8 => (3, 0, ""),
            FieldType::UInt16 => (5, 0, ""),
            FieldType::Int32 => (6, 0, ""),
            FieldType::UInt32 => (7, 0, ""),
            FieldType::Float64 => (FLOAT64, 0, ""),
            FieldType::Byte => (16, 0, ""),
            FieldType::String => (17, 0, ""),
            FieldType::Nested(t) => (NESTED, 0, t),
            FieldType::Float64Array(n) => (FLOAT64 + ARRAY, n, ""),
            FieldType::NestedSequence(t) => (NESTED + UNBOUNDED_SEQUENCE, 0, t),
        }
    }

    fn nested(self) -> Option<&'static str> {
        match self {
            FieldType::Nested(t) | FieldType::NestedSequence(t) => Some(t),
            _ => None,
        }
    }
}

/// A message type's fields, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TypeDescription {
    /// ROS 2 name (`sensor_msgs/msg/Imu`).
    pub name: &'static str,
    /// Fields: name and type.
    pub fields: &'static [(&'static str, FieldType)],
}

use FieldType::{Float64, Nested};

const fn xyz() -> &'static [(&'static str, FieldType)] {
    &[("x", Float64), ("y", Float64), ("z", Float64)]
}

const HEADER: (&str, FieldType) = ("header", Nested("std_msgs/msg/Header"));

/// Every type fusiond reads or writes on ROS 2, and every type they refer to.
pub const TYPES: &[TypeDescription] = &[
    TypeDescription {
        name: "builtin_interfaces/msg/Time",
        fields: &[("sec", FieldType::Int32), ("nanosec", FieldType::UInt32)],
    },
    TypeDescription {
        name: "std_msgs/msg/Header",
        fields: &[("stamp", Nested("builtin_interfaces/msg/Time")), ("frame_id", FieldType::String)],
    },
    TypeDescription { name: "rosgraph_msgs/msg/Clock", fields: &[("clock", Nested("builtin_interfaces/msg/Time"))] },
    TypeDescription { name: "geometry_msgs/msg/Vector3", fields: xyz() },
    TypeDescription { name: "geometry_msgs/msg/Point", fields: xyz() },
    TypeDescription {
        name: "geometry_msgs/msg/Quaternion",
        fields: &[("x", Float64), ("y", Float64), ("z", Float64), ("w", Float64)],
    },
    TypeDescription {
        name: "geometry_msgs/msg/Pose",
        fields: &[
            ("position", Nested("geometry_msgs/msg/Point")),
            ("orientation", Nested("geometry_msgs/msg/Quaternion")),
        ],
    },
    TypeDescription {
        name: "geometry_msgs/msg/PoseWithCovariance",
        fields: &[("pose", Nested("geometry_msgs/msg/Pose")), ("covariance", FieldType::Float64Array(36))],
    },
    TypeDescription {
        name: "geometry_msgs/msg/PoseWithCovarianceStamped",
        fields: &[HEADER, ("pose", Nested("geometry_msgs/msg/PoseWithCovariance"))],
    },
    TypeDescription {
        name: "geometry_msgs/msg/Twist",
        fields: &[("linear", Nested("geometry_msgs/msg/Vector3")), ("angular", Nested("geometry_msgs/msg/Vector3"))],
    },
    TypeDescription {
        name: "geometry_msgs/msg/TwistWithCovariance",
        fields: &[("twist", Nested("geometry_msgs/msg/Twist")), ("covariance", FieldType::Float64Array(36))],
    },
    TypeDescription {
        name: "geometry_msgs/msg/TwistWithCovarianceStamped",
        fields: &[HEADER, ("twist", Nested("geometry_msgs/msg/TwistWithCovariance"))],
    },
    TypeDescription {
        name: "geometry_msgs/msg/Transform",
        fields: &[
            ("translation", Nested("geometry_msgs/msg/Vector3")),
            ("rotation", Nested("geometry_msgs/msg/Quaternion")),
        ],
    },
    TypeDescription {
        name: "geometry_msgs/msg/TransformStamped",
        fields: &[HEADER, ("child_frame_id", FieldType::String), ("transform", Nested("geometry_msgs/msg/Transform"))],
    },
    TypeDescription {
        name: "tf2_msgs/msg/TFMessage",
        fields: &[("transforms", FieldType::NestedSequence("geometry_msgs/msg/TransformStamped"))],
    },
    TypeDescription {
        name: "nav_msgs/msg/Odometry",
        fields: &[
            HEADER,
            ("child_frame_id", FieldType::String),
            ("pose", Nested("geometry_msgs/msg/PoseWithCovariance")),
            ("twist", Nested("geometry_msgs/msg/TwistWithCovariance")),
        ],
    },
    TypeDescription {
        name: "sensor_msgs/msg/Imu",
        fields: &[
            HEADER,
            ("orientation", Nested("geometry_msgs/msg/Quaternion")),
            ("orientation_covariance", FieldType::Float64Array(9)),
            ("angular_velocity", Nested("geometry_msgs/msg/Vector3")),
            ("angular_velocity_covariance", FieldType::Float64Array(9)),
            ("linear_acceleration", Nested("geometry_msgs/msg/Vector3")),
            ("linear_acceleration_covariance", FieldType::Float64Array(9)),
        ],
    },
    TypeDescription {
        name: "sensor_msgs/msg/MagneticField",
        fields: &[
            HEADER,
            ("magnetic_field", Nested("geometry_msgs/msg/Vector3")),
            ("magnetic_field_covariance", FieldType::Float64Array(9)),
        ],
    },
    TypeDescription {
        name: "sensor_msgs/msg/FluidPressure",
        fields: &[HEADER, ("fluid_pressure", Float64), ("variance", Float64)],
    },
    TypeDescription {
        name: "sensor_msgs/msg/NavSatStatus",
        fields: &[("status", FieldType::Int8), ("service", FieldType::UInt16)],
    },
    TypeDescription {
        name: "sensor_msgs/msg/NavSatFix",
        fields: &[
            HEADER,
            ("status", Nested("sensor_msgs/msg/NavSatStatus")),
            ("latitude", Float64),
            ("longitude", Float64),
            ("altitude", Float64),
            ("position_covariance", FieldType::Float64Array(9)),
            ("position_covariance_type", FieldType::UInt8),
        ],
    },
    TypeDescription {
        name: "diagnostic_msgs/msg/KeyValue",
        fields: &[("key", FieldType::String), ("value", FieldType::String)],
    },
    TypeDescription {
        name: "diagnostic_msgs/msg/DiagnosticStatus",
        fields: &[
            ("level", FieldType::Byte),
            ("name", FieldType::String),
            ("message", FieldType::String),
            ("hardware_id", FieldType::String),
            ("values", FieldType::NestedSequence("diagnostic_msgs/msg/KeyValue")),
        ],
    },
    TypeDescription {
        name: "diagnostic_msgs/msg/DiagnosticArray",
        fields: &[HEADER, ("status", FieldType::NestedSequence("diagnostic_msgs/msg/DiagnosticStatus"))],
    },
];

/// The description of the type named `name` (ROS 2 spelling).
pub fn description(name: &str) -> Option<&'static TypeDescription> {
    TYPES.iter().find(|t| t.name == name)
}

fn write_description(out: &mut String, t: &TypeDescription) {
    out.push_str(&format!("{{\"type_name\": \"{}\", \"fields\": [", t.name));
    for (i, (name, ty)) in t.fields.iter().enumerate() {
        let (id, capacity, nested) = ty.code();
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str(&format!(
            "{{\"name\": \"{name}\", \"type\": {{\"type_id\": {id}, \"capacity\": {capacity}, \
             \"string_capacity\": 0, \"nested_type_name\": \"{nested}\"}}}}"
        ));
    }
    out.push_str("]}");
}

/// The text REP-2011 hashes for the type named `name`: its description and
/// those of the types it refers to (see the module's documentation). `None`
/// for a type (or a referred type) not in [`TYPES`].
pub fn hashed_text(name: &str) -> Option<String> {
    let root = description(name)?;
    let mut referenced: Vec<&TypeDescription> = Vec::new();
    let mut todo: Vec<&str> = root.fields.iter().filter_map(|(_, t)| t.nested()).collect();
    while let Some(n) = todo.pop() {
        if referenced.iter().any(|r| r.name == n) {
            continue;
        }
        let t = description(n)?;
        todo.extend(t.fields.iter().filter_map(|(_, t)| t.nested()));
        referenced.push(t);
    }
    referenced.sort_by_key(|t| t.name);
    let mut out = String::from("{\"type_description\": ");
    write_description(&mut out, root);
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, t) in referenced.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_description(&mut out, t);
    }
    out.push_str("]}");
    Some(out)
}

/// The REP-2011 hash of the type named `name` (`RIHS01_` and 64 hex digits).
pub fn type_hash(name: &str) -> Option<String> {
    let digest = Sha256::digest(hashed_text(name)?.as_bytes());
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    Some(format!("RIHS01_{hex}"))
}

/// The DDS name of a ROS 2 type: `sensor_msgs/msg/Imu` is
/// `sensor_msgs::msg::dds_::Imu_`. `None` for a name not of that form.
pub fn dds_type_name(name: &str) -> Option<String> {
    let mut parts = name.split('/');
    let (Some(package), Some("msg"), Some(ty), None) = (parts.next(), parts.next(), parts.next(), parts.next()) else {
        return None;
    };
    Some(format!("{package}::msg::dds_::{ty}_"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hashes ROS 2 Jazzy publishes for these types (its generated
    /// `*.json` type descriptions, and `ros2 topic info --verbose`).
    #[test]
    fn computed_hashes_are_the_published_ones() {
        for (name, published) in [
            ("sensor_msgs/msg/Imu", "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b"),
            ("nav_msgs/msg/Odometry", "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"),
            ("tf2_msgs/msg/TFMessage", "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"),
            (
                "sensor_msgs/msg/MagneticField",
                "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff",
            ),
            (
                "sensor_msgs/msg/FluidPressure",
                "RIHS01_22dfb2b145a0bd5a31a1ac3882a1b32148b51d9b2f3bab250290d66f3595bc32",
            ),
        ] {
            assert_eq!(type_hash(name).as_deref(), Some(published), "{name}");
        }
    }

    /// Further types, computed the same way (no published value was found to
    /// compare them with): a change of a definition shows here.
    #[test]
    fn further_hashes_are_stable() {
        for (name, hash) in [
            (
                "diagnostic_msgs/msg/DiagnosticArray",
                "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e",
            ),
            (
                "geometry_msgs/msg/TwistWithCovarianceStamped",
                "RIHS01_77b67434531e6529b7a0091357b186b6ebdb17fd9ffd3e0c7ce9d3fb11a44563",
            ),
            (
                "geometry_msgs/msg/PoseWithCovarianceStamped",
                "RIHS01_26432f9803e43727d3c8f668d1fdb3c630f548af631e2f4e31382371bfea3b6e",
            ),
            ("sensor_msgs/msg/NavSatFix", "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404"),
        ] {
            assert_eq!(type_hash(name).as_deref(), Some(hash), "{name}");
        }
    }

    #[test]
    fn every_referred_type_is_described() {
        for t in TYPES {
            assert!(type_hash(t.name).is_some(), "{}", t.name);
        }
        assert_eq!(type_hash("sensor_msgs/msg/Image"), None);
    }

    #[test]
    fn dds_names() {
        assert_eq!(dds_type_name("sensor_msgs/msg/Imu").as_deref(), Some("sensor_msgs::msg::dds_::Imu_"));
        assert_eq!(dds_type_name("sensor_msgs/Imu"), None);
    }
}
