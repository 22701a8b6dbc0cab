//! rmw_zenoh's wire conventions (ros2/rmw_zenoh: `docs/design.md`,
//! `liveliness_utils.cpp`, `attachment_helpers.cpp`, `qos.cpp`), so that
//! fusion-ros is one more node to every ROS 2 node on a robot that runs
//! `RMW_IMPLEMENTATION=rmw_zenoh_cpp`:
//!
//! - **Data** of a topic goes on the key `<domain>/<topic>/<DDS type>/<type
//!   hash>`, the topic without its leading slash
//!   (`0/odometry/filtered/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc9…`).
//!   The payload is the message's CDR with its encapsulation header.
//! - **Every publication carries an attachment**: its sequence number and
//!   source time (i64 each, little endian) and the publisher's 16-byte GID
//!   after its length (`0x10`), as Zenoh's serializer writes them: 33 bytes.
//!   A ROS subscriber drops a sample without one. This is the format of Jazzy
//!   from rmw_zenoh 0.2.4, Kilted from 0.6.0, and Rolling; Jazzy's 0.2.3 and
//!   older labelled each field by name, and Humble's rmw_zenoh has no type
//!   hashes: neither is supported.
//! - **The graph is liveliness tokens**:
//!   `@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/<namespace>/<node name>`
//!   and, for a publisher or subscription, `/<topic>/<DDS type>/<type hash>/<QoS>`.
//!   A `/` inside a field is written `%` (so the topic keeps its leading
//!   slash, as `%imu%data`); a node's own token has its id twice. A QoS field
//!   is written only where it differs from rmw_zenoh's default (reliable,
//!   volatile, keep-last 42, infinite durations, automatic liveliness).
//! - **An entity's GID** is the XXH3-128 hash of its token: its low 64 bits
//!   then its high 64 bits, each little endian.

use fusion_shared::ros::typehash;

/// The key space of the liveliness tokens.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// rmw_zenoh's default history depth: a token's depth is written only when
/// it differs.
pub const DEFAULT_DEPTH: u32 = 42;

/// A field with `/` in it, as a token writes it (`/imu/data` is `%imu%data`).
pub fn mangle(field: &str) -> String {
    field.replace('/', "%")
}

/// An endpoint's QoS, as far as a token tells it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (`true`) or best effort.
    pub reliable: bool,
    /// Transient local (`true`) or volatile.
    pub transient_local: bool,
    /// Keep-last depth.
    pub depth: u32,
}

impl Qos {
    /// rclcpp's default (`rclcpp::QoS(10)`): reliable, volatile, depth 10.
    pub const DEFAULT: Qos = Qos { reliable: true, transient_local: false, depth: 10 };
    /// `rclcpp::SensorDataQoS`: best effort, volatile, depth 5 (a
    /// subscription of it matches reliable and best-effort publishers).
    pub const SENSOR_DATA: Qos = Qos { reliable: false, transient_local: false, depth: 5 };
    /// tf2's broadcaster on `/tf`: reliable, volatile, depth 100.
    pub const TF: Qos = Qos { reliable: true, transient_local: false, depth: 100 };

    /// The token's QoS field: `<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,<ns>:<liveliness>,<lease s>,<ns>`,
    /// each number only where it differs from rmw_zenoh's default (the
    /// `rmw_qos_*_policy_e` values: reliable 1, best effort 2; transient
    /// local 1, volatile 2).
    pub fn keyexpr(&self) -> String {
        let reliability = if self.reliable { String::new() } else { "2".into() };
        let durability = if self.transient_local { "1".to_string() } else { String::new() };
        let depth = if self.depth == DEFAULT_DEPTH { String::new() } else { self.depth.to_string() };
        format!("{reliability}:{durability}:,{depth}:,:,:,,")
    }
}

/// What a token names: a node, or a node's publisher or subscription.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityKind {
    /// `NN`.
    Node,
    /// `MP`.
    Publisher,
    /// `MS`.
    Subscription,
}

impl EntityKind {
    fn code(self) -> &'static str {
        match self {
            EntityKind::Node => "NN",
            EntityKind::Publisher => "MP",
            EntityKind::Subscription => "MS",
        }
    }
}

/// A topic's type as rmw_zenoh names it: the DDS type name and the REP-2011
/// hash of the ROS type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicType {
    /// The ROS 2 name (`sensor_msgs/msg/Imu`).
    pub ros: &'static str,
    /// The DDS name (`sensor_msgs::msg::dds_::Imu_`).
    pub dds: String,
    /// `RIHS01_…`.
    pub hash: String,
}

