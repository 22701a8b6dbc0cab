//! `fusionctl foxglove`: serves a running fusiond live over the Foxglove
//! WebSocket protocol (the `foxglove` SDK), on the topics and with the JSON
//! messages of a recording (`fusion_shared::recording`): the estimate as
//! `foxglove.PoseInFrame` and, once a datum is set, `foxglove.LocationFix`; the
//! full snapshot (health, reasons, counters, x, P); every input sample (the
//! fixes). Open it in the Foxglove app with "Open connection" to
//! `ws://HOST:PORT`; Lichtblick and older Foxglove Studio, which offer the
//! protocol's older subprotocol name, are served too ([`front`]).

mod front;

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use fusion_client::{Client, ClientError, SampleKind};
use fusion_shared::recording::{self, SnapshotJson};
use fusion_shared::snapshot::INPUT_NONE;

fn channel(topic: &str, schema_name: &str, schema: String) -> anyhow::Result<Arc<foxglove::RawChannel>> {
    let schema = foxglove::Schema::new(schema_name, recording::SCHEMA_ENCODING, schema.into_bytes());
    Ok(foxglove::ChannelBuilder::new(topic).message_encoding(recording::MESSAGE_ENCODING).schema(schema).build_raw()?)
}

/// The channels served: the snapshots, the pose, the location and each kind's samples.
struct Channels {
    state: Arc<foxglove::RawChannel>,
    pose: Arc<foxglove::RawChannel>,
    location: Arc<foxglove::RawChannel>,
    kinds: HashMap<SampleKind, Arc<foxglove::RawChannel>>,
    /// The pose and location timestamps are shown as dates (the SDK stamps
    /// its log times with the wall clock itself).
    wall_offset: u64,
}

impl Channels {
    fn new() -> anyhow::Result<Self> {
        let state = channel(recording::STATE_TOPIC, recording::STATE_SCHEMA, recording::state_schema())?;
        let pose = channel(recording::POSE_TOPIC, recording::POSE_SCHEMA, recording::POSE_IN_FRAME_JSON_SCHEMA.into())?;
        let location =
            channel(recording::LOCATION_TOPIC, recording::LOCATION_SCHEMA, recording::LOCATION_FIX_JSON_SCHEMA.into())?;
        let mut kinds = HashMap::new();
        for &kind in SampleKind::ALL {
            let (name, schema) = recording::sample_schema(kind);
            kinds.insert(kind, channel(&recording::sample_topic(kind), &name, schema)?);
        }
        let wall_offset = fusion_shared::time::wall_minus_monotonic_ns();
        Ok(Self { state, pose, location, kinds, wall_offset })
    }

    /// Logs a snapshot to the channels that have sinks: itself, and the pose
    /// and location of one that a sample made.
    fn snapshot(&self, s: &fusion_client::StateSnapshot, buf: &mut Vec<u8>) -> anyhow::Result<()> {
        if self.state.has_sinks() {
            buf.clear();
            serde_json::to_writer(&mut *buf, &SnapshotJson::from(s))?;
            self.state.log(buf);
        }
        if s.input_kind == INPUT_NONE {
            return Ok(());
        }
        if self.pose.has_sinks() {
            self.pose.log(&serde_json::to_vec(&recording::pose_in_frame(s, self.wall_offset))?);
        }
        if self.location.has_sinks()
            && let Some(fix) = recording::location_fix(s, self.wall_offset)
        {
            self.location.log(&serde_json::to_vec(&fix)?);
        }
        Ok(())
    }
}

/// fusiond's state service once it runs; until then, says so after
/// [`NO_DAEMON_WARNING`] and every [`NO_DAEMON_REPEAT`] (`next_warning`).
fn state_reader(
    client: &Client,
    namespace: &str,
    started: std::time::Instant,
    next_warning: &mut std::time::Instant,
) -> anyhow::Result<Option<fusion_client::StateSubscriber>> {
    match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
        Ok(r) => {
            if std::time::Instant::now() >= started + NO_DAEMON_WARNING {
                eprintln!("fusionctl foxglove: fusiond is running in namespace {namespace:?} now: serving it");
            }
            Ok(Some(r))
        }
        Err(ClientError::DaemonNotRunning { .. }) => {
            if std::time::Instant::now() >= *next_warning {
                eprintln!(
                    "fusionctl foxglove: no fusiond runs in namespace {namespace:?} after {:.0} s: serving \
                     nothing but the samples published there; waiting for fusiond (is the namespace right? \
                     `fusionctl state --namespace NS` asks one)",
                    started.elapsed().as_secs_f64()
                );
                *next_warning += NO_DAEMON_REPEAT;
            }
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// How long the server waits for fusiond before it says none runs.
const NO_DAEMON_WARNING: Duration = Duration::from_secs(2);
/// How often it says so again while none runs.
const NO_DAEMON_REPEAT: Duration = Duration::from_secs(30);

/// Serves namespace `namespace` on `host:port` (0: any free port) until `stop`;
/// says so on stderr while no fusiond runs there.
pub fn run(namespace: &str, host: &str, port: u16, stop: &AtomicBool) -> anyhow::Result<()> {
    let client = Client::connect(namespace)?;
    let mut samples = client.sample_subscriber()?;
    // The SDK's server on a local port; clients connect to the front
    // (`front`: it also serves the protocol's older subprotocol name).
    let server =
        foxglove::WebSocketServer::new().name(format!("fusiond {namespace}")).bind("127.0.0.1", 0).start_blocking()?;
    let listener =
        std::net::TcpListener::bind((host, port)).with_context(|| format!("cannot listen on {host}:{port}"))?;
    let local = listener.local_addr()?;
    let front_stop = Arc::new(AtomicBool::new(false));
    let front = {
        let (stop, backend) = (Arc::clone(&front_stop), std::net::SocketAddr::from(([127, 0, 0, 1], server.port())));
        std::thread::spawn(move || front::serve(listener, backend, stop))
    };
    // The port line is what a script (or test) waits for.
    println!("serving fusiond namespace {namespace:?} on ws://{host}:{}", local.port());
    let channels = Channels::new()?;
    let mut reader = None;
    let mut buf = Vec::with_capacity(8192);
    // While no fusiond runs in the namespace, say so after NO_DAEMON_WARNING
    // and again every NO_DAEMON_REPEAT (a wrong namespace serves nothing).
    let started = std::time::Instant::now();
    let mut next_warning = started + NO_DAEMON_WARNING;
    while !stop.load(Ordering::Relaxed) {
        let mut busy = false;
        while let Some(s) = samples.try_next()? {
            busy = true;
            let Some(channel) = channels.kinds.get(&s.kind()).filter(|c| c.has_sinks()) else { continue };
            buf.clear();
            recording::write_sample(&s, &mut buf);
            channel.log(&buf);
        }
        if reader.is_none() {
            // fusiond may start after this server.
            reader = state_reader(&client, namespace, started, &mut next_warning)?;
        }
        if let Some(reader) = &mut reader {
            while let Some(s) = reader.try_next()? {
                busy = true;
                channels.snapshot(s, &mut buf)?;
            }
        }
        if !busy {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    front_stop.store(true, Ordering::Relaxed);
    server.stop().wait_blocking();
    front.join().map_err(|_| anyhow::anyhow!("the front of the server failed"))??;
    Ok(())
}
