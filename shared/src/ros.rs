//! ROS bags in: ROS 1 bags (`.bag`: the index read by the `rosbag` crate, the
//! chunks here, in `ros1`, with every size checked; messages by
//! `serde_rosmsg`) and ROS 2 bags in MCAP (the `mcap` crate, after
//! `mcap_scan` checked the file) or in SQLite (`db3`), messages in CDR by
//! `cdr-encoding`.
//!
//! A topic map ([`Route`]s: a topic, the kinds it gives and the sensor id they
//! go to; fusiond's `[[sensor]] topic = …`) says which topics are read and as
//! what. Each message's header stamp is its sample's time; axes and frames are
//! REP-103 and REP-105 (FLU body, ENU world), as fusiond's own. Each kind of a
//! route numbers its samples from 0. What each message type gives is in
//! [`messages`]. A mapped topic of a type fusiond does not read, or mapped to a
//! kind its type does not give, is an error before anything is read; a message
//! that gives no sample (an orientation not given, a covariance unknown, a
//! message that does not decode) is a counted refusal with its reason, and
//! [`BagSummary`] says what each topic gave.

mod db3;
pub mod messages;
mod ros1;
pub mod ros2;
pub mod typehash;

use std::collections::BTreeMap;
use std::path::Path;

use messages::{
    Convert, FluidPressure, Imu, MagneticField, MessageType, NavSatFix, Odometry, PoseWithCovarianceStamped,
    Ros1Header, Ros2Header, Stamp, TwistWithCovarianceStamped,
};
use serde::de::DeserializeOwned;

use crate::sample::{Sample, SampleKind};

/// A topic read as kinds of one sensor id.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// The topic, as in the bag (`/imu/data`).
    pub topic: String,
    /// The kinds taken from each of its messages (an IMU topic: `imu`, and
    /// `attitude` for its orientation).
    pub kinds: Vec<SampleKind>,
    /// The sensor id of the samples.
    pub sensor: u32,
    /// The `[[sensor]]` entry's name, for messages.
    pub name: String,
}

impl Route {
    /// The route of a `[[sensor]]` entry named `name` with id `sensor`, its
    /// `kinds` (by name) and its `topic`: `None` without a topic; an error
    /// naming the first kind that is not one.
    pub fn of_sensor(name: &str, sensor: u32, kinds: &[String], topic: Option<&str>) -> Result<Option<Self>, String> {
        let Some(topic) = topic else { return Ok(None) };
        let kinds = kinds
            .iter()
            .map(|k| SampleKind::from_name(k).ok_or_else(|| format!("[[sensor]] {name:?} names an unknown kind {k:?}")))
            .collect::<Result<_, _>>()?;
        Ok(Some(Self { topic: topic.into(), kinds, sensor, name: name.into() }))
    }
}

/// A bag that cannot be read, or a topic map that does not fit it.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// The file could not be opened or mapped.
    #[error("cannot read it: {0}")]
    Io(#[from] std::io::Error),
    /// Not a bag fusiond reads, or damaged before its first message.
    #[error("{0}")]
    Format(String),
    /// A mapped topic's type is not one fusiond reads.
    #[error(
        "topic {topic} (mapped to [[sensor]] {name:?}) is a {ty}, which fusiond does not read; it reads {}",
        MessageType::ALL.map(|(_, n)| n).join(", ")
    )]
    UnknownType {
        /// The topic.
        topic: String,
        /// Its message type.
        ty: String,
        /// The `[[sensor]]` it is mapped to.
        name: String,
    },
    /// A mapped topic's type does not give a kind it is mapped to.
    #[error("topic {topic} is a {ty}, which gives no {kind} sample ([[sensor]] {name:?}); it gives {gives}")]
    WrongKind {
        /// The topic.
        topic: String,
        /// Its message type.
        ty: String,
        /// The kind it cannot give.
        kind: &'static str,
        /// The `[[sensor]]` entry.
        name: String,
        /// The kinds it gives.
        gives: String,
    },
}

