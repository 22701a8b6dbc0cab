//! `fusion-ros --config robot.toml`: fusiond as a node of a running ROS 2
//! robot over rmw_zenoh. The configuration's `[[sensor]] topic = …` entries
//! say which topics go to fusiond as which kinds (as for its bags), its
//! `[ros]` table where odometry, TF and diagnostics go. See the guide's
//! "ROS 2" page.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Parser;
use fusion_ros::clock::RosClock;
use fusion_ros::dds::DdsNode;
use fusion_ros::input::{InputTopic, input_topics};
use fusion_ros::node::RosNode;
use fusion_ros::settings::{ClockSource, NodeConfig, Transport};
use fusion_shared::service;
use zenoh::Wait;

mod dds_io;
mod pump;
mod zenoh_io;

use pump::{Inbound, Outputs, Shared};

#[derive(Parser)]
#[command(
    name = "fusion-ros",
    version,
    about = "fusiond as a ROS 2 node (rmw_zenoh): sensor topics in; odometry, TF and diagnostics out"
)]
struct Cli {
    /// fusiond's configuration: its `[[sensor]] topic` map and `[ros]` table.
    #[arg(long)]
    config: PathBuf,
    /// Namespace of fusiond's services.
    #[arg(long, default_value = service::DEFAULT_NAMESPACE, value_parser = service::namespace_arg)]
    namespace: String,
    /// Zenoh endpoint to connect to, in place of `[ros] connect` (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// Zenoh endpoint to listen on, in place of `[ros] listen` (repeatable).
    #[arg(long)]
    listen: Vec<String>,
    /// Seconds between status lines (info level).
    #[arg(long, default_value_t = 10.0)]
    status_interval: f64,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=warn,rustdds=warn")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusion-ros: {}", fusion_shared::exit::error_line(e.as_ref()));
            ExitCode::from(fusion_shared::exit::FAILURE)
        }
    }
}

/// The configuration with the command line's endpoints.
fn config(cli: &Cli) -> anyhow::Result<NodeConfig> {
    let text = std::fs::read_to_string(&cli.config).with_context(|| format!("cannot read {}", cli.config.display()))?;
    let mut c = NodeConfig::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", cli.config.display()))?;
    if !cli.connect.is_empty() {
        c.ros.connect = cli.connect.clone();
    }
    if !cli.listen.is_empty() {
        c.ros.listen = cli.listen.clone();
    }
    Ok(c)
}

fn run(cli: &Cli) -> anyhow::Result<()> {
    let c = config(cli)?;
    let status_interval = Duration::try_from_secs_f64(cli.status_interval)
        .ok()
        .filter(|d| !d.is_zero())
        .context("--status-interval must be a positive number of seconds")?;
    let domain = c.domain_id().map_err(|e| anyhow::anyhow!(e))?;
    let topics = input_topics(&c.routes, &c.ros.topic_types).map_err(|e| anyhow::anyhow!(e))?;
    let shared = pump::shared(RosClock::new(c.ros.clock));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        let s = Arc::clone(&shared);
        // SAFETY: the handler only stores to an atomic.
        unsafe { signal_hook::low_level::register(signal, move || s.stop.store(true, Ordering::Relaxed)) }
            .context("cannot install signal handler")?;
    }
    let (tx, rx) = crossbeam::channel::bounded::<Inbound>(INPUT_QUEUE);
    match c.ros.transport {
        Transport::Zenoh => {
            let mut node = RosNode::open(&c.ros, domain)?;
            let outputs = zenoh_io::outputs(&mut node, &c)?;
            let mut subscribers = Vec::new();
            for (i, t) in topics.iter().enumerate() {
                subscribers.push(zenoh_io::subscribe(&mut node, i, t, c.ros.max_topic_rate_hz, tx.clone(), &shared)?);
            }
            drop(tx);
            if c.ros.clock == ClockSource::Sim {
                subscribers.push(zenoh_io::subscribe_clock(&mut node, &shared)?);
            }
            announce(&c, domain, &format!("rmw_zenoh, zenoh id {}", node.session.zid()), &topics);
            pump(cli, &c, &topics, rx, &outputs, &shared, status_interval, Some(&node), |_| Ok(()));
            drop(subscribers);
            let _ = node.session.close().wait();
        }
        Transport::Dds => {
            let mut node = DdsNode::open(&c.ros.namespace, &c.ros.node, domain, &c.ros.dds_interfaces)?;
            let outputs = dds_io::outputs(&mut node, &c)?;
            let (subs, clock) = dds_io::subscriptions(&mut node, &topics, c.ros.clock == ClockSource::Sim)?;
            announce(&c, domain, "DDS", &topics);
            let (rate, tops) = (c.ros.max_topic_rate_hz, topics.clone());
            let receive = move |sh: &Shared| dds_io::receive(subs, clock, &tops, rate, tx, sh);
            pump(cli, &c, &topics, rx, &outputs, &shared, status_interval, None, receive);
        }
    }
    Ok(())
}

