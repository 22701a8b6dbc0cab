//! `fusion-bridge`: fusiond's streams between this host's iceoryx2 services and
//! Zenoh, so that processes on other computers use the same client API against
//! their own bridge.
//!
//! ```text
//! host A (fusiond)                                   host B (readers, sensors)
//! fusiond ── <ns>/state ──► bridge --state out ══ Zenoh ══► bridge --state in ──► <ns>/state ──► readers
//! fusiond ◄─ <ns>/<kind> ── bridge --samples in ◄═ Zenoh ══ bridge --samples out ◄─ <ns>/<kind> ◄── sensors
//! ```
//!
//! Zenoh keys: `<prefix>/<ns>/state` and `<prefix>/<ns>/samples/<kind>`. Each
//! message is the wire type's bytes (`#[repr(C)]`, little-endian), encoded
//! `application/octet-stream;<versioned type name>`: a bridge refuses, counts and
//! names a message of another type name or size (another fusiond version), and
//! forwards nothing of it. Every stream runs on a thread of its own with its own
//! iceoryx2 node; Zenoh delivers in order and reliably, with `Block` congestion
//! control (a slow network slows the bridge, never drops a snapshot).
//!
//! Sample timestamps are CLOCK_MONOTONIC of the host that made them: forward
//! samples only between hosts whose clocks agree (fusiond judges lateness on its
//! own clock). Snapshots carry their times as data and can go anywhere.

use std::collections::HashMap;
use std::io::IsTerminal;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::{CommandFactory, Parser, ValueEnum};
use fusion_client::{Client, SampleSubscriber, SensorPublishers};
use fusion_shared::service::{self, ServiceNames};
use fusion_shared::{KindFn, KindVisitor, PayloadFn, Sample, SampleKind, StateSnapshot, WireSample};
use iceoryx2::prelude::ZeroCopySend;
use zenoh::Wait;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;

#[cfg(target_endian = "big")]
compile_error!("fusion-bridge sends the wire types' little-endian bytes");

#[derive(Parser)]
#[command(
    name = "fusion-bridge",
    version,
    about = "Forward fusiond's snapshots and samples between iceoryx2 and Zenoh"
)]
struct Cli {
    /// Namespace of the local services.
    #[arg(long, default_value = service::DEFAULT_NAMESPACE, value_parser = service::namespace_arg)]
    namespace: String,
    /// Zenoh endpoint to listen on (repeatable), e.g. `tcp/0.0.0.0:7447`.
    #[arg(long)]
    listen: Vec<String>,
    /// Zenoh endpoint of another bridge to connect to (repeatable), e.g. `tcp/10.0.0.2:7447`.
    #[arg(long)]
    connect: Vec<String>,
    /// The snapshot stream: `out` on fusiond's host (local snapshots to Zenoh),
    /// `in` on a reader's host (Zenoh to a local `<ns>/state`).
    #[arg(long, value_enum, default_value_t = Direction::Off)]
    state: Direction,
    /// The sample streams: `out` on the sensors' host, `in` on fusiond's host.
    #[arg(long, value_enum, default_value_t = Direction::Off)]
    samples: Direction,
    /// The kinds `--samples` forwards (comma-separated; every kind when not given).
    #[arg(long, value_delimiter = ',')]
    kinds: Vec<String>,
    /// Readers the local `<ns>/state` of `--state in` admits.
    #[arg(long, default_value_t = service::MAX_STATE_SUBSCRIBERS)]
    max_readers: usize,
    /// First part of every Zenoh key.
    #[arg(long, default_value = "fusion")]
    key_prefix: String,
    /// Also find peers by Zenoh's multicast scouting (off: only the endpoints given).
    #[arg(long)]
    scouting: bool,
    /// Seconds between status lines (info level).
    #[arg(long, default_value_t = 10.0)]
    status_interval: f64,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Direction {
    Off,
    /// Local iceoryx2 to Zenoh.
    Out,
    /// Zenoh to local iceoryx2.
    In,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=warn")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    let cli = Cli::parse();
    // Invalid arguments are a usage error (status 2) before anything starts.
    let args = check(&cli).unwrap_or_else(|e| {
        Cli::command()
            .error(clap::error::ErrorKind::ValueValidation, fusion_shared::exit::error_line(e.as_ref()))
            .exit()
    });
    match run(cli, args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusion-bridge: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::FAILURE)
        }
    }
}

