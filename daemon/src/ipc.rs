//! `fusiond run`: the live daemon. The only file of the daemon that touches iceoryx2.
//!
//! One thread owns every iceoryx2 port (they are `!Send`). Each turn of the loop
//! drains both sample subscribers, feeds every sample to the engine with the
//! daemon's clock, publishes one [`StateSnapshot`] per processed sample (written
//! in place in a shared-memory chunk loaned beforehand) and then notifies
//! `<ns>/state` once, then loans the chunk of the next snapshot. Between
//! turns it either busy-polls (`spin`, keeping what the next sample will touch in
//! the cache, every 100 µs while idle) or sleeps on the `<ns>/wake` listener
//! (`event`). Every 10 ms it re-evaluates the health (a stream that stopped is
//! marked stale even though nothing arrives), refreshes connections so a late
//! reader gets the latest snapshot, and every summary interval hands counters to
//! the summary thread.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fusion_shared::service::{self, InvalidNamespace, ServiceNames};
use fusion_shared::transport::Ipc;
use fusion_shared::{Sample, SampleKind, StateSnapshot, now_ns};
use hdrhistogram::Histogram;
use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;

use crate::config::{Config, ModelConfig};
use crate::engine::{Engine, EngineConfig, Insert, SensorStats};
use crate::health::HealthMonitor;
use crate::model::Model;
use crate::model::ins::InsModel;
use crate::model::linear::LinearModel;
use crate::snapshot::{self, Input};
use crate::summary::{Summary, SummaryLogger};

/// How the daemon waits for samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitMode {
    /// Busy-poll the subscribers: lowest latency, one core fully used.
    Spin,
    /// Sleep on the `<ns>/wake` event between samples: no CPU while idle.
    Event,
}

/// Options of `fusiond run` besides the config file.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Namespace of the services.
    pub namespace: String,
    /// Wait mode.
    pub wait: WaitMode,
    /// Interval of the info-level summary line.
    pub summary_interval: Duration,
    /// CPU to pin the fusion loop's thread to (`--cpu`). A spinning loop wants a
    /// core of its own: pinned, the kernel never moves it, and other busy
    /// threads can be kept off that core. `None` leaves placement to the kernel.
    pub cpu: Option<usize>,
}

/// Why the daemon could not start or had to stop.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The namespace is not usable as part of a service name.
    #[error(transparent)]
    Namespace(#[from] InvalidNamespace),
    /// Another fusiond publishes the state of this namespace.
    #[error("another fusiond is already running in namespace {0:?}")]
    AlreadyRunning(String),
    /// The model could not be built from the config.
    #[error("model: {0}")]
    Model(String),
    /// A service could not be opened.
    #[error(transparent)]
    Service(#[from] service::ServiceError),
    /// iceoryx2 refused a node or port.
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// The loop's thread could not be pinned to the requested CPU.
    #[error("{0}")]
    Cpu(String),
}

/// Pins the calling thread to CPU `cpu` (Linux `sched_setaffinity`); an error
/// names the CPUs this process may use.
pub fn pin_current_thread(cpu: usize) -> Result<(), String> {
    use rustix::thread::{CpuSet, sched_getaffinity, sched_setaffinity};
    let allowed = sched_getaffinity(None).map(|set| {
        let cpus: Vec<String> = (0..CpuSet::MAX_CPU).filter(|&c| set.is_set(c)).map(|c| c.to_string()).collect();
        cpus.join(",")
    });
    let allowed = allowed.unwrap_or_else(|e| format!("unknown ({e})"));
    if cpu >= CpuSet::MAX_CPU {
        return Err(format!("cannot pin to CPU {cpu}: this process may use CPUs {allowed}"));
    }
    let mut set = CpuSet::new();
    set.set(cpu);
    sched_setaffinity(None, &set)
        .map_err(|e| format!("cannot pin to CPU {cpu} ({e}): this process may use CPUs {allowed}"))
}

/// What a run did, for the caller (and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunReport {
    /// Samples taken from the subscribers.
    pub received: u64,
    /// Snapshots published.
    pub snapshots: u64,
}

/// Health and housekeeping period.
const HOUSEKEEPING_NS: u64 = 10_000_000;
/// Spin mode: while no sample arrives, the memory the next sample will touch is
/// read (and the pre-loaned snapshot chunk written) this often, so that the
/// next sample finds it in the cache (see [`Fusion::warm`]).
const WARM_NS: u64 = 100_000;
/// Samples per turn (per kind) before housekeeping gets a look in.
const BATCH: usize = 256;

