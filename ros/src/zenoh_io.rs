//! fusion-ros on rmw_zenoh: its publishers, and its subscriptions, each
//! message checked in Zenoh's callback ([`admit`]) and handed to the input
//! thread.

use std::sync::{Arc, Mutex};

use anyhow::Context;
use fusion_ros::input::{Bucket, InputTopic, admit};
use fusion_ros::node::RosNode;
use fusion_ros::rmw_zenoh::{Qos, TopicType};
use fusion_ros::settings::NodeConfig;
use fusion_shared::ros::ros2::Clock;
use fusion_shared::time::now_ns;

use crate::pump::{Inbound, Outputs, Shared};

pub fn outputs(node: &mut RosNode, c: &NodeConfig) -> anyhow::Result<Outputs> {
    let ty = |name: &str| TopicType::of(name).with_context(|| format!("no type description of {name}"));
    let odometry = Box::new(node.publisher(&c.ros.odometry_topic, &ty("nav_msgs/msg/Odometry")?, Qos::DEFAULT)?);
    let tf = match c.ros.tf_topic.as_str() {
        "" => None,
        topic => Some(Box::new(node.publisher(topic, &ty("tf2_msgs/msg/TFMessage")?, Qos::TF)?) as _),
    };
    let diagnostics = match c.ros.diagnostics_topic.as_str() {
        "" => None,
        topic => Some(Box::new(node.publisher(topic, &ty("diagnostic_msgs/msg/DiagnosticArray")?, Qos::DEFAULT)?) as _),
    };
    Ok(Outputs { odometry, tf, diagnostics })
}

/// The subscription of input topic `index`: each message checked
/// ([`admit`]) and handed to the input thread; a full queue is counted.
pub fn subscribe(
    node: &mut RosNode,
    index: usize,
    t: &InputTopic,
    max_rate_hz: f64,
    tx: crossbeam::channel::Sender<Inbound>,
    shared: &Arc<Shared>,
) -> anyhow::Result<zenoh::pubsub::Subscriber<()>> {
    let (expected, topic, shared) = (t.ty.clone(), t.topic.clone(), Arc::clone(shared));
    let bucket = Mutex::new(Bucket::new(max_rate_hz, now_ns()));
    node.subscribe(&t.topic, &t.ty, Qos::SENSOR_DATA, move |sample| {
        let attachment = sample.attachment().map(|a| a.to_bytes());
        let key = sample.key_expr().as_str();
        match admit(&expected, key, attachment.as_deref(), &bucket, now_ns()) {
            Ok(_) => {
                let data = sample.payload().to_bytes().into_owned();
                if tx.try_send(Inbound { topic: index, data }).is_err() {
                    shared.stats.refuse(&topic, "fusion-ros's queue is full (fusiond or this host too slow)");
                }
            }
            Err(why) => {
                shared.stats.message(&topic);
                shared.stats.refuse(&topic, &why);
            }
        }
    })
}

/// `/clock` (sim time): each message sets or checks the clock's offset.
pub fn subscribe_clock(node: &mut RosNode, shared: &Arc<Shared>) -> anyhow::Result<zenoh::pubsub::Subscriber<()>> {
    let ty = TopicType::of("rosgraph_msgs/msg/Clock").context("no type description of rosgraph_msgs/msg/Clock")?;
    let (shared, expected) = (Arc::clone(shared), ty.clone());
    node.subscribe("/clock", &ty, Qos::SENSOR_DATA, move |sample| {
        let key = sample.key_expr().as_str();
        if fusion_ros::rmw_zenoh::key_type(key).is_none_or(|(dds, hash)| dds != expected.dds || hash != expected.hash) {
            shared.stats.refuse("/clock", &format!("key {key}: not a rosgraph_msgs/msg/Clock of this distribution"));
            return;
        }
        match fusion_shared::ros::decode_cdr::<Clock>(&sample.payload().to_bytes()) {
            Ok(c) => match c.clock.ns() {
                Some(ns) => shared.clock.on_clock(ns, now_ns()),
                None => shared.stats.refuse("/clock", "a negative time"),
            },
            Err(why) => shared.stats.refuse("/clock", &why),
        }
    })
}