/// The arguments, checked.
struct Checked {
    names: ServiceNames,
    kinds: Vec<SampleKind>,
    status_interval: Duration,
    zenoh: zenoh::Config,
    keys: Keys,
}

/// Checks every argument without starting anything.
fn check(cli: &Cli) -> anyhow::Result<Checked> {
    let names = ServiceNames::new(&cli.namespace)?;
    anyhow::ensure!(
        cli.state != Direction::Off || cli.samples != Direction::Off,
        "nothing to forward: give --state in|out and/or --samples in|out"
    );
    anyhow::ensure!(
        cli.scouting || !cli.listen.is_empty() || !cli.connect.is_empty(),
        "no peers: give --listen and/or --connect endpoints (or --scouting)"
    );
    let kinds: Vec<SampleKind> = if cli.kinds.is_empty() {
        SampleKind::ALL.to_vec()
    } else {
        cli.kinds
            .iter()
            .map(|k| SampleKind::from_name(k).with_context(|| format!("--kinds: unknown sample kind {k:?}")))
            .collect::<anyhow::Result<_>>()?
    };
    let status_interval = Duration::try_from_secs_f64(cli.status_interval)
        .ok()
        .filter(|d| !d.is_zero())
        .context("--status-interval must be a positive number of seconds")?;
    let keys = Keys { prefix: format!("{}/{}", cli.key_prefix, names.namespace) };
    zenoh::key_expr::KeyExpr::try_from(keys.state())
        .map_err(|e| anyhow::anyhow!("--key-prefix {:?}: {e}", cli.key_prefix))?;
    Ok(Checked { names, kinds, status_interval, zenoh: zenoh_config(cli)?, keys })
}

/// What one stream did, for the status lines and the last line.
#[derive(Default)]
struct Counts {
    forwarded: AtomicU64,
    refused: AtomicU64,
    /// `--state in`: snapshots missing from the sequence (the exporting side
    /// lagged behind fusiond, or the bridge restarted).
    gaps: AtomicU64,
}

impl Counts {
    fn line(&self) -> String {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        format!("forwarded {}, refused {}, gaps {}", get(&self.forwarded), get(&self.refused), get(&self.gaps))
    }
}

