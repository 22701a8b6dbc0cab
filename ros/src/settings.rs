//! The `[ros]` table of fusiond's configuration file, which fusion-ros reads
//! beside the `[[sensor]] topic = …` map: one file for the robot's fusiond,
//! its bags and its ROS 2 node. Every key has a default, the ROS one where
//! ROS has one (REP-105 frames, robot_localization's topic, rmw_zenoh's
//! session).

use fusion_shared::ros::Route;
use serde::Deserialize;

/// Where ROS 2 header stamps come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClockSource {
    /// The wall clock (CLOCK_REALTIME): ROS time without `use_sim_time`.
    Wall,
    /// `/clock` (`use_sim_time`: `ros2 bag play --clock`, a simulator).
    Sim,
}

/// Which ROS 2 middleware the node speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// DDS (`rmw_fastrtps_cpp`, `rmw_cyclonedds_cpp`: ROS 2's default).
    Dds,
    /// rmw_zenoh (`rmw_zenoh_cpp`), through a Zenoh router.
    Zenoh,
}

/// `[ros]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RosSettings {
    /// The middleware: DDS (ROS 2's default) or rmw_zenoh.
    pub transport: Transport,
    /// ROS domain id; `None`: `ROS_DOMAIN_ID` from the environment, else 0.
    pub domain_id: Option<u32>,
    /// The node's name.
    pub node: String,
    /// The node's namespace.
    pub namespace: String,
    /// rmw_zenoh: Zenoh endpoints to connect to: rmw_zenoh's router
    /// (`ros2 run rmw_zenoh_cpp rmw_zenohd`) by default.
    pub connect: Vec<String>,
    /// rmw_zenoh: Zenoh endpoints to listen on (rmw_zenoh's default: any free port on
    /// localhost, for peers the router tells of).
    pub listen: Vec<String>,
    /// rmw_zenoh: Zenoh's multicast scouting (rmw_zenoh's default: off; the router
    /// finds the peers).
    pub multicast_scouting: bool,
    /// DDS: the addresses of the interfaces DDS uses (multicast joins and
    /// sends, advertised locators); empty: every interface, ROS 2's default.
    /// `["127.0.0.1"]` keeps DDS on this host (discovery by unicast to the
    /// well-known ports on 127.0.0.1).
    pub dds_interfaces: Vec<std::net::IpAddr>,
    /// Where header stamps come from.
    pub clock: ClockSource,
    /// `nav_msgs/msg/Odometry` out.
    pub odometry_topic: String,
    /// TF out (`""`: no TF).
    pub tf_topic: String,
    /// `diagnostic_msgs/msg/DiagnosticArray` out (`""`: none).
    pub diagnostics_topic: String,
    /// The odometry's frame, TF's parent (REP-105 `odom`).
    pub world_frame: String,
    /// The robot's frame, TF's child (REP-105 `base_link`).
    pub base_frame: String,
    /// `base_link`'s origin in fusiond's body frame (the IMU's), m.
    pub base_link_position_m: [f64; 3],
    /// `base_link`'s axes in the body frame, body ← base_link:
    /// Rz(yaw) Ry(pitch) Rx(roll), degrees.
    pub base_link_rotation_rpy_deg: [f64; 3],
    /// Odometry and TF per second at most (0: one per snapshot). The
    /// iceoryx2 snapshots are not decimated.
    pub rate_hz: f64,
    /// Seconds between diagnostics.
    pub diagnostics_period_s: f64,
    /// Messages per second a topic may bring; more are dropped and counted
    /// (a flood on one topic leaves the others alone).
    pub max_topic_rate_hz: f64,
    /// A topic's message type where its kinds do not say it
    /// (`"/wheel/twist" = "geometry_msgs/msg/TwistWithCovarianceStamped"`):
    /// by default a topic is read as the first type of the bag table that
    /// gives all its kinds (`odometry` or `twist` alone: `nav_msgs/msg/Odometry`).
    pub topic_types: std::collections::BTreeMap<String, String>,
}

impl Default for RosSettings {
    fn default() -> Self {
        Self {
            transport: Transport::Dds,
            domain_id: None,
            node: "fusiond".into(),
            namespace: "/".into(),
            connect: vec!["tcp/localhost:7447".into()],
            listen: vec!["tcp/localhost:0".into()],
            multicast_scouting: false,
            dds_interfaces: Vec::new(),
            clock: ClockSource::Wall,
            odometry_topic: "/odometry/filtered".into(),
            tf_topic: "/tf".into(),
            diagnostics_topic: "/diagnostics".into(),
            world_frame: "odom".into(),
            base_frame: "base_link".into(),
            base_link_position_m: [0.0; 3],
            base_link_rotation_rpy_deg: [0.0; 3],
            rate_hz: 50.0,
            diagnostics_period_s: 1.0,
            max_topic_rate_hz: 5000.0,
            topic_types: Default::default(),
        }
    }
}