/// What a bag's topic gave.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TopicSummary {
    /// Its message type.
    pub ty: String,
    /// Messages read.
    pub messages: u64,
    /// Whether the topic map reads it.
    pub mapped: bool,
    /// Samples made, by kind name.
    pub samples: BTreeMap<&'static str, u64>,
    /// Messages (per kind) that made no sample, by reason.
    pub refused: BTreeMap<String, u64>,
    /// Messages with the same bytes as an earlier one of the topic (within
    /// [`DUPLICATE_WINDOW`]): their samples carry the earlier one's sequence
    /// numbers, and fusiond counts them as duplicates.
    pub duplicates: u64,
}

/// What a bag gave, topic by topic (`fusiond replay` prints it).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BagSummary {
    /// `"ROS 1"`, `"ROS 2 (MCAP)"` or `"ROS 2 (SQLite)"`.
    pub format: &'static str,
    /// Each topic of the bag.
    pub topics: BTreeMap<String, TopicSummary>,
    /// Mapped topics with no message in the bag.
    pub missing: Vec<String>,
    /// Where the bag stopped being readable, if it did before its end.
    pub damage: Option<String>,
}

impl std::fmt::Display for BagSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "bag ({}):", self.format)?;
        for (topic, t) in &self.topics {
            if !t.mapped {
                writeln!(
                    f,
                    "  {topic} ({}): {} messages, not mapped (no [[sensor]] topic): ignored",
                    t.ty, t.messages
                )?;
                continue;
            }
            let made: Vec<String> = t.samples.iter().map(|(k, n)| format!("{n} {k}")).collect();
            write!(f, "  {topic} ({}): {} messages -> {}", t.ty, t.messages, made.join(", "))?;
            let refused: Vec<String> = t.refused.iter().map(|(r, n)| format!("{n} refused: {r}")).collect();
            if !refused.is_empty() {
                write!(f, "; {}", refused.join("; "))?;
            }
            if t.duplicates > 0 {
                write!(f, "; {} duplicates (the same bytes as an earlier message)", t.duplicates)?;
            }
            writeln!(f)?;
        }
        for topic in &self.missing {
            writeln!(f, "  {topic}: mapped, but no message in the bag")?;
        }
        if let Some(d) = &self.damage {
            writeln!(f, "  the bag is damaged: {d}; what comes after is not read")?;
        }
        Ok(())
    }
}

/// One sample of a bag (or why a message gave none), in the bag's order.
#[derive(Debug, Clone, PartialEq)]
pub struct BagItem {
    /// The message's number in the bag, from 1.
    pub position: u64,
    /// The sample, or why there is none.
    pub sample: Result<Sample, String>,
}

/// The ROS 1 bag magic.
pub const ROS1_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Whether `head` (the first bytes of a file) starts a ROS 1 bag.
pub fn is_ros1(head: &[u8]) -> bool {
    head.starts_with(ROS1_MAGIC)
}

/// Whether `bytes` (a whole MCAP file) is a ROS 2 bag: its header's profile
/// is `ros2` (fusiond's own recordings have none).
pub fn is_ros2_mcap(bytes: &[u8]) -> bool {
    let Ok(mut records) = mcap::read::LinearReader::new(bytes) else { return false };
    matches!(records.next(), Some(Ok(mcap::records::Record::Header(h))) if h.profile == "ros2")
}

/// The first bytes of an SQLite database: a ROS 2 bag in `.db3`.
pub const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";