fn run(cli: Cli, args: Checked) -> anyhow::Result<()> {
    let Checked { names, kinds, status_interval, zenoh, keys } = args;
    let session = zenoh::open(zenoh).wait().map_err(|e| anyhow::anyhow!("cannot open the Zenoh session: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop)).context("cannot install signal handler")?;
    }
    let mut streams: Vec<Stream> = Vec::new();
    let mut spawn = |name: &'static str, body: StreamBody| {
        let counts = Arc::new(Counts::default());
        let mine = Arc::clone(&counts);
        let thread = std::thread::Builder::new().name(format!("bridge-{name}")).spawn(move || body(&mine));
        thread.map(|t| streams.push((name, counts, t)))
    };
    let (ns, s) = (names.namespace.clone(), Arc::clone(&stop));
    match cli.state {
        Direction::Out => {
            let (z, key) = (session.clone(), keys.state());
            spawn("state out", Box::new(move |c| state_out(&ns, &z, &key, &s, c)))?;
        }
        Direction::In => {
            let (z, key, readers) = (session.clone(), keys.state(), cli.max_readers);
            spawn("state in", Box::new(move |c| state_in(&ns, readers, &z, &key, &s, c)))?;
        }
        Direction::Off => {}
    }
    let (ns, s) = (names.namespace.clone(), Arc::clone(&stop));
    match cli.samples {
        Direction::Out => {
            let (z, keys) = (session.clone(), keys.clone());
            spawn("samples out", Box::new(move |c| samples_out(&ns, &kinds, &z, &keys, &s, c)))?;
        }
        Direction::In => {
            let (z, keys) = (session.clone(), keys.clone());
            spawn("samples in", Box::new(move |c| samples_in(&ns, &kinds, &z, &keys, &s, c)))?;
        }
        Direction::Off => {}
    }
    tracing::info!(
        namespace = %names.namespace,
        zenoh_id = %session.zid(),
        listen = ?cli.listen,
        connect = ?cli.connect,
        "fusion-bridge running: {}",
        streams.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
    );

    let mut next_status = Instant::now() + status_interval;
    let mut result = Ok(());
    let mut peers = 0;
    // While --connect endpoints reach no peer, say so (Zenoh keeps retrying
    // them in silence; the status lines only ever said "forwarded 0").
    let mut next_unreached = Instant::now() + UNREACHED_WARNING;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(20));
        let now = session.info().peers_zid().wait().count();
        if now != peers {
            tracing::info!("zenoh peers: {now}");
            peers = now;
        }
        if peers == 0 && !cli.connect.is_empty() && Instant::now() >= next_unreached {
            tracing::warn!(
                connect = ?cli.connect,
                "no Zenoh peer reached after {:.0} s: is the other bridge running and listening at the --connect \
                 endpoints, and can this host reach them? Retrying.",
                UNREACHED_WARNING.as_secs_f64()
            );
            next_unreached = Instant::now() + UNREACHED_REPEAT;
        }
        if let Some((name, _, _)) = streams.iter().find(|s| s.2.is_finished())
            && !stop.swap(true, Ordering::Relaxed)
        {
            // A stream ends by itself only on an error (reported below): stop the others.
            tracing::error!("stream {name} stopped");
        }
        if Instant::now() >= next_status {
            next_status += status_interval;
            for (name, counts, _) in &streams {
                tracing::info!("{name}: {}; zenoh peers {peers}", counts.line());
            }
        }
    }
    for (name, counts, thread) in streams {
        let outcome = thread.join().map_err(|_| anyhow::anyhow!("stream {name} panicked")).and_then(|r| r);
        tracing::info!("{name}: {}", counts.line());
        if let Err(e) = outcome {
            result = Err(e.context(format!("stream {name}")));
        }
    }
    let _ = session.close().wait();
    result
}

/// How long `--connect` endpoints may reach no peer before the bridge says so.
const UNREACHED_WARNING: Duration = Duration::from_secs(5);
/// How often it says so again while none is reached.
const UNREACHED_REPEAT: Duration = Duration::from_secs(30);