/// What fusion-ros takes from a configuration file.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    /// `[ros]`.
    pub ros: RosSettings,
    /// The `[[sensor]] topic` map.
    pub routes: Vec<Route>,
}

#[derive(Deserialize)]
struct File {
    #[serde(default)]
    ros: RosSettings,
    #[serde(default)]
    sensor: Vec<SensorTopic>,
}

#[derive(Deserialize)]
struct SensorTopic {
    name: String,
    id: u32,
    kinds: Vec<String>,
    topic: Option<String>,
}

fn name_ok(what: &str, name: &str, absolute: bool) -> Result<(), String> {
    let chars_ok = name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/');
    if name.is_empty() || !chars_ok || name.contains("//") || (absolute && !name.starts_with('/')) {
        let start = if absolute { ", start with /" } else { "" };
        return Err(format!("[ros] {what} {name:?}: a ROS name has letters, digits, _ and /{start}, no //"));
    }
    Ok(())
}

impl NodeConfig {
    /// The `[ros]` table and the topic map of a configuration's text, checked.
    pub fn parse(text: &str) -> Result<Self, String> {
        let file: File = toml::from_str(text).map_err(|e| e.to_string())?;
        let r = &file.ros;
        name_ok("node", &r.node, false)?;
        name_ok("namespace", &r.namespace, true)?;
        if r.node.contains('/') {
            return Err(format!("[ros] node {:?}: a node's name has no /", r.node));
        }
        name_ok("odometry_topic", &r.odometry_topic, true)?;
        for (what, topic) in [("tf_topic", &r.tf_topic), ("diagnostics_topic", &r.diagnostics_topic)] {
            if !topic.is_empty() {
                name_ok(what, topic, true)?;
            }
        }
        for (what, frame) in [("world_frame", &r.world_frame), ("base_frame", &r.base_frame)] {
            if frame.is_empty() {
                return Err(format!("[ros] {what} is empty"));
            }
        }
        let finite = r.base_link_position_m.iter().chain(&r.base_link_rotation_rpy_deg).all(|v| v.is_finite());
        if !finite {
            return Err("[ros] base_link_position_m and base_link_rotation_rpy_deg must be finite".into());
        }
        if !(r.rate_hz.is_finite() && r.rate_hz >= 0.0) {
            return Err(format!("[ros] rate_hz {}: must be ≥ 0 (0: every snapshot)", r.rate_hz));
        }
        for (what, v) in [("diagnostics_period_s", r.diagnostics_period_s), ("max_topic_rate_hz", r.max_topic_rate_hz)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("[ros] {what} {v}: must be > 0"));
            }
        }
        if r.transport == Transport::Zenoh && r.connect.is_empty() && r.listen.is_empty() && !r.multicast_scouting {
            return Err("[ros] no Zenoh peers: give connect (the router) or listen endpoints".into());
        }
        let routes: Vec<Route> = file
            .sensor
            .iter()
            .filter_map(|s| Route::of_sensor(&s.name, s.id, &s.kinds, s.topic.as_deref()).transpose())
            .collect::<Result<_, _>>()?;
        if routes.is_empty() {
            return Err("no [[sensor]] has a topic: give each sensor the ROS topic it is read from \
                        (topic = \"/imu/data\")"
                .into());
        }
        for r in &routes {
            name_ok(&format!("[[sensor]] {:?} topic", r.name), &r.topic, true)?;
        }
        Ok(Self { ros: file.ros, routes })
    }

    /// The domain id: `[ros] domain_id`, else `ROS_DOMAIN_ID`, else 0.
    pub fn domain_id(&self) -> Result<u32, String> {
        if let Some(d) = self.ros.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => {
                v.trim().parse().map_err(|_| format!("ROS_DOMAIN_ID={v:?} is not a domain id"))
            }
            _ => Ok(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SENSORS: &str = "[[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\ntopic = \"/imu/data\"\n";

    #[test]
    fn defaults_are_the_ros_ones() {
        let c = NodeConfig::parse(SENSORS).unwrap();
        assert_eq!(c.ros, RosSettings::default());
        assert_eq!((c.ros.world_frame.as_str(), c.ros.base_frame.as_str()), ("odom", "base_link"));
        assert_eq!(c.ros.connect, ["tcp/localhost:7447"]);
        assert_eq!(c.routes.len(), 1);
    }

    #[test]
    fn bad_tables_are_named() {
        let bad = |ros: &str| NodeConfig::parse(&format!("[ros]\n{ros}\n{SENSORS}")).unwrap_err();
        assert!(bad("odometry_topic = \"odom\"").contains("start with /"));
        assert!(bad("node = \"a/b\"").contains("no /"));
        assert!(bad("rate_hz = -1").contains("rate_hz"));
        assert!(bad("colour = 1").contains("colour"));
        assert!(bad("transport = \"zenoh\"\nconnect = []\nlisten = []").contains("no Zenoh peers"));
        assert!(NodeConfig::parse("[ros]\n").unwrap_err().contains("no [[sensor]] has a topic"));
    }
}