/// Whether the file at `path` is a ROS bag fusiond reads: ROS 1, or ROS 2 in
/// MCAP (profile `ros2`) or in SQLite (`.db3`). Told by its first bytes (and
/// an MCAP file's header), not its name.
pub fn is_bag(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 16];
    let Ok(n) = std::fs::File::open(path).and_then(|mut f| f.read(&mut head)) else { return false };
    let head = &head[..n];
    is_ros1(head)
        || head.starts_with(SQLITE_MAGIC)
        || (head.starts_with(mcap::MAGIC) && {
            let file = std::fs::File::open(path);
            // SAFETY: read-only input; a file changed under the map gives wrong samples, not unsoundness.
            let map = file.and_then(|f| unsafe { memmap2::Mmap::map(&f) });
            map.is_ok_and(|m| is_ros2_mcap(&m))
        })
}

/// A topic's routes and its message type, once checked.
struct Topic {
    ty: Option<MessageType>,
    /// (kind, sensor, next seq).
    outputs: Vec<(SampleKind, u32, u64)>,
    /// Its last [`DUPLICATE_WINDOW`] messages' bytes, with the sequence
    /// number each output gave them.
    recent: std::collections::VecDeque<(Vec<u8>, Vec<u64>)>,
}

/// How many of a mapped topic's last messages a message is compared with to
/// find a duplicate (a driver or recorder that wrote a message twice).
pub const DUPLICATE_WINDOW: usize = 64;

/// The topic map checked against a topic of type `ty`.
fn topic_for(routes: &[Route], topic: &str, ty: &str) -> Result<Topic, BagError> {
    let mapped: Vec<&Route> = routes.iter().filter(|r| r.topic == topic).collect();
    if mapped.is_empty() {
        return Ok(Topic { ty: None, outputs: Vec::new(), recent: Default::default() });
    }
    let Some(t) = MessageType::from_name(ty) else {
        return Err(BagError::UnknownType { topic: topic.into(), ty: ty.into(), name: mapped[0].name.clone() });
    };
    let mut outputs = Vec::new();
    for r in mapped {
        for &kind in &r.kinds {
            if !t.kinds().contains(&kind) {
                let gives: Vec<&str> = t.kinds().iter().map(|k| k.name()).collect();
                return Err(BagError::WrongKind {
                    topic: topic.into(),
                    ty: ty.into(),
                    kind: kind.name(),
                    name: r.name.clone(),
                    gives: gives.join(", "),
                });
            }
            outputs.push((kind, r.sensor, 0));
        }
    }
    Ok(Topic { ty: Some(t), outputs, recent: Default::default() })
}

/// How messages are decoded: ROS 1 serialisation or CDR.
trait Decode {
    type Header: Stamp + DeserializeOwned + 'static;
    fn decode<T: DeserializeOwned>(data: &[u8]) -> Result<T, String>;
}

struct Ros1;
struct Ros2;

impl Decode for Ros1 {
    type Header = Ros1Header;
    fn decode<T: DeserializeOwned>(data: &[u8]) -> Result<T, String> {
        let len = u32::try_from(data.len()).map_err(|_| "a message over 4 GiB".to_string())?;
        let mut de = serde_rosmsg::Deserializer::new(std::io::Cursor::new(data), len);
        let v = T::deserialize(&mut de).map_err(|e| format!("does not decode: {e}"))?;
        if !de.is_fully_read() {
            return Err("does not decode: bytes left over".into());
        }
        Ok(v)
    }
}