/// A running stream: its name, counts and thread.
type Stream = (&'static str, Arc<Counts>, std::thread::JoinHandle<anyhow::Result<()>>);
/// What a stream's thread runs.
type StreamBody = Box<dyn FnOnce(&Counts) -> anyhow::Result<()> + Send>;

/// The Zenoh keys of one namespace.
#[derive(Clone)]
struct Keys {
    /// `<prefix>/<ns>`.
    prefix: String,
}

impl Keys {
    fn state(&self) -> String {
        format!("{}/state", self.prefix)
    }

    fn samples(&self, kind: SampleKind) -> String {
        format!("{}/samples/{}", self.prefix, kind.name())
    }
}

/// The Zenoh transports this build has (the `zenoh` crate's `transport_*` features).
const TRANSPORTS: &[&str] = &["tcp"];

/// The Zenoh configuration: a peer with exactly the endpoints given, each
/// checked (multicast scouting only with `--scouting`).
fn zenoh_config(cli: &Cli) -> anyhow::Result<zenoh::Config> {
    let mut config = zenoh::Config::default();
    let set = |config: &mut zenoh::Config, key: &str, value: String| {
        config.insert_json5(key, &value).map_err(|e| anyhow::anyhow!("zenoh config {key}: {e}"))
    };
    set(&mut config, "mode", "\"peer\"".into())?;
    for (key, endpoints) in [("listen/endpoints", &cli.listen), ("connect/endpoints", &cli.connect)] {
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
    set(&mut config, "scouting/multicast/enabled", cli.scouting.to_string())?;
    // Opening does not wait for the peers (Zenoh then warns "Scouting delay
    // elapsed" at every start without one): the bridge connects as they come
    // and names the `--connect` endpoints that reach none itself.
    set(&mut config, "open/return_conditions/connect_scouted", "false".into())?;
    Ok(config)
}

/// The encoding of wire type `T`: `application/octet-stream;<type name>`.
fn encoding<T: ZeroCopySend>() -> Encoding {
    // SAFETY: only reads the name the type declares.
    Encoding::APPLICATION_OCTET_STREAM.with_schema(unsafe { <T as ZeroCopySend>::type_name() })
}

/// A Zenoh publisher of wire type `T` on `key`: its encoding, reliable, `Block`.
fn declare_publisher<T: ZeroCopySend>(
    session: &zenoh::Session,
    key: String,
) -> anyhow::Result<zenoh::pubsub::Publisher<'static>> {
    let declared =
        session.declare_publisher(key.clone()).encoding(encoding::<T>()).congestion_control(CongestionControl::Block);
    declared.wait().map_err(|e| anyhow::anyhow!("Zenoh publisher {key}: {e}"))
}

/// The bytes of a wire value.
fn bytes_of<T: ZeroCopySend + Copy>(value: &T) -> &[u8] {
    // SAFETY: the wire types are `#[repr(C)]` integers and floats without
    // padding (their sizes are asserted; daemon/tests/python_client.rs checks
    // that the fields fill them), so every byte is initialised.
    unsafe { std::slice::from_raw_parts((value as *const T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// Puts a sample's payload, as its wire type's bytes, on a Zenoh publisher.
struct Put<'a>(&'a zenoh::pubsub::Publisher<'static>);

impl PayloadFn for Put<'_> {
    type Output = zenoh::Result<()>;
    fn call<T: WireSample>(self, payload: &T) -> zenoh::Result<()> {
        self.0.put(bytes_of(payload)).wait()
    }
}

/// Decodes a message as the wire type of the kind its key names.
struct Decode<'a>(&'a zenoh::sample::Sample);

impl KindFn for Decode<'_> {
    type Output = Result<Sample, String>;
    fn call<T: WireSample>(self) -> Result<Sample, String> {
        decode::<T>(self.0).map(T::into_sample)
    }
}

/// A wire value from a message, or why it is refused.
fn decode<T: ZeroCopySend + Copy + Default>(sample: &zenoh::sample::Sample) -> Result<T, String> {
    if *sample.encoding() != encoding::<T>() {
        return Err(format!("encoding {} (expected {})", sample.encoding(), encoding::<T>()));
    }
    let bytes = sample.payload().to_bytes();
    if bytes.len() != std::mem::size_of::<T>() {
        return Err(format!("{} bytes (expected {})", bytes.len(), std::mem::size_of::<T>()));
    }
    let mut value = T::default();
    // SAFETY: `bytes` has the size of `T`, and every bit pattern is a valid
    // wire value (integers and floats only).
    unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), (&mut value as *mut T).cast::<u8>(), bytes.len()) };
    Ok(value)
}

/// Counts a refused message; logs the first one of each reason.
fn refuse(counts: &Counts, logged: &mut Vec<String>, key: &str, reason: String) {
    counts.refused.fetch_add(1, Ordering::Relaxed);
    if !logged.contains(&reason) && logged.len() < 16 {
        tracing::warn!("refused a message on {key}: {reason}");
        logged.push(reason);
    }
}

/// Waits for fusiond's `<ns>/state` (the bridge may start first).
fn state_reader(client: &Client, stop: &AtomicBool) -> anyhow::Result<Option<fusion_client::StateSubscriber>> {
    let mut said = false;
    while !stop.load(Ordering::Relaxed) {
        match client.state_subscriber_with_buffer(service::STATE_BUFFER) {
            Ok(reader) => return Ok(Some(reader)),
            Err(fusion_client::ClientError::DaemonNotRunning { namespace }) => {
                if !std::mem::replace(&mut said, true) {
                    tracing::info!("waiting for fusiond in namespace {namespace:?}");
                }
                std::thread::sleep(Duration::from_millis(100));
            }
            Err(e) => return Err(e.into()),
        }
    }
    Ok(None)
}

