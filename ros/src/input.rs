//! ROS 2 messages in: what each mapped topic is read as, the checks a
//! message passes before it is decoded, and the counts of what was refused.
//!
//! A topic's type is fixed before anything is read (from its kinds, or
//! `[ros.topic_types]`), and fusion-ros subscribes to every type on it
//! (`<domain>/<topic>/*/*`), so that a message of another type or another
//! distribution's definition is seen, counted and named, not silently
//! missing. A message is refused, counted by topic and reason, and warned
//! about the first time, when:
//! - its key names another type (two publishers of different types on one
//!   topic) or another type hash (another ROS distribution's definition;
//!   Humble's rmw_zenoh writes `TypeHashNotSupported`);
//! - it has no attachment, or one that is not rmw_zenoh's (ROS nodes drop
//!   such samples too);
//! - its topic brought more than `[ros] max_topic_rate_hz` in the last
//!   second (a token bucket per topic: a flood on one leaves the others alone);
//! - it does not decode, or gives no sample (the bag reader's reasons).

use std::collections::BTreeMap;
use std::sync::Mutex;

use fusion_shared::SampleKind;
use fusion_shared::ros::Route;
use fusion_shared::ros::messages::MessageType;

use crate::rmw_zenoh::{Attachment, TopicType, key_type};

/// The ROS 2 name of a bag-table type (`sensor_msgs/Imu` → `sensor_msgs/msg/Imu`).
fn ros2_name(ros1: &str) -> String {
    ros1.replacen('/', "/msg/", 1)
}

/// A mapped topic: its name, type and the kinds of every route on it.
#[derive(Debug, Clone)]
pub struct InputTopic {
    /// The topic (`/imu/data`).
    pub topic: String,
    /// Its type.
    pub ty: TopicType,
}

/// Every mapped topic once, with its type: `overrides` (`[ros.topic_types]`)
/// where given, else the first type of the bag table that gives all the
/// kinds its routes take.
pub fn input_topics(routes: &[Route], overrides: &BTreeMap<String, String>) -> Result<Vec<InputTopic>, String> {
    let mut topics: Vec<InputTopic> = Vec::new();
    for r in routes {
        if topics.iter().any(|t| t.topic == r.topic) {
            continue;
        }
        let kinds: Vec<SampleKind> =
            routes.iter().filter(|o| o.topic == r.topic).flat_map(|o| o.kinds.iter().copied()).collect();
        let name = match overrides.get(&r.topic) {
            Some(name) => {
                let t = MessageType::from_name(name)
                    .ok_or_else(|| format!("[ros.topic_types] {:?} = {name:?}: not a type fusiond reads", r.topic))?;
                if let Some(k) = kinds.iter().find(|k| !t.kinds().contains(k)) {
                    return Err(format!("[ros.topic_types] {:?}: a {name} gives no {} sample", r.topic, k.name()));
                }
                ros2_name(&name.replacen("/msg/", "/", 1))
            }
            None => MessageType::ALL
                .iter()
                .find(|(t, _)| kinds.iter().all(|k| t.kinds().contains(k)))
                .map(|(_, n)| ros2_name(n))
                .ok_or_else(|| format!("topic {}: no ROS message gives all of its kinds", r.topic))?,
        };
        let ty = TopicType::of(&name).ok_or_else(|| format!("topic {}: no type description of {name}", r.topic))?;
        topics.push(InputTopic { topic: r.topic.clone(), ty });
    }
    Ok(topics)
}

/// A topic's counts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TopicCounts {
    /// Messages that reached fusion-ros.
    pub messages: u64,
    /// Samples sent to fusiond.
    pub samples: u64,
    /// Messages (or, for a message's kinds, samples) refused, by reason.
    pub refused: BTreeMap<String, u64>,
}

/// Reasons kept apart per topic; more are counted as one (a hostile peer
/// cannot grow the table).
pub const MAX_REASONS: usize = 32;

/// Every topic's counts, shared by the Zenoh callbacks and the input thread.
#[derive(Debug, Default)]
pub struct InputStats {
    topics: Mutex<BTreeMap<String, TopicCounts>>,
}

impl InputStats {
    fn with<R>(&self, topic: &str, f: impl FnOnce(&mut TopicCounts) -> R) -> R {
        let mut topics = self.topics.lock().unwrap_or_else(|e| e.into_inner());
        if !topics.contains_key(topic) {
            topics.insert(topic.to_string(), TopicCounts::default());
        }
        f(topics.get_mut(topic).expect("inserted"))
    }

    /// A message of `topic` reached fusion-ros.
    pub fn message(&self, topic: &str) {
        self.with(topic, |c| c.messages += 1);
    }

    /// A sample of `topic` went to fusiond.
    pub fn sample(&self, topic: &str) {
        self.with(topic, |c| c.samples += 1);
    }

    /// Something of `topic` was refused for `reason`: counted, and warned
    /// about the first time.
    pub fn refuse(&self, topic: &str, reason: &str) {
        let first = self.with(topic, |c| {
            let key = if c.refused.len() >= MAX_REASONS && !c.refused.contains_key(reason) {
                "other reasons"
            } else {
                reason
            };
            let n = c.refused.entry(key.to_string()).or_default();
            *n += 1;
            *n == 1
        });
        if first {
            tracing::warn!(topic, "refused: {reason} (counted; said once)");
        }
    }

    /// Every topic's counts now.
    pub fn counts(&self) -> BTreeMap<String, TopicCounts> {
        self.topics.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

/// A token bucket: at most `rate` a second, bursts of one second's worth.
#[derive(Debug)]
pub struct Bucket {
    rate: f64,
    tokens: f64,
    last_ns: u64,
}

impl Bucket {
    /// A full bucket of `rate` a second.
    pub fn new(rate: f64, now_ns: u64) -> Self {
        Self { rate, tokens: rate, last_ns: now_ns }
    }

    /// Whether one more may pass at `now_ns`.
    pub fn take(&mut self, now_ns: u64) -> bool {
        let dt = now_ns.saturating_sub(self.last_ns) as f64 * 1e-9;
        self.last_ns = self.last_ns.max(now_ns);
        self.tokens = (self.tokens + dt * self.rate).min(self.rate);
        if self.tokens < 1.0 {
            return false;
        }
        self.tokens -= 1.0;
        true
    }
}

/// The checks of a message before it is decoded: its key's type and hash,
/// its attachment, its topic's rate.
pub fn admit(
    expected: &TopicType,
    key: &str,
    attachment: Option<&[u8]>,
    bucket: &Mutex<Bucket>,
    now_ns: u64,
) -> Result<Attachment, String> {
    let (dds, hash) = key_type(key).ok_or_else(|| format!("key {key:?} names no type"))?;
    if dds != expected.dds {
        return Err(format!("a {dds} on a topic read as {} (two types on one topic; [ros.topic_types])", expected.dds));
    }
    if hash != expected.hash {
        return Err(format!(
            "type hash {hash}: another ROS distribution's {} (fusion-ros has Jazzy's {}; Humble has none)",
            expected.ros, expected.hash
        ));
    }
    let attachment = attachment.ok_or("no attachment (not an rmw_zenoh publisher; ROS nodes drop it too)")?;
    let attachment = Attachment::from_bytes(attachment)?;
    if !bucket.lock().unwrap_or_else(|e| e.into_inner()).take(now_ns) {
        return Err("a flood: more than [ros] max_topic_rate_hz messages a second".into());
    }
    Ok(attachment)
}

#[cfg(test)]
mod tests;