/// Runs the daemon until `shutdown` becomes true.
pub fn run(config: &Config, options: &RunOptions, shutdown: &AtomicBool) -> Result<RunReport, RunError> {
    match config.model {
        ModelConfig::Linear { .. } => {
            let model = LinearModel::from_config(config).map_err(|e| RunError::Model(e.to_string()))?;
            run_model(model, config, options, shutdown)
        }
        ModelConfig::Ins { .. } => {
            let model = InsModel::from_config(config).map_err(|e| RunError::Model(e.to_string()))?;
            run_model(model, config, options, shutdown)
        }
    }
}

fn ipc<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> RunError + '_ {
    move |e| RunError::Ipc(format!("{what}: {e:?}"))
}

/// The ports of one daemon, created in the order a reader of the log expects.
struct Ports {
    imu: iceoryx2::port::subscriber::Subscriber<Ipc, fusion_shared::ImuSample, ()>,
    position: iceoryx2::port::subscriber::Subscriber<Ipc, fusion_shared::PositionSample, ()>,
    wake: iceoryx2::port::listener::Listener<Ipc>,
    state: iceoryx2::port::publisher::Publisher<Ipc, StateSnapshot, ()>,
    state_event: iceoryx2::port::notifier::Notifier<Ipc>,
}

impl Ports {
    fn open(node: &Node<Ipc>, names: &ServiceNames) -> Result<Self, RunError> {
        let state = service::state_service(node, names, true)?;
        let state = match state.publisher_builder().create() {
            Ok(p) => p,
            // The state service allows one publisher: fusiond.
            Err(PublisherCreateError::ExceedsMaxSupportedPublishers) => {
                return Err(RunError::AlreadyRunning(names.namespace.clone()));
            }
            Err(e) => return Err(ipc("state publisher")(e)),
        };
        let imu = service::imu_service(node, names)?;
        let imu =
            imu.subscriber_builder().buffer_size(service::SAMPLE_BUFFER).create().map_err(ipc("imu subscriber"))?;
        let position = service::position_service(node, names)?;
        let position = position
            .subscriber_builder()
            .buffer_size(service::SAMPLE_BUFFER)
            .create()
            .map_err(ipc("position subscriber"))?;
        let wake = service::event_service(node, &names.wake)?;
        let wake = wake.listener_builder().create().map_err(ipc("wake listener"))?;
        let state_event = service::event_service(node, &names.state)?;
        let state_event = state_event.notifier_builder().create().map_err(ipc("state notifier"))?;
        Ok(Self { imu, position, wake, state, state_event })
    }
}

/// A snapshot chunk loaned from the state publisher (holding a default
/// snapshot, or one written while warming), not yet filled or sent.
type LoanedSnapshot = iceoryx2::sample_mut::SampleMut<Ipc, StateSnapshot, ()>;

/// The fusion loop's state besides the ports.
struct Fusion<M: Model> {
    engine: Engine<M>,
    /// The chunk of the next snapshot, loaned right after the last send so that
    /// loaning (and writing its default content) is off the path from sample to
    /// snapshot, which fills it in place.
    loaned: Option<LoanedSnapshot>,
    health: HealthMonitor,
    health_now: (u32, u32),
    latency: Histogram<u64>,
    report: RunReport,
    publish_errors: u64,
    receive_errors: u64,
}

impl<M: Model> Fusion<M> {
    /// Feeds one sample to the engine and publishes the resulting snapshot.
    fn handle(&mut self, sample: Sample, ports: &Ports) {
        self.report.received += 1;
        let received_ns = now_ns();
        let Insert::Processed { replayed, outcome } = self.engine.insert(&sample, Some(received_ns), &mut |_| {})
        else {
            return;
        };
        if let Some(slot) = self.engine.slot_of(sample.kind(), sample.sensor()) {
            self.health.record(slot, &outcome);
        }
        let initialised = self.engine.latest().is_some_and(|e| M::initialised(&e.state));
        self.health_now = self.health.evaluate(self.engine.sensors(), received_ns, initialised);
        let input = Input { sample: &sample, received_ns, replayed };
        let published = self.publish(ports, Some(input));
        if let Some(published_ns) = published
            && replayed == 0
            && sample.sent_ns() > 0
        {
            // Out-of-range values (clock skew between processes) are not recorded.
            let _ = self.latency.record(published_ns.saturating_sub(sample.sent_ns()));
        }
    }