/// fusiond's snapshots to Zenoh, every one in order.
fn state_out(ns: &str, session: &zenoh::Session, key: &str, stop: &AtomicBool, counts: &Counts) -> anyhow::Result<()> {
    let client = Client::connect(ns)?;
    let publisher = declare_publisher::<StateSnapshot>(session, key.to_string())?;
    let Some(mut reader) = state_reader(&client, stop)? else { return Ok(()) };
    while !stop.load(Ordering::Relaxed) {
        if let Some(snapshot) = reader.wait_next(Duration::from_millis(100))? {
            publisher.put(bytes_of(snapshot)).wait().map_err(|e| anyhow::anyhow!("Zenoh put {key}: {e}"))?;
            counts.forwarded.fetch_add(1, Ordering::Relaxed);
        }
    }
    Ok(())
}

/// Snapshots from Zenoh to a local `<ns>/state`, as fusiond publishes them.
fn state_in(
    ns: &str,
    max_readers: usize,
    session: &zenoh::Session,
    key: &str,
    stop: &AtomicBool,
    counts: &Counts,
) -> anyhow::Result<()> {
    let names = ServiceNames::new(ns)?;
    let config = service::iceoryx_config(None).map_err(anyhow::Error::msg)?;
    let node = service::create_node(&format!("fusion-bridge.{ns}"), &config).map_err(anyhow::Error::msg)?;
    let state = service::state_service(&node, &names, Some(max_readers))?;
    let publisher = state.publisher_builder().create().map_err(|e| {
        anyhow::anyhow!("cannot publish {}: {e:?} (a fusiond or another bridge publishes it here)", names.state)
    })?;
    let event = service::event_service(&node, &names.state)?;
    let notifier = event.notifier_builder().create().map_err(|e| anyhow::anyhow!("{} notifier: {e:?}", names.state))?;
    let subscriber = session.declare_subscriber(key.to_string()).wait().map_err(|e| anyhow::anyhow!("{key}: {e}"))?;
    let mut logged = Vec::new();
    let mut last_seq: Option<u64> = None;
    while !stop.load(Ordering::Relaxed) {
        let Ok(Some(message)) = subscriber.recv_timeout(Duration::from_millis(100)) else { continue };
        let snapshot = match decode::<StateSnapshot>(&message) {
            Ok(s) => s,
            Err(reason) => {
                refuse(counts, &mut logged, key, reason);
                continue;
            }
        };
        // A fusiond that restarted counts from 0 again; only a forward jump is a gap.
        if let Some(last) = last_seq
            && snapshot.seq > last + 1
        {
            counts.gaps.fetch_add(snapshot.seq - last - 1, Ordering::Relaxed);
        }
        last_seq = Some(snapshot.seq);
        publisher.send_copy(snapshot).map_err(|e| anyhow::anyhow!("send on {}: {e:?}", names.state))?;
        let _ = notifier.notify();
        counts.forwarded.fetch_add(1, Ordering::Relaxed);
    }
    drop((publisher, notifier, state, event, node));
    service::remove_domain_counter_if_last(&config);
    Ok(())
}

