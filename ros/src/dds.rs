//! fusion-ros's ROS 2 node on DDS, the default middleware of Humble, Jazzy
//! and Kilted, through `ros2-client` on RustDDS (pure Rust, no ROS
//! installation). It follows ROS 2's DDS conventions: topics `rt/<topic>`,
//! types `<pkg>::msg::dds_::<Type>_`, XCDR1 data, and the node announced on
//! `ros_discovery_info` (so `ros2 node list` and `ros2 topic info` show it).
//!
//! DDS matches a reader only with writers of its type name, so a publisher
//! of another type on a mapped topic is never delivered (DDS tells no type
//! hash to compare). A message that does not decode is counted as the bag
//! reader counts it. Discovery is DDS's: SPDP multicast on the robot's
//! network (239.255.0.1), as every ROS 2 node does by default.

use std::sync::Mutex;

use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Subscription,
    qos::{Durability, History, WhenFull},
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::rmw_zenoh::Qos;

/// A ROS name split as `ros2-client` takes it: `/imu/data` is `("/imu", "data")`.
fn name(topic: &str) -> anyhow::Result<Name> {
    let (ns, base) = topic.rsplit_once('/').ok_or_else(|| anyhow::anyhow!("topic {topic:?} has no /"))?;
    let ns = if ns.is_empty() { "/" } else { ns };
    Name::new(ns, base).map_err(|e| anyhow::anyhow!("topic {topic:?}: {e:?}"))
}

/// `sensor_msgs/msg/Imu` as `ros2-client` names it.
fn type_name(ros: &str) -> anyhow::Result<MessageTypeName> {
    let mut parts = ros.split('/');
    match (parts.next(), parts.next(), parts.next()) {
        (Some(package), Some("msg"), Some(ty)) => Ok(MessageTypeName::new(package, ty)),
        _ => anyhow::bail!("{ros:?} is not a ROS 2 message type name"),
    }
}

fn qos(q: Qos) -> QosProfile {
    let base = QosProfile::subscription_default()
        .durability(if q.transient_local { Durability::TransientLocal } else { Durability::Volatile })
        .history(History::KeepLast { depth: q.depth as usize });
    if q.reliable { base.reliability_reliable(WhenFull::DEFAULT) } else { base.reliability_best_effort() }
}

/// The node on DDS.
pub struct DdsNode {
    node: Node,
}

impl DdsNode {
    /// A node `namespace`/`name` in ROS domain `domain`, on the interfaces of
    /// `interfaces` (empty: every one).
    pub fn open(namespace: &str, node: &str, domain: u32, interfaces: &[std::net::IpAddr]) -> anyhow::Result<Self> {
        let domain = u16::try_from(domain).map_err(|_| anyhow::anyhow!("domain id {domain} is over 232"))?;
        fn cannot(domain: u16, e: impl std::fmt::Debug) -> anyhow::Error {
            anyhow::anyhow!("cannot start DDS (domain {domain}): {e:?}")
        }
        let context = if interfaces.is_empty() {
            Context::with_options(ContextOptions::new().domain_id(domain)).map_err(|e| cannot(domain, e))?
        } else {
            let participant = DomainParticipantBuilder::new(domain)
                .with_only_networks(interfaces.iter().copied())
                .build()
                .map_err(|e| cannot(domain, e))?;
            Context::from_domain_participant(participant).map_err(|e| cannot(domain, e))?
        };
        let node_name = NodeName::new(namespace, node).map_err(|e| anyhow::anyhow!("node name {node:?}: {e:?}"))?;
        let node = context
            .new_node(node_name, NodeOptions::new().enable_rosout(false))
            .map_err(|e| anyhow::anyhow!("cannot make the DDS node: {e:?}"))?;
        Ok(Self { node })
    }

    /// A publisher of `topic` of type `ros` (ROS 2 spelling).
    pub fn publisher<M: Serialize>(&mut self, topic: &str, ros: &str, q: Qos) -> anyhow::Result<DdsPublisher<M>> {
        let t = self
            .node
            .create_topic(&name(topic)?, type_name(ros)?, &qos(q))
            .map_err(|e| anyhow::anyhow!("DDS topic {topic}: {e:?}"))?;
        let publisher =
            self.node.create_publisher(&t, None).map_err(|e| anyhow::anyhow!("DDS publisher {topic}: {e:?}"))?;
        Ok(DdsPublisher { publisher: Mutex::new(publisher), sent: Mutex::new(0) })
    }

    /// A subscription to `topic` of type `ros`, its messages decoded as `M`.
    pub fn subscription<M: DeserializeOwned + 'static>(
        &mut self,
        topic: &str,
        ros: &str,
        q: Qos,
    ) -> anyhow::Result<Subscription<M>> {
        let t = self
            .node
            .create_topic(&name(topic)?, type_name(ros)?, &qos(q))
            .map_err(|e| anyhow::anyhow!("DDS topic {topic}: {e:?}"))?;
        self.node.create_subscription(&t, None).map_err(|e| anyhow::anyhow!("DDS subscription {topic}: {e:?}"))
    }
}

/// A DDS publisher.
pub struct DdsPublisher<M: Serialize> {
    publisher: Mutex<Publisher<M>>,
    sent: Mutex<u64>,
}

impl<M: Serialize + Clone + std::fmt::Debug + Send> crate::Sink<M> for DdsPublisher<M> {
    fn put(&self, message: &M) -> anyhow::Result<()> {
        let publisher = self.publisher.lock().unwrap_or_else(|e| e.into_inner());
        publisher.publish(message.clone()).map_err(|e| anyhow::anyhow!("DDS publish: {e:?}"))?;
        *self.sent.lock().unwrap_or_else(|e| e.into_inner()) += 1;
        Ok(())
    }

    fn sent(&self) -> u64 {
        *self.sent.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_split_as_ros2_client_takes_them() {
        assert_eq!(name("/imu/data").unwrap().to_dds_name("rt", &NodeName::new("/", "n").unwrap(), ""), "rt/imu/data");
        assert_eq!(name("/tf").unwrap().to_dds_name("rt", &NodeName::new("/", "n").unwrap(), ""), "rt/tf");
        assert!(type_name("sensor_msgs/Imu").is_err());
    }
}