impl TopicType {
    /// The type named `ros` (ROS 2 spelling), if fusiond knows it.
    pub fn of(ros: &str) -> Option<Self> {
        let d = typehash::description(ros)?;
        Some(Self { ros: d.name, dds: typehash::dds_type_name(d.name)?, hash: typehash::type_hash(d.name)? })
    }

    /// The type whose DDS name is `dds` (`sensor_msgs::msg::dds_::Imu_`), if
    /// fusiond knows it.
    pub fn of_dds(dds: &str) -> Option<Self> {
        let (package, rest) = dds.split_once("::msg::dds_::")?;
        Self::of(&format!("{package}/msg/{}", rest.strip_suffix('_')?))
    }
}

/// The data key of `topic` (`/odometry/filtered`) of type `ty` in `domain`.
pub fn topic_key(domain: u32, topic: &str, ty: &TopicType) -> String {
    format!("{domain}/{}/{}/{}", topic.trim_matches('/'), ty.dds, ty.hash)
}

/// The key that matches every type of `topic` in `domain`: a sample's last
/// two chunks then say its type and hash ([`key_type`]).
pub fn topic_key_any_type(domain: u32, topic: &str) -> String {
    format!("{domain}/{}/*/*", topic.trim_matches('/'))
}

/// A data key's DDS type and type hash (its last two chunks).
pub fn key_type(key: &str) -> Option<(&str, &str)> {
    let (rest, hash) = key.rsplit_once('/')?;
    let (_, dds) = rest.rsplit_once('/')?;
    Some((dds, hash))
}

/// A node as rmw_zenoh announces it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    /// ROS domain id.
    pub domain: u32,
    /// The Zenoh session's id, as Zenoh writes it.
    pub zid: String,
    /// The node's id in its session.
    pub id: u64,
    /// Security enclave (`/`).
    pub enclave: String,
    /// Namespace (`/`).
    pub namespace: String,
    /// Name.
    pub name: String,
}

impl Node {
    fn prefix(&self, entity: u64, kind: EntityKind) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{entity}/{}/{}/{}/{}",
            self.domain,
            self.zid,
            self.id,
            kind.code(),
            mangle(&self.enclave),
            mangle(&self.namespace),
            mangle(&self.name)
        )
    }

    /// The node's own token (its id twice).
    pub fn token(&self) -> String {
        self.prefix(self.id, EntityKind::Node)
    }

    /// The token of its publisher or subscription `entity` on `topic`.
    pub fn endpoint_token(&self, entity: u64, kind: EntityKind, topic: &str, ty: &TopicType, qos: Qos) -> String {
        format!("{}/{}/{}/{}/{}", self.prefix(entity, kind), mangle(topic), ty.dds, ty.hash, qos.keyexpr())
    }
}

/// The GID of the entity whose token is `token`.
pub fn gid(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut out = [0u8; 16];
    out[..8].copy_from_slice(&(h as u64).to_le_bytes());
    out[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    out
}

/// What every publication carries besides its payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    /// The publisher's count of its publications, from 1.
    pub sequence_number: i64,
    /// When it was published, ns of the publisher's wall clock.
    pub source_timestamp_ns: i64,
    /// The publisher's GID.
    pub gid: [u8; 16],
}

impl Attachment {
    /// Its 33 bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut s = zenoh_ext::ZSerializer::new();
        s.serialize(self.sequence_number);
        s.serialize(self.source_timestamp_ns);
        s.serialize(&self.gid[..]);
        s.finish().to_bytes().into_owned()
    }

    /// An attachment read back, or why it is not one.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let z = zenoh::bytes::ZBytes::from(bytes.to_vec());
        let mut d = zenoh_ext::ZDeserializer::new(&z);
        let bad = || format!("an attachment of {} bytes that is not rmw_zenoh's", bytes.len());
        let sequence_number = d.deserialize::<i64>().map_err(|_| bad())?;
        let source_timestamp_ns = d.deserialize::<i64>().map_err(|_| bad())?;
        let gid: Vec<u8> = d.deserialize().map_err(|_| bad())?;
        let gid = <[u8; 16]>::try_from(gid.as_slice()).map_err(|_| bad())?;
        if !d.done() {
            return Err(bad());
        }
        Ok(Self { sequence_number, source_timestamp_ns, gid })
    }
}

#[cfg(test)]
mod tests;