    /// Fills the next snapshot in its chunk (the estimate, `input` and the
    /// current health), stamps and sends it; returns the publish time.
    ///
    /// [`snapshot::fill`] writes every field that can change, so filling a chunk
    /// that holds a default (or an older) snapshot gives what filling one
    /// snapshot over and over would (`snapshot` tests).
    fn publish(&mut self, ports: &Ports, input: Option<Input<'_>>) -> Option<u64> {
        // Error texts are built only on failure.
        let loaned = match self.loaned.take() {
            Some(s) => Ok(s),
            None => ports.state.loan().map_err(|e| format!("loan: {e:?}")),
        };
        let sent = loaned.and_then(|mut chunk| {
            let snap = chunk.payload_mut();
            snapshot::fill(snap, &self.engine, input, self.health_now);
            snap.seq = self.report.snapshots;
            let publish_ns = now_ns();
            snap.publish_ns = publish_ns;
            chunk.send().map(|_| publish_ns).map_err(|e| format!("send: {e:?}"))
        });
        match sent {
            Ok(publish_ns) => {
                self.report.snapshots += 1;
                Some(publish_ns)
            }
            Err(e) => {
                if self.publish_errors == 0 {
                    tracing::warn!("cannot publish a snapshot: {e} (further failures are only counted)");
                }
                self.publish_errors += 1;
                None
            }
        }
    }

    /// Spin mode, while idle: touches what the next sample will touch, the
    /// engine's entries ([`Engine::warm`]) and the loaned chunk of the next
    /// snapshot (loaning one if none is held), by rewriting its content. Between
    /// samples a millisecond apart this memory otherwise leaves the caches, and
    /// the next sample pays the misses on its way to the reader.
    fn warm(&mut self, ports: &Ports) {
        if self.loaned.is_none() {
            self.loaned = ports.state.loan().ok();
        }
        if let Some(chunk) = self.loaned.as_mut() {
            let snap = chunk.payload_mut();
            *snap = std::hint::black_box(*snap);
        }
        self.engine.warm();
    }
}

/// Takes one sample off a subscriber (copied out, the shared-memory slot released).
fn receive<T: std::fmt::Debug + ZeroCopySend + Copy>(
    subscriber: &iceoryx2::port::subscriber::Subscriber<Ipc, T, ()>,
    errors: &mut u64,
    what: &str,
) -> Option<T> {
    match subscriber.receive() {
        Ok(sample) => sample.map(|s| *s),
        Err(e) => {
            if *errors == 0 {
                tracing::warn!("{what} receive: {e:?} (further failures are only counted)");
            }
            *errors += 1;
            None
        }
    }
}