impl Decode for Ros2 {
    type Header = Ros2Header;
    /// A CDR message (XCDR1): the 4-byte encapsulation header (its second
    /// byte 0: big-endian, 1: little-endian), then the data, aligned from
    /// there. Every declared length is checked against the message before
    /// anything is allocated (`cdr-encoding` borrows what it reads), and bytes
    /// past the message, other than padding to a multiple of 4, are refused.
    fn decode<T: DeserializeOwned>(data: &[u8]) -> Result<T, String> {
        use cdr_encoding::from_bytes;
        // rosbag2's per-message compression (`--compression-mode message`):
        // each message a zstd frame (a CDR message starts with 0x00).
        let decompressed;
        let data = if data.starts_with(ZSTD_MAGIC) {
            decompressed =
                decompress_zstd(data).map_err(|e| format!("a zstd-compressed message does not decompress: {e}"))?;
            &decompressed[..]
        } else {
            data
        };
        let Some((header, body)) = data.split_at_checked(4) else {
            return Err(format!("does not decode: {} bytes, shorter than a CDR header", data.len()));
        };
        let (value, used) = match [header[0], header[1]] {
            [0, 0] => from_bytes::<T, byteorder::BigEndian>(body),
            [0, 1] => from_bytes::<T, byteorder::LittleEndian>(body),
            [a, b] => return Err(format!("does not decode: encapsulation {a:#04x}{b:02x} is not plain CDR")),
        }
        .map_err(|e| format!("does not decode: {e}"))?;
        let left = body.len() - used;
        if left >= 4 || (left > 0 && !body.len().is_multiple_of(4)) {
            return Err(format!("does not decode: {left} bytes left over after the message"));
        }
        Ok(value)
    }
}

/// A ROS 2 message (CDR) of type `T`, checked as a bag's are ([`Ros2`]'s
/// decoder: the encapsulation header, every length, no bytes left over).
pub fn decode_cdr<T: DeserializeOwned>(data: &[u8]) -> Result<T, String> {
    Ros2::decode(data)
}

/// The first bytes of a zstd frame.
pub const ZSTD_MAGIC: &[u8] = &[0x28, 0xb5, 0x2f, 0xfd];

/// The most a compressed message may decompress to, bytes.
pub const MAX_MESSAGE_BYTES: u64 = 1 << 28;

/// A zstd frame, decompressed into at most [`MAX_MESSAGE_BYTES`].
fn decompress_zstd(data: &[u8]) -> Result<Vec<u8>, String> {
    let decoder = zstd::stream::read::Decoder::with_buffer(data).map_err(|e| e.to_string())?;
    let out = crate::mcap_scan::read_at_most(decoder, MAX_MESSAGE_BYTES, data.len()).map_err(|e| e.to_string())?;
    if out.len() as u64 > MAX_MESSAGE_BYTES {
        return Err(format!("it decompresses to more than {MAX_MESSAGE_BYTES} bytes"));
    }
    Ok(out)
}

fn decode<D: Decode>(ty: MessageType, data: &[u8]) -> Result<Box<dyn Convert>, String> {
    fn boxed<T: Convert + 'static>(v: T) -> Box<dyn Convert> {
        Box::new(v)
    }
    type H<D> = <D as Decode>::Header;
    Ok(match ty {
        MessageType::Imu => boxed(D::decode::<Imu<H<D>>>(data)?),
        MessageType::Odometry => boxed(D::decode::<Odometry<H<D>>>(data)?),
        MessageType::NavSatFix => boxed(D::decode::<NavSatFix<H<D>>>(data)?),
        MessageType::TwistWithCovarianceStamped => boxed(D::decode::<TwistWithCovarianceStamped<H<D>>>(data)?),
        MessageType::PoseWithCovarianceStamped => boxed(D::decode::<PoseWithCovarianceStamped<H<D>>>(data)?),
        MessageType::FluidPressure => boxed(D::decode::<FluidPressure<H<D>>>(data)?),
        MessageType::MagneticField => boxed(D::decode::<MagneticField<H<D>>>(data)?),
    })
}

/// What a read has seen so far: topics, the summary, the message count.
#[derive(Default)]
struct Topics {
    topics: BTreeMap<String, Topic>,
    summary: BagSummary,
    position: u64,
}

/// The state of one read of a bag: the topic map, what it has seen, and where
/// its samples go.
struct Reading<'r, F> {
    routes: &'r [Route],
    t: Topics,
    each: F,
}

impl Topics {
    /// Checks a topic (once) against the topic map.
    fn topic(&mut self, routes: &[Route], topic: &str, ty: &str) -> Result<(), BagError> {
        if !self.topics.contains_key(topic) {
            let t = topic_for(routes, topic, ty)?;
            let s = self.summary.topics.entry(topic.into()).or_default();
            (s.ty, s.mapped) = (ty.into(), t.ty.is_some());
            self.topics.insert(topic.into(), t);
        }
        Ok(())
    }

