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

use std::io::IsTerminal;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::{CommandFactory, Parser, ValueEnum};
use fusion_shared::SampleKind;
use fusion_shared::service::{self, ServiceNames};
use zenoh::{Session, Wait};

#[cfg(target_endian = "big")]
compile_error!("fusion-bridge sends the wire types' little-endian bytes");

mod streams;

use streams::{Counts, Keys, samples_in, samples_out, state_in, state_out};

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

fn run(cli: Cli, args: Checked) -> anyhow::Result<()> {
    let Checked { names, kinds, status_interval, zenoh, keys } = args;
    let session = zenoh::open(zenoh).wait().map_err(|e| anyhow::anyhow!("cannot open the Zenoh session: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop)).context("cannot install signal handler")?;
    }
    let streams = start_streams(&cli, &names.namespace, kinds, &keys, &session, &stop)?;
    tracing::info!(
        namespace = %names.namespace,
        zenoh_id = %session.zid(),
        listen = ?cli.listen,
        connect = ?cli.connect,
        "fusion-bridge running: {}",
        streams.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
    );
    watch(&cli, status_interval, &session, &streams, &stop);
    let result = join(streams);
    let _ = session.close().wait();
    result
}

/// Starts a thread per stream the directions ask for (`--state`, `--samples`),
/// between iceoryx2 in `namespace` and Zenoh at `keys`.
fn start_streams(
    cli: &Cli,
    namespace: &str,
    kinds: Vec<SampleKind>,
    keys: &Keys,
    session: &Session,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<Vec<Stream>> {
    let mut streams: Vec<Stream> = Vec::new();
    let mut spawn = |name: &'static str, body: StreamBody| {
        let counts = Arc::new(Counts::default());
        let mine = Arc::clone(&counts);
        let thread = std::thread::Builder::new().name(format!("bridge-{name}")).spawn(move || body(&mine));
        thread.map(|t| streams.push((name, counts, t)))
    };
    let (ns, s) = (namespace.to_string(), Arc::clone(stop));
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
    let (ns, s) = (namespace.to_string(), Arc::clone(stop));
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
    Ok(streams)
}

/// Until `stop`: says when the Zenoh peers change, when `--connect` reaches
/// none, each stream's counts every `status_interval`, and stops every stream
/// when one ends by itself (only an error ends one).
fn watch(cli: &Cli, status_interval: Duration, session: &Session, streams: &[Stream], stop: &AtomicBool) {
    let mut next_status = Instant::now() + status_interval;
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
            tracing::error!("stream {name} stopped");
        }
        if Instant::now() >= next_status {
            next_status += status_interval;
            for (name, counts, _) in streams {
                tracing::info!("{name}: {}; zenoh peers {peers}", counts.line());
            }
        }
    }
}

/// Waits for every stream's thread, says its final counts, and returns the
/// last error a stream ended with.
fn join(streams: Vec<Stream>) -> anyhow::Result<()> {
    let mut result = Ok(());
    for (name, counts, thread) in streams {
        let outcome = thread.join().map_err(|_| anyhow::anyhow!("stream {name} panicked")).and_then(|r| r);
        tracing::info!("{name}: {}", counts.line());
        if let Err(e) = outcome {
            result = Err(e.context(format!("stream {name}")));
        }
    }
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