fn run_model<M: Model>(
    model: M,
    config: &Config,
    options: &RunOptions,
    shutdown: &AtomicBool,
) -> Result<RunReport, RunError> {
    let names = ServiceNames::new(&options.namespace)?;
    let iceoryx = service::iceoryx_config(None).map_err(RunError::Ipc)?;
    let node = service::create_node(&format!("fusiond.{}", names.namespace), &iceoryx).map_err(RunError::Ipc)?;
    let ports = Ports::open(&node, &names)?;
    let summary = SummaryLogger::start().map_err(|e| RunError::Ipc(format!("summary thread: {e}")))?;
    // After the summary thread started: it must not inherit the loop's CPU.
    if let Some(cpu) = options.cpu {
        pin_current_thread(cpu).map_err(RunError::Cpu)?;
    }
    tracing::info!(
        namespace = %names.namespace,
        model = M::KIND,
        wait = ?options.wait,
        cpu = ?options.cpu,
        "fusiond running: samples on {} and {}, state on {}",
        names.imu,
        names.position,
        names.state
    );

    let mut fusion = Fusion {
        engine: Engine::new(model, EngineConfig::from_config(config)),
        loaned: None,
        health: HealthMonitor::new(config.health),
        health_now: (fusion_shared::snapshot::health::INITIALISING, 0),
        // 1 ns to 10 s at 3 significant digits: allocated once, here.
        latency: Histogram::new_with_bounds(1, 10_000_000_000, 3).map_err(|e| RunError::Ipc(e.to_string()))?,
        report: RunReport::default(),
        publish_errors: 0,
        receive_errors: 0,
    };
    let summary_ns = options.summary_interval.as_nanos().max(1) as u64;
    let mut next_housekeeping = now_ns();
    let mut next_warm = next_housekeeping;
    let mut last_summary = (now_ns(), SensorStats::default(), SensorStats::default(), 0u64);
    let mut published_health = fusion.health_now;
    let mut pending_imu: Option<fusion_shared::ImuSample> = None;
    let mut pending_position: Option<fusion_shared::PositionSample> = None;

    while !shutdown.load(Ordering::Relaxed) {
        let snapshots_before = fusion.report.snapshots;
        let mut taken = 0;
        // Two-way merge by timestamp: under a backlog, taking the older of the two
        // pending samples keeps fusion in time order instead of making one kind
        // artificially late (or too late) behind a batch of the other.
        // Positions are polled first: an IMU sample (the stream that carries the
        // estimate forward, at the higher rate) found by the second poll is fused
        // at once, without waiting on a further poll (60 ns here). A fix that
        // lands between the two polls and is older than the IMU sample is fused
        // next, by the engine's rewind, to the same estimate.
        while taken < 2 * BATCH {
            if pending_position.is_none() {
                pending_position = receive(&ports.position, &mut fusion.receive_errors, "position");
            }
            if pending_imu.is_none() {
                pending_imu = receive(&ports.imu, &mut fusion.receive_errors, "imu");
            }
            let sample = match (pending_imu, pending_position) {
                (Some(i), Some(p)) if p.t_ns < i.t_ns => Sample::Position(pending_position.take().unwrap_or(p)),
                (Some(i), _) => Sample::Imu(pending_imu.take().unwrap_or(i)),
                (None, Some(p)) => Sample::Position(pending_position.take().unwrap_or(p)),
                (None, None) => break,
            };
            fusion.handle(sample, &ports);
            taken += 1;
        }
        if fusion.report.snapshots > snapshots_before {
            published_health = fusion.health_now;
            let _ = ports.state_event.notify();
            // The readers have their snapshot: loan the next one now, off the
            // latency path (if this fails, `publish` tries again and counts it).
            fusion.loaned = ports.state.loan().ok();
        }

        let now = now_ns();
        if now >= next_housekeeping {
            next_housekeeping = now + HOUSEKEEPING_NS;
            let initialised = fusion.engine.latest().is_some_and(|e| M::initialised(&e.state));
            fusion.health_now = fusion.health.evaluate(fusion.engine.sensors(), now, initialised);
            if fusion.health_now != published_health && fusion.engine.latest().is_some() {
                // Nothing arrived but the health changed (a stream went stale): say so.
                if fusion.publish(&ports, None).is_some() {
                    published_health = fusion.health_now;
                    let _ = ports.state_event.notify();
                }
            }
            // Lets a reader that connected since the last send get the history sample.
            let _ = ports.state.update_connections();
            if now.saturating_sub(last_summary.0) >= summary_ns {
                let imu = fusion.engine.totals(Some(SampleKind::Imu));
                let position = fusion.engine.totals(Some(SampleKind::Position));
                let h = &fusion.latency;
                let latency_ns =
                    (!h.is_empty()).then(|| (h.value_at_quantile(0.5), h.value_at_quantile(0.99), h.max()));
                summary.send(Summary {
                    interval_s: (now - last_summary.0) as f64 * 1e-9,
                    imu: imu.since(&last_summary.1),
                    position: position.since(&last_summary.2),
                    snapshots: fusion.report.snapshots - last_summary.3,
                    latency_ns,
                    health: fusion.health_now,
                });
                fusion.latency.reset();
                last_summary = (now, imu, position, fusion.report.snapshots);
            }
        }

        if taken > 0 {
            next_warm = now + WARM_NS;
        } else {
            match options.wait {
                WaitMode::Spin => {
                    if now >= next_warm {
                        fusion.warm(&ports);
                        next_warm = now_ns() + WARM_NS;
                    }
                    std::hint::spin_loop();
                }
                WaitMode::Event => {
                    let timeout = Duration::from_nanos(next_housekeeping.saturating_sub(now_ns()).max(1));
                    match ports.wake.timed_wait(|_| {}, timeout) {
                        // A signal interrupted the wait: the loop condition looks at it.
                        Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                        Err(e) => {
                            tracing::warn!("wake listener: {e:?}");
                            std::thread::sleep(timeout);
                        }
                    }
                }
            }
        }
    }

    tracing::info!(
        received = fusion.report.received,
        snapshots = fusion.report.snapshots,
        publish_errors = fusion.publish_errors,
        receive_errors = fusion.receive_errors,
        "fusiond stopping"
    );
    // The loaned chunk keeps the publisher (and through it the node) alive: it
    // goes first, or the node would outlive the domain cleanup below.
    fusion.loaned = None;
    drop(ports);
    drop(node);
    service::remove_domain_counter_if_last(&iceoryx);
    Ok(fusion.report)
}