    /// A message of `topic`: its samples, or why it gave none. A message with
    /// the same bytes (its stamp among them) as one of the topic's last
    /// [`DUPLICATE_WINDOW`] gives its samples again with the same sequence
    /// numbers, so that fusiond counts them as duplicates.
    fn message<D: Decode>(&mut self, topic: &str, data: &[u8], each: &mut impl FnMut(BagItem)) {
        self.position += 1;
        let (Some(t), Some(s)) = (self.topics.get_mut(topic), self.summary.topics.get_mut(topic)) else { return };
        s.messages += 1;
        let Some(ty) = t.ty else { return };
        let earlier = t.recent.iter().find(|(bytes, _)| bytes.as_slice() == data).map(|(_, seqs)| seqs.clone());
        s.duplicates += u64::from(earlier.is_some());
        let decoded = decode::<D>(ty, data);
        let mut seqs = Vec::with_capacity(t.outputs.len());
        for (i, (kind, sensor, next)) in t.outputs.iter_mut().enumerate() {
            let seq = earlier.as_ref().map_or(*next, |e| e[i]);
            seqs.push(seq);
            let sample = decoded.as_ref().map_err(Clone::clone).and_then(|m| m.sample(*kind, *sensor, seq));
            match &sample {
                Ok(_) => {
                    if earlier.is_none() {
                        *next += 1;
                    }
                    *s.samples.entry(kind.name()).or_default() += 1;
                }
                Err(why) => *s.refused.entry(format!("{} {why}", kind.name())).or_default() += 1,
            }
            each(BagItem { position: self.position, sample });
        }
        if earlier.is_none() {
            if t.recent.len() == DUPLICATE_WINDOW {
                t.recent.pop_front();
            }
            t.recent.push_back((data.to_vec(), seqs));
        }
    }
}

impl<F: FnMut(BagItem)> Reading<'_, F> {
    fn topic(&mut self, topic: &str, ty: &str) -> Result<(), BagError> {
        self.t.topic(self.routes, topic, ty)
    }

    fn message<D: Decode>(&mut self, topic: &str, data: &[u8]) {
        self.t.message::<D>(topic, data, &mut self.each);
    }

    fn finish(self, format: &'static str) -> BagSummary {
        let mut summary = self.t.summary;
        summary.format = format;
        for r in self.routes {
            if !summary.topics.contains_key(&r.topic) && !summary.missing.contains(&r.topic) {
                summary.missing.push(r.topic.clone());
            }
        }
        summary
    }
}

/// Live ROS 2 messages (CDR) read one at a time, with the topic map, the
/// decoder, the refusals and the summary of a bag's read: one configuration
/// for the bag and the live robot. A topic's type is the first one seen on it.
pub struct LiveReader {
    routes: Vec<Route>,
    t: Topics,
}

impl LiveReader {
    /// A reader of the topics `routes` maps.
    pub fn new(routes: Vec<Route>) -> Self {
        Self { routes, t: Topics::default() }
    }

    /// The topic map.
    pub fn routes(&self) -> &[Route] {
        &self.routes
    }

    /// A message of `topic` of the ROS type `ty` (`sensor_msgs/msg/Imu`):
    /// `each` gets its samples (or why it gave none), numbered on from the
    /// topic's earlier ones. `Err`: the whole message is refused for its
    /// type: one fusiond does not read, one that gives no kind it is mapped
    /// to, or a second type on a topic that had another.
    pub fn message(&mut self, topic: &str, ty: &str, data: &[u8], mut each: impl FnMut(BagItem)) -> Result<(), String> {
        match self.t.summary.topics.get(topic) {
            Some(s) if s.ty != ty => return Err(format!("a {ty} on a topic of {} (two types on one topic)", s.ty)),
            Some(_) => {}
            None => self.t.topic(&self.routes, topic, ty).map_err(|e| e.to_string())?,
        }
        self.t.message::<Ros2>(topic, data, &mut each);
        Ok(())
    }