/// Messages queued for the input thread at most.
const INPUT_QUEUE: usize = 8192;

fn announce(c: &NodeConfig, domain: u32, middleware: &str, topics: &[InputTopic]) {
    tracing::info!(
        domain,
        node = %c.ros.node,
        "fusion-ros running ({middleware}): {} topics in, odometry on {}",
        topics.len(),
        c.ros.odometry_topic
    );
}

/// The input and output threads, and a receiving thread of the middleware's
/// where it needs one, until stopped; then the last status line.
#[allow(clippy::too_many_arguments)]
fn pump(
    cli: &Cli,
    c: &NodeConfig,
    topics: &[InputTopic],
    rx: crossbeam::channel::Receiver<Inbound>,
    outputs: &Outputs,
    shared: &Arc<Shared>,
    status_interval: Duration,
    zenoh: Option<&RosNode>,
    receive: impl FnOnce(&Shared) -> anyhow::Result<()> + Send,
) {
    std::thread::scope(|scope| {
        let (ns, routes, tops, sh) = (cli.namespace.as_str(), c.routes.clone(), topics.to_vec(), &**shared);
        let input = scope.spawn(move || pump::input(ns, routes, tops, rx, sh));
        let output = scope.spawn(|| pump::output(&cli.namespace, &c.ros, &c.routes, outputs, shared));
        let receiver = scope.spawn(|| {
            if let Err(e) = receive(shared) {
                tracing::error!("receiving: {e:#}");
                shared.stop.store(true, Ordering::Relaxed);
            }
        });
        watch(zenoh, c, topics, outputs, shared, status_interval);
        shared.stop.store(true, Ordering::Relaxed);
        let _ = (input.join(), output.join(), receiver.join());
    });
    status(topics, outputs, shared);
}

/// Until stopped: the router's reachability, the wall clock's steps and a
/// status line every `interval`.
fn watch(
    zenoh: Option<&RosNode>,
    c: &NodeConfig,
    topics: &[InputTopic],
    out: &Outputs,
    shared: &Shared,
    interval: Duration,
) {
    let start = Instant::now();
    let (mut next_status, mut next_clock) = (start + interval, start + Duration::from_secs(1));
    let mut said_unreached = false;
    while !shared.stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(20));
        let now = Instant::now();
        if let Some(node) = zenoh.filter(|_| !said_unreached && now - start > Duration::from_secs(5)) {
            let routers = node.session.info().routers_zid().wait().count();
            let peers = node.session.info().peers_zid().wait().count();
            if routers + peers == 0 {
                tracing::warn!(
                    connect = ?c.ros.connect,
                    "no Zenoh router reached after 5 s: start one (`ros2 run rmw_zenoh_cpp rmw_zenohd`, or zenohd) \
                     at [ros] connect; retrying"
                );
            }
            said_unreached = true;
        }
        if now >= next_clock {
            next_clock += Duration::from_secs(1);
            if let Some(step) = shared.clock.check_wall() {
                tracing::warn!("the wall clock was set by {:.3} s: ROS stamps follow it", step as f64 * 1e-9);
            }
        }
        if now >= next_status {
            next_status += interval;
            status(topics, out, shared);
        }
    }
}

/// One line of what came in and went out.
fn status(topics: &[InputTopic], out: &Outputs, shared: &Shared) {
    let counts = shared.stats.counts();
    let mut parts = Vec::new();
    for t in topics {
        let c = counts.get(&t.topic).cloned().unwrap_or_default();
        let refused: u64 = c.refused.values().sum();
        parts.push(format!("{} {} messages, {} samples, {refused} refused", t.topic, c.messages, c.samples));
    }
    let tf = out.tf.as_ref().map_or(0, |p| p.sent());
    let diagnostics = out.diagnostics.as_ref().map_or(0, |p| p.sent());
    tracing::info!(
        "in: {}; out: odometry {}, tf {tf}, diagnostics {diagnostics}",
        parts.join("; "),
        out.odometry.sent()
    );
}