/// The local sensors' samples of `kinds` to Zenoh, woken by `<ns>/wake`.
fn samples_out(
    ns: &str,
    kinds: &[SampleKind],
    session: &zenoh::Session,
    keys: &Keys,
    stop: &AtomicBool,
    counts: &Counts,
) -> anyhow::Result<()> {
    struct Declare<'a> {
        session: &'a zenoh::Session,
        keys: &'a Keys,
        kinds: &'a [SampleKind],
        publishers: HashMap<SampleKind, zenoh::pubsub::Publisher<'static>>,
        error: Option<anyhow::Error>,
    }
    impl KindVisitor for Declare<'_> {
        fn visit<T: WireSample>(&mut self) {
            if !self.kinds.contains(&T::KIND) || self.error.is_some() {
                return;
            }
            match declare_publisher::<T>(self.session, self.keys.samples(T::KIND)) {
                Ok(p) => drop(self.publishers.insert(T::KIND, p)),
                Err(e) => self.error = Some(e),
            }
        }
    }
    let mut declare = Declare { session, keys, kinds, publishers: HashMap::new(), error: None };
    SampleKind::visit_all(&mut declare);
    if let Some(e) = declare.error {
        return Err(e);
    }
    let client = Client::connect(ns)?;
    let mut reader: SampleSubscriber = client.sample_subscriber()?;
    let names = client.names().clone();
    let config = service::iceoryx_config(None).map_err(anyhow::Error::msg)?;
    let node = service::create_node(&format!("fusion-bridge.{ns}"), &config).map_err(anyhow::Error::msg)?;
    let wake = service::event_service(&node, &names.wake)?;
    let listener = wake.listener_builder().create().map_err(|e| anyhow::anyhow!("{} listener: {e:?}", names.wake))?;
    while !stop.load(Ordering::Relaxed) {
        while let Some(sample) = reader.try_next()? {
            let Some(publisher) = declare.publishers.get(&sample.kind()) else { continue };
            sample
                .with_payload(Put(publisher))
                .map_err(|e| anyhow::anyhow!("Zenoh put {}: {e}", keys.samples(sample.kind())))?;
            counts.forwarded.fetch_add(1, Ordering::Relaxed);
        }
        // Sensors notify <ns>/wake after each sample; the timeout bounds the
        // delay of one that does not.
        let _ = listener.timed_wait(|_| {}, service::listener_timeout(Duration::from_millis(10)));
    }
    Ok(())
}

/// Samples of `kinds` from Zenoh to the local sample services (fusiond's input).
fn samples_in(
    ns: &str,
    kinds: &[SampleKind],
    session: &zenoh::Session,
    keys: &Keys,
    stop: &AtomicBool,
    counts: &Counts,
) -> anyhow::Result<()> {
    let client = Client::connect(ns)?;
    let mut publishers = SensorPublishers::default();
    for &kind in kinds {
        publishers.open(&client, kind, 0)?;
    }
    let all = format!("{}/samples/*", keys.prefix);
    let subscriber = session.declare_subscriber(all.clone()).wait().map_err(|e| anyhow::anyhow!("{all}: {e}"))?;
    let mut logged = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let Ok(Some(message)) = subscriber.recv_timeout(Duration::from_millis(100)) else { continue };
        let key = message.key_expr().as_str().to_string();
        let kind = key.rsplit('/').next().and_then(SampleKind::from_name).filter(|k| kinds.contains(k));
        let Some(kind) = kind else {
            refuse(counts, &mut logged, &key, "not a forwarded sample kind".into());
            continue;
        };
        match kind.with_wire_type(Decode(&message)) {
            Ok(sample) => {
                publishers.publish(sample)?;
                counts.forwarded.fetch_add(1, Ordering::Relaxed);
            }
            Err(reason) => refuse(counts, &mut logged, &key, reason),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use fusion_shared::ImuSample;

    use super::*;

    #[test]
    fn wire_values_round_trip_and_other_versions_are_refused() {
        let imu = ImuSample::new(5, 1, 2, [1.0, 2.0, 3.0], [4.0, 5.0, f64::NAN]);
        let bytes = bytes_of(&imu);
        assert_eq!(bytes.len(), 80);
        let message = |payload: &[u8], enc: Encoding| {
            let key = zenoh::key_expr::KeyExpr::try_from("fusion/ns/samples/imu".to_string()).unwrap();
            zenoh::sample::SampleBuilder::put(key, payload.to_vec()).encoding(enc).into()
        };
        let back: ImuSample = decode(&message(bytes, encoding::<ImuSample>())).unwrap();
        assert_eq!(bytes_of(&back), bytes);
        let wrong = Encoding::APPLICATION_OCTET_STREAM.with_schema("fusion.ImuSample.v1");
        assert!(decode::<ImuSample>(&message(bytes, wrong)).unwrap_err().contains("fusion.ImuSample.v1"));
        assert!(decode::<ImuSample>(&message(&bytes[..79], encoding::<ImuSample>())).unwrap_err().contains("79 bytes"));
    }
}