    /// What each topic gave so far.
    pub fn summary(&self) -> &BagSummary {
        &self.t.summary
    }
}

/// Reads the bag at `path` (ROS 1, or ROS 2 in MCAP), calling `each` with every
/// sample the topic map `routes` takes from it, in the bag's order.
pub fn read_bag(path: &Path, routes: &[Route], each: impl FnMut(BagItem)) -> Result<BagSummary, BagError> {
    let file = std::fs::File::open(path)?;
    // SAFETY: the bag is read-only input; a file changed under the map gives
    // wrong samples or a decode error, not unsoundness in this reader.
    let map = unsafe { memmap2::Mmap::map(&file)? };
    let mut reading = Reading { routes, t: Topics::default(), each };
    if is_ros1(&map) {
        ros1::read(path, &map, &mut reading)?;
        return Ok(reading.finish("ROS 1"));
    }
    if map.starts_with(mcap::MAGIC) {
        if !is_ros2_mcap(&map) {
            return Err(BagError::Format("an MCAP file, but not a ROS 2 bag (its profile is not \"ros2\")".into()));
        }
        read_ros2(&map, &mut reading)?;
        return Ok(reading.finish("ROS 2 (MCAP)"));
    }
    if map.starts_with(SQLITE_MAGIC) {
        drop(map);
        db3::read(path, &mut reading)?;
        return Ok(reading.finish("ROS 2 (SQLite)"));
    }
    Err(BagError::Format("neither a ROS 1 bag (#ROSBAG V2.0) nor a ROS 2 bag (MCAP, or SQLite .db3)".into()))
}

fn read_ros2<F: FnMut(BagItem)>(bytes: &[u8], r: &mut Reading<'_, F>) -> Result<(), BagError> {
    let scan = crate::mcap_scan::scan(bytes);
    if let Some(d) = scan.damage {
        r.t.summary.damage = Some(d.to_string());
    }
    let readable = &bytes[..scan.readable];
    // The summary (when written) lists every channel: the topic map is checked first.
    if let Ok(Some(summary)) = mcap::Summary::read(readable) {
        for c in summary.channels.values() {
            r.topic(&c.topic, c.schema.as_ref().map_or("", |s| s.name.as_str()))?;
        }
    }
    let stream = mcap::MessageStream::new(readable).map_err(|e| BagError::Format(e.to_string()))?;
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                r.t.summary.damage.get_or_insert(format!("after message {}: {e}", r.t.position));
                return Ok(());
            }
        };
        let topic = &m.channel.topic;
        if !r.t.topics.contains_key(topic) {
            if m.channel.message_encoding == "cdr" {
                r.topic(topic, m.channel.schema.as_ref().map_or("", |s| s.name.as_str()))?;
            } else {
                r.topic(topic, &format!("{} message", m.channel.message_encoding))?;
            }
        }
        r.message::<Ros2>(topic, &m.data);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_entry_is_a_route_if_it_has_a_topic() {
        let kinds = ["imu".to_string(), "attitude".to_string()];
        let r = Route::of_sensor("ahrs", 3, &kinds, Some("/imu/data")).unwrap().unwrap();
        assert_eq!(
            (r.topic.as_str(), r.sensor, r.kinds.as_slice()),
            ("/imu/data", 3, &[SampleKind::Imu, SampleKind::Attitude][..])
        );
        assert_eq!(Route::of_sensor("ahrs", 3, &kinds, None), Ok(None));
        let e = Route::of_sensor("ahrs", 3, &["imu".into(), "ahrs".into()], Some("/imu/data")).unwrap_err();
        assert_eq!(e, "[[sensor]] \"ahrs\" names an unknown kind \"ahrs\"");
    }
}
