//! fusion-ros's ROS 2 node on Zenoh: its session (rmw_zenoh's defaults), its
//! liveliness tokens, and publishers that attach what rmw_zenoh attaches.

use std::sync::atomic::{AtomicU64, Ordering};

use serde::Serialize;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::{Session, Wait};

use crate::rmw_zenoh::{Attachment, EntityKind, Node, Qos, TopicType, gid, topic_key, topic_key_any_type};
use crate::settings::RosSettings;

/// The Zenoh transports this build has.
pub const TRANSPORTS: &[&str] = &["tcp"];

/// The session's configuration: rmw_zenoh's (`DEFAULT_RMW_ZENOH_SESSION_CONFIG`):
/// a peer that connects to the router and listens on `[ros] listen`, with
/// gossip scouting and, unless `[ros] multicast_scouting`, no multicast.
pub fn zenoh_config(ros: &RosSettings) -> anyhow::Result<zenoh::Config> {
    let mut config = zenoh::Config::default();
    let set = |config: &mut zenoh::Config, key: &str, value: String| {
        config.insert_json5(key, &value).map_err(|e| anyhow::anyhow!("zenoh config {key}: {e}"))
    };
    set(&mut config, "mode", "\"peer\"".into())?;
    for (key, endpoints) in [("connect/endpoints", &ros.connect), ("listen/endpoints", &ros.listen)] {
        for e in endpoints {
            let endpoint =
                e.parse::<zenoh::config::EndPoint>().map_err(|err| anyhow::anyhow!("endpoint {e:?}: {err}"))?;
            let protocol = endpoint.protocol();
            anyhow::ensure!(
                TRANSPORTS.contains(&protocol.as_str()),
                "endpoint {e:?}: transport {protocol} is not built in (this build has: {})",
                TRANSPORTS.join(", ")
            );
        }
        set(&mut config, key, serde_json::to_string(endpoints)?)?;
    }
    set(&mut config, "scouting/multicast/enabled", ros.multicast_scouting.to_string())?;
    // The router may come later: open at once, connect when it is there.
    set(&mut config, "open/return_conditions/connect_scouted", "false".into())?;
    set(&mut config, "connect/exit_on_failure", "false".into())?;
    set(&mut config, "connect/timeout_ms", "0".into())?;
    Ok(config)
}

/// The node: its session, its identity and the tokens that announce it.
pub struct RosNode {
    /// The Zenoh session.
    pub session: Session,
    node: Node,
    next_id: u64,
    tokens: Vec<LivelinessToken>,
}

impl RosNode {
    /// Opens the session and announces the node.
    pub fn open(ros: &RosSettings, domain: u32) -> anyhow::Result<Self> {
        let session = zenoh::open(zenoh_config(ros)?)
            .wait()
            .map_err(|e| anyhow::anyhow!("cannot open the Zenoh session: {e}"))?;
        let node = Node {
            domain,
            zid: session.zid().to_string(),
            id: 0,
            enclave: "/".into(),
            namespace: ros.namespace.clone(),
            name: ros.node.clone(),
        };
        let mut me = Self { session, node, next_id: 1, tokens: Vec::new() };
        let token = me.node.token();
        me.declare(&token)?;
        Ok(me)
    }

    /// The node as its tokens name it.
    pub fn node(&self) -> &Node {
        &self.node
    }

    fn declare(&mut self, token: &str) -> anyhow::Result<()> {
        let t = self
            .session
            .liveliness()
            .declare_token(token.to_string())
            .wait()
            .map_err(|e| anyhow::anyhow!("liveliness token {token}: {e}"))?;
        self.tokens.push(t);
        Ok(())
    }

    fn endpoint(&mut self, kind: EntityKind, topic: &str, ty: &TopicType, qos: Qos) -> anyhow::Result<String> {
        let id = self.next_id;
        self.next_id += 1;
        let token = self.node.endpoint_token(id, kind, topic, ty, qos);
        self.declare(&token)?;
        Ok(token)
    }

    /// A publisher of `topic`, announced with `qos` (Zenoh's links are
    /// reliable; a full queue drops rather than blocks, as rmw_zenoh does for
    /// keep-last).
    pub fn publisher(&mut self, topic: &str, ty: &TopicType, qos: Qos) -> anyhow::Result<RosPublisher> {
        let token = self.endpoint(EntityKind::Publisher, topic, ty, qos)?;
        let key = topic_key(self.node.domain, topic, ty);
        let publisher = self
            .session
            .declare_publisher(key.clone())
            .congestion_control(CongestionControl::Drop)
            .wait()
            .map_err(|e| anyhow::anyhow!("publisher {key}: {e}"))?;
        Ok(RosPublisher { publisher, gid: gid(&token), sequence: AtomicU64::new(0) })
    }

    /// A subscription to `topic`, announced as of type `ty`, receiving every
    /// type on it (`<domain>/<topic>/*/*`): `callback` gets each sample.
    pub fn subscribe(
        &mut self,
        topic: &str,
        ty: &TopicType,
        qos: Qos,
        callback: impl Fn(zenoh::sample::Sample) + Send + Sync + 'static,
    ) -> anyhow::Result<Subscriber<()>> {
        self.endpoint(EntityKind::Subscription, topic, ty, qos)?;
        let key = topic_key_any_type(self.node.domain, topic);
        self.session
            .declare_subscriber(key.clone())
            .callback(callback)
            .wait()
            .map_err(|e| anyhow::anyhow!("subscriber {key}: {e}"))
    }
}

/// A publisher that attaches its sequence number, the wall time and its GID
/// to every message, as rmw_zenoh does.
pub struct RosPublisher {
    publisher: Publisher<'static>,
    gid: [u8; 16],
    sequence: AtomicU64,
}

impl<T: Serialize> crate::Sink<T> for RosPublisher {
    /// Publishes `message` in CDR.
    fn put(&self, message: &T) -> anyhow::Result<()> {
        let sequence_number = self.sequence.fetch_add(1, Ordering::Relaxed) as i64 + 1;
        let wall = fusion_shared::time::now_ns() + fusion_shared::time::wall_minus_monotonic_ns();
        let attachment = Attachment { sequence_number, source_timestamp_ns: wall as i64, gid: self.gid };
        self.publisher
            .put(fusion_shared::ros::ros2::to_cdr(message))
            .attachment(attachment.to_bytes())
            .wait()
            .map_err(|e| anyhow::anyhow!("publishing on {}: {e}", self.publisher.key_expr()))
    }

    fn sent(&self) -> u64 {
        self.sequence.load(Ordering::Relaxed)
    }
}
