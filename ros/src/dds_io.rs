//! fusion-ros on DDS: its publishers, and a thread that takes every
//! subscription's messages as they come (a `mio` poll over the readers) and
//! hands them to the input thread as CDR, through the same topic reader as
//! rmw_zenoh's and the bags'.

use std::time::Duration;

use fusion_ros::Sink;
use fusion_ros::dds::DdsNode;
use fusion_ros::input::{Bucket, InputTopic};
use fusion_ros::rmw_zenoh::Qos;
use fusion_ros::settings::NodeConfig;
use fusion_shared::ros::messages::{
    FluidPressure, Imu, MagneticField, MessageType, NavSatFix, Odometry, PoseWithCovarianceStamped, Ros2Header,
    TwistWithCovarianceStamped,
};
use fusion_shared::ros::ros2::{Clock, DiagnosticArray, TfMessage, to_cdr};
use fusion_shared::time::now_ns;
use ros2_client::Subscription;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::sync::atomic::Ordering;

use crate::pump::{Inbound, Outputs, Shared};

/// Odometry, TF and diagnostics publishers.
pub fn outputs(node: &mut DdsNode, c: &NodeConfig) -> anyhow::Result<Outputs> {
    let odometry: Box<dyn Sink<Odometry<Ros2Header>>> =
        Box::new(node.publisher(&c.ros.odometry_topic, "nav_msgs/msg/Odometry", Qos::DEFAULT)?);
    let tf = match c.ros.tf_topic.as_str() {
        "" => None,
        topic => Some(Box::new(node.publisher::<TfMessage>(topic, "tf2_msgs/msg/TFMessage", Qos::TF)?) as _),
    };
    let diagnostics = match c.ros.diagnostics_topic.as_str() {
        "" => None,
        topic => Some(Box::new(node.publisher::<DiagnosticArray>(
            topic,
            "diagnostic_msgs/msg/DiagnosticArray",
            Qos::DEFAULT,
        )?) as _),
    };
    Ok(Outputs { odometry, tf, diagnostics })
}

/// A subscription whose messages go on as CDR (`Err`: one that did not decode).
pub trait Drain: Send {
    /// Every message received so far.
    fn drain(&mut self, each: &mut dyn FnMut(Result<Vec<u8>, String>));
    /// Registers it with `poll` as `token`.
    fn register(&mut self, poll: &Poll, token: Token) -> std::io::Result<()>;
}

struct Typed<M>(Subscription<M>);

impl<M: DeserializeOwned + Serialize + Send + 'static> Drain for Typed<M> {
    fn drain(&mut self, each: &mut dyn FnMut(Result<Vec<u8>, String>)) {
        loop {
            match self.0.take() {
                Ok(Some((m, _))) => each(Ok(to_cdr(&m))),
                Ok(None) => return,
                Err(e) => each(Err(format!("does not decode: {e:?}"))),
            }
        }
    }

    fn register(&mut self, poll: &Poll, token: Token) -> std::io::Result<()> {
        poll.registry().register(&mut self.0, token, Interest::READABLE)
    }
}

/// The subscription of an input topic, as its type.
fn typed(node: &mut DdsNode, t: &InputTopic) -> anyhow::Result<Box<dyn Drain>> {
    fn sub<M: DeserializeOwned + Serialize + Send + 'static>(
        node: &mut DdsNode,
        t: &InputTopic,
    ) -> anyhow::Result<Box<dyn Drain>> {
        Ok(Box::new(Typed(node.subscription::<M>(&t.topic, t.ty.ros, Qos::SENSOR_DATA)?)))
    }
    type H = Ros2Header;
    let ty =
        MessageType::from_name(t.ty.ros).ok_or_else(|| anyhow::anyhow!("{}: not a type fusiond reads", t.ty.ros))?;
    match ty {
        MessageType::Imu => sub::<Imu<H>>(node, t),
        MessageType::Odometry => sub::<Odometry<H>>(node, t),
        MessageType::NavSatFix => sub::<NavSatFix<H>>(node, t),
        MessageType::TwistWithCovarianceStamped => sub::<TwistWithCovarianceStamped<H>>(node, t),
        MessageType::PoseWithCovarianceStamped => sub::<PoseWithCovarianceStamped<H>>(node, t),
        MessageType::FluidPressure => sub::<FluidPressure<H>>(node, t),
        MessageType::MagneticField => sub::<MagneticField<H>>(node, t),
    }
}

/// The input topics' subscriptions, and `/clock`'s under sim time.
pub type Subscriptions = (Vec<Box<dyn Drain>>, Option<Subscription<Clock>>);

/// Every input topic's subscription, and `/clock`'s under sim time.
pub fn subscriptions(node: &mut DdsNode, topics: &[InputTopic], sim: bool) -> anyhow::Result<Subscriptions> {
    let subs = topics.iter().map(|t| typed(node, t)).collect::<anyhow::Result<_>>()?;
    let clock = if sim {
        Some(node.subscription::<Clock>("/clock", "rosgraph_msgs/msg/Clock", Qos::SENSOR_DATA)?)
    } else {
        None
    };
    Ok((subs, clock))
}

/// Until stopped: each subscription's messages to the input thread (at most
/// `[ros] max_topic_rate_hz` a topic), `/clock`'s to the clock.
pub fn receive(
    mut subs: Vec<Box<dyn Drain>>,
    mut clock: Option<Subscription<Clock>>,
    topics: &[InputTopic],
    max_rate_hz: f64,
    tx: crossbeam::channel::Sender<Inbound>,
    shared: &Shared,
) -> anyhow::Result<()> {
    let poll = Poll::new()?;
    for (i, s) in subs.iter_mut().enumerate() {
        s.register(&poll, Token(i))?;
    }
    let clock_token = Token(subs.len());
    if let Some(c) = clock.as_mut() {
        poll.registry().register(c, clock_token, Interest::READABLE)?;
    }
    let mut buckets: Vec<Bucket> = topics.iter().map(|_| Bucket::new(max_rate_hz, now_ns())).collect();
    let mut events = Events::with_capacity(64);
    let mut poll = poll;
    while !shared.stop.load(Ordering::Relaxed) {
        poll.poll(&mut events, Some(Duration::from_millis(100)))?;
        for e in events.iter() {
            if e.token() == clock_token {
                take_clock(clock.as_ref(), shared);
                continue;
            }
            let i = e.token().0;
            let (topic, bucket) = (&topics[i].topic, &mut buckets[i]);
            subs[i].drain(&mut |m| match m {
                Ok(data) if bucket.take(now_ns()) => {
                    if tx.try_send(Inbound { topic: i, data }).is_err() {
                        shared.stats.refuse(topic, "fusion-ros's queue is full (fusiond or this host too slow)");
                    }
                }
                Ok(_) => {
                    shared.stats.message(topic);
                    shared.stats.refuse(topic, "a flood: more than [ros] max_topic_rate_hz messages a second");
                }
                Err(why) => {
                    shared.stats.message(topic);
                    shared.stats.refuse(topic, &why);
                }
            });
        }
    }
    Ok(())
}

fn take_clock(clock: Option<&Subscription<Clock>>, shared: &Shared) {
    let Some(c) = clock else { return };
    loop {
        match c.take() {
            Ok(Some((m, _))) => match m.clock.ns() {
                Some(ns) => shared.clock.on_clock(ns, now_ns()),
                None => shared.stats.refuse("/clock", "a negative time"),
            },
            Ok(None) => return,
            Err(e) => shared.stats.refuse("/clock", &format!("does not decode: {e:?}")),
        }
    }
}
