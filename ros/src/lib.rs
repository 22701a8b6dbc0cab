//! fusion-ros: fusiond as a node of a running ROS 2 robot, over rmw_zenoh,
//! with no ROS installation (see the guide's "ROS 2" page).
//!
//! Sensor topics come in through the same `[[sensor]] topic = …` map and CDR
//! decoder that bags use ([`fusion_shared::ros::LiveReader`]) and go to fusiond
//! as samples; fusiond's snapshots go out as `nav_msgs/msg/Odometry` of
//! `base_link`, TF `odom → base_link` and `diagnostic_msgs/msg/DiagnosticArray`.

pub mod clock;
pub mod diagnostics;
pub mod input;
pub mod node;
pub mod odometry;
pub mod rmw_zenoh;

/// A publisher of messages of type `M`, on either middleware.
pub trait Sink<M>: Send + Sync {
    /// Publishes `message`.
    fn put(&self, message: &M) -> anyhow::Result<()>;
    /// Messages published.
    fn sent(&self) -> u64;
}
pub mod dds;
pub mod settings;
