//! `fusiond run` over iceoryx2: with its `port` the only files of the daemon
//! that touch it.
//!
//! One thread owns every iceoryx2 port (they are `!Send`). [`IpcSource`]
//! subscribes to `<ns>/<kind>` for every sample kind (`port`) and merges the
//! subscribers by timestamp (`merge`, pure); [`IpcSink`] fills each snapshot in place in a shared-memory chunk
//! loaned beforehand, sends it, notifies `<ns>/state` once per turn and then loans
//! the next chunks. The loop itself is the transport-free [`crate::live`] core.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use fusion_shared::config_record::{ConfigRecord, MAX_CONFIG_TEXT};
use fusion_shared::service::{self, InvalidNamespace, ServiceNames};
use fusion_shared::transport::Ipc;
use fusion_shared::{KindVisitor, Sample, SampleKind, StateSnapshot, WireSample};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;

mod merge;
mod port;

use merge::Heads;
use port::{KindPort, Port};

use crate::config::{Config, ConfigError, WithModel, with_model};
use crate::engine::{Engine, EngineConfig};
use crate::live::{LiveCore, LoopObserver, SampleSource, SnapshotSink};
pub use crate::live::{RunReport, WaitMode};
use crate::measurement::Steps;
use crate::summary::SummaryLogger;
use crate::systemd::Watchdog;

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
    /// Fault injection: stall the loop after this many samples (`--fault-stall-after`).
    pub stall: Option<crate::systemd::StallFault>,
    /// The text of the configuration file, published once on `<ns>/config` for
    /// recorders (`None`: not published).
    pub config_text: Option<String>,
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
    #[error(transparent)]
    Model(#[from] ConfigError),
    /// A service could not be opened.
    #[error(transparent)]
    Service(#[from] service::ServiceError),
    /// iceoryx2 refused a node or port.
    #[error("iceoryx2: {what}: {detail}")]
    Ipc {
        /// What was being created.
        what: &'static str,
        /// iceoryx2's reason.
        detail: String,
    },
    /// The loop's thread could not be pinned to the requested CPU.
    #[error("cannot pin to CPU {cpu}{}: this process may use CPUs {allowed}", .reason.as_ref().map(|r| format!(" ({r})")).unwrap_or_default())]
    Cpu {
        /// The CPU asked for.
        cpu: usize,
        /// The OS's reason, if it refused.
        reason: Option<rustix::io::Errno>,
        /// The CPUs this process may use.
        allowed: String,
    },
    /// The summary thread could not be started.
    #[error("cannot start the summary thread")]
    Thread(#[source] std::io::Error),
}

fn ipc<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> RunError {
    move |e| RunError::Ipc { what, detail: format!("{e:?}") }
}

/// Pins the calling thread to CPU `cpu` (Linux `sched_setaffinity`); an error
/// names the CPUs this process may use.
pub fn pin_current_thread(cpu: usize) -> Result<(), RunError> {
    use rustix::thread::{CpuSet, sched_getaffinity, sched_setaffinity};
    let allowed = sched_getaffinity(None).map(|set| {
        let cpus: Vec<String> = (0..CpuSet::MAX_CPU).filter(|&c| set.is_set(c)).map(|c| c.to_string()).collect();
        cpus.join(",")
    });
    let allowed = allowed.unwrap_or_else(|e| format!("unknown ({e})"));
    if cpu >= CpuSet::MAX_CPU {
        return Err(RunError::Cpu { cpu, reason: None, allowed });
    }
    let mut set = CpuSet::new();
    set.set(cpu);
    sched_setaffinity(None, &set).map_err(|e| RunError::Cpu { cpu, reason: Some(e), allowed })
}

/// Runs the daemon until `shutdown` becomes true.
pub fn run(config: &Config, options: &RunOptions, shutdown: &AtomicBool) -> Result<RunReport, RunError> {
    struct Run<'a>(&'a Config, &'a RunOptions, &'a AtomicBool);
    impl WithModel for Run<'_> {
        type Output = Result<RunReport, RunError>;
        fn run<M: Steps>(self, model: M) -> Self::Output {
            run_model(model, self.0, self.1, self.2)
        }
    }
    with_model(config, Run(config, options, shutdown))
}

/// The sample subscribers of every kind, merged by timestamp, and the wake-up
/// listener.
pub struct IpcSource {
    /// One port per kind; the IMU's last (see [`IpcSource::next`]).
    ports: Vec<Box<dyn Port>>,
    wake: Listener<Ipc>,
    receive_errors: u64,
    /// Wake-ups with [`service::READER_REFUSED_EVENT`] seen.
    readers_refused: u64,
    /// In-order samples handed out in a row before a late one that was waiting.
    passed_over: u32,
    /// The port of the last sample, when the merge picked it with no late
    /// sample waiting and no port blocked: the next sample of its instant in
    /// it goes alone ([`merge::goes_alone`]).
    alone: Option<usize>,
    /// The last full look found every port empty: until a sample comes, each
    /// look is a scan ([`IpcSource::scan`]).
    idle: bool,
    /// The port other than the IMU's that the last scan polled.
    scanned: usize,
    /// A port may hold samples taken this turn: [`SampleSource::end_turn`]
    /// gives them back.
    holding: bool,
    /// The wake listener was drained since the loop last looked at the
    /// subscribers: a notification from now on leaves a datagram, and
    /// [`SampleSource::wait`] may sleep on its socket.
    armed: bool,
}

impl IpcSource {
    fn open(node: &Node<Ipc>, names: &ServiceNames) -> Result<Self, RunError> {
        struct Open<'a> {
            node: &'a Node<Ipc>,
            names: &'a ServiceNames,
            ports: Vec<Box<dyn Port>>,
            error: Option<RunError>,
        }
        impl KindVisitor for Open<'_> {
            fn visit<T: WireSample>(&mut self) {
                if self.error.is_some() {
                    return;
                }
                let port = service::sample_service::<T>(self.node, self.names).map_err(RunError::from).and_then(|s| {
                    let subscriber = s
                        .subscriber_builder()
                        .buffer_size(service::SAMPLE_BUFFER)
                        .create()
                        .map_err(ipc("sample subscriber"))?;
                    Ok((s, subscriber))
                });
                match port {
                    Ok((service, subscriber)) => self.ports.push(Box::new(KindPort::<T>::new(subscriber, service))),
                    Err(e) => self.error = Some(e),
                }
            }
        }
        let mut open = Open { node, names, ports: Vec::new(), error: None };
        SampleKind::visit_all(&mut open);
        if let Some(e) = open.error {
            return Err(e);
        }
        // The IMU (the first kind) is polled last: an IMU sample, the stream that
        // carries the estimate forward at the highest rate, found by the last poll
        // is fused at once, without waiting on further polls (60 ns each here). A
        // measurement that lands between the polls and is older than the IMU
        // sample is fused next, by the engine's rewind, to the same estimate.
        open.ports.rotate_left(1);
        let wake = service::event_service(node, &names.wake)?;
        let wake = wake.listener_builder().create().map_err(ipc("wake listener"))?;
        Ok(Self {
            ports: open.ports,
            wake,
            receive_errors: 0,
            readers_refused: 0,
            passed_over: 0,
            alone: None,
            idle: false,
            scanned: 0,
            holding: false,
            armed: false,
        })
    }

    /// A look while idle: polls the IMU's port and one other active port, each
    /// scan the next one in turn, into `heads`; returns whether either holds a
    /// sample. The merge then sees every other port as its last poll left it:
    /// empty.
    ///
    /// A full look polls every active port (about 65 ns each), and a sample
    /// that arrives while the loop is idle waits on average half a look before
    /// the poll that finds it: with five kinds published, a quarter of a
    /// microsecond. A scan finds the IMU sample, which carries the estimate
    /// forward at the highest rate, within two polls, and every other kind
    /// within as many scans as there are such kinds. A measurement that
    /// arrived since its port's last scan and is older than the IMU sample
    /// found is fused next, by the engine's rewind, to the same estimate (as
    /// one that lands between the polls of a full look).
    fn scan(&mut self, newest: Option<merge::Key>, heads: &mut [Heads; SampleKind::COUNT]) -> bool {
        let imu = self.ports.len() - 1;
        let ports = &self.ports;
        if let Some(i) = merge::scanned_next(imu, self.scanned, |i| ports[i].active()) {
            self.scanned = i;
            heads[i] = self.ports[i].poll(&mut self.receive_errors, newest);
        }
        heads[imu] = self.ports[imu].poll(&mut self.receive_errors, newest);
        heads[self.scanned].holds() || heads[imu].holds()
    }
}

impl SampleSource for IpcSource {
    /// The oldest of the subscribers' next samples (at equal time the lower
    /// rank) that comes after `newest` (in order), else the oldest of all (late).
    ///
    /// Under a backlog, taking the oldest keeps fusion in time order instead of
    /// making one kind artificially late (or too late) behind a batch of
    /// another. A late sample waiting beside an in-order one goes second: it
    /// costs the engine a placement either way and its snapshot is provisional,
    /// while the in-order sample's snapshot would otherwise wait for both (the
    /// IMU sample right behind a late GNSS fix). At most `MAX_PASSED_OVER`
    /// in-order samples go ahead of it. A late sample at the head of a port
    /// steps aside into the port's late slot, so that the samples queued
    /// behind it (a retransmitted copy ahead of a backlog) are merged in time
    /// order and not made late while it waits.
    ///
    /// A port that is blocked for the rest of the turn (its publishers gave
    /// their share and have more) holds back every sample at or after the
    /// oldest it gave this turn: its unseen samples may be older. `None` then
    /// ends the turn; the next one gives its publishers their next share.
    ///
    /// Once a full look finds every port empty (and none blocked), the looks
    /// are scans (`IpcSource::scan`) until a sample is taken or the loop
    /// waits or refreshes.
    fn next(&mut self, newest: Option<(u64, u8)>) -> Option<Sample> {
        // The next sample of an instant, from the port of the last one, goes
        // without polling every port (`merge::goes_alone`).
        if let Some(i) = self.alone.take() {
            let head = self.ports[i].poll(&mut self.receive_errors, newest);
            if merge::goes_alone(&head, newest) {
                (self.alone, self.holding) = (Some(i), true);
                return self.ports[i].take(false);
            }
        }
        let mut heads = [Heads::EMPTY; SampleKind::COUNT];
        if self.idle {
            // Every port but the two a scan polls is empty: the last full look
            // found them so, and a scan that finds a sample ends the idle time.
            if !self.scan(newest, &mut heads) {
                return None;
            }
        } else {
            for (head, port) in heads.iter_mut().zip(self.ports.iter_mut()) {
                *head = port.poll(&mut self.receive_errors, newest);
            }
        }
        self.holding |= heads.iter().any(Heads::holds);
        let Some((port, late)) = merge::pick(&heads, newest, &mut self.passed_over) else {
            // Nothing held and nothing blocked: idle.
            self.idle = heads.iter().all(|h| *h == Heads::EMPTY);
            return None;
        };
        self.idle = false;
        // A clean pick: in order, no late sample waiting (`pick` leaves
        // `passed_over` at 0 after an in-order pick only then) and no port blocked.
        let clean = !late && self.passed_over == 0 && heads.iter().all(|h| h.bound.is_none());
        self.alone = clean.then_some(port);
        self.ports[port].take(late)
    }

    fn refresh(&mut self) {
        self.ports.iter_mut().for_each(|p| p.refresh());
        // A port that became active is looked at at once.
        self.idle = false;
        // A daemon that spins never waits on the listener: collect here what
        // the waits would have seen. A notification drained here may be of a
        // sample not yet taken: the loop looks at the subscribers before it sleeps.
        let refused = &mut self.readers_refused;
        let _ = self.wake.try_wait(|a| count_refused(refused, a));
        self.armed = false;
    }

    fn readers_refused(&self) -> u64 {
        self.readers_refused
    }

    fn end_turn(&mut self) {
        // `alone` stays: released, no port is blocked in the next turn.
        if std::mem::take(&mut self.holding) {
            self.ports.iter_mut().for_each(|p| p.release());
        }
    }

    /// Sleeps on the wake listener's socket (`poll(2)`) until a publisher
    /// notifies, at most `timeout`.
    ///
    /// iceoryx2's `Listener::timed_wait` makes its socket blocking, sets the
    /// receive timeout, receives, and on waking makes the socket non-blocking
    /// again and empties it: three system calls between the wake-up and the
    /// first look at the subscribers, on every sample. Here the loop looks at
    /// the subscribers as soon as `poll` returns, and the listener is drained
    /// (non-blocking `try_wait`) on the next call, after the samples were
    /// fused and their snapshots sent. That call returns without sleeping, so
    /// that the loop looks at the subscribers once more before it sleeps: a
    /// sample whose notification was drained with an earlier one is not left
    /// waiting.
    fn wait(&mut self, timeout: Duration) {
        // The look after a wait, and so the one before a sleep, is a full
        // one: a scan could leave the sample that woke the loop unseen.
        self.idle = false;
        if !self.armed {
            let refused = &mut self.readers_refused;
            match self.wake.try_wait(|a| count_refused(refused, a)) {
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                Err(e) => {
                    tracing::warn!("wake listener: {e:?}");
                    std::thread::sleep(timeout);
                }
            }
            self.armed = true;
            return;
        }
        // SAFETY: the descriptor is the listener's, which outlives this call.
        let fd = unsafe { std::os::fd::BorrowedFd::borrow_raw(self.wake.file_descriptor().native_handle()) };
        let mut fds = [rustix::event::PollFd::new(&fd, rustix::event::PollFlags::IN)];
        let timeout = rustix::event::Timespec {
            tv_sec: timeout.as_secs().min(i64::MAX as u64) as i64,
            tv_nsec: i64::from(timeout.subsec_nanos()),
        };
        // Woken (or timed out, or a signal: the loop condition looks at it),
        // the loop takes the samples; the next call drains the listener.
        let _ = rustix::event::poll(&mut fds, Some(&timeout));
        self.armed = false;
    }
}

/// Counts the wake-ups from refused readers among `activation`.
fn count_refused(count: &mut u64, activation: EventActivation) {
    if activation.id.as_value() == service::READER_REFUSED_EVENT {
        *count = count.saturating_add(activation.count);
    }
}

/// A snapshot chunk loaned from the state publisher (holding a default
/// snapshot, or one written while warming), not yet filled or sent.
type LoanedSnapshot = iceoryx2::sample_mut::SampleMut<Ipc, StateSnapshot, ()>;

/// Snapshot chunks the sink holds loaned ahead of the samples (the state
/// publisher's `max_loaned_samples`).
const LOANED: usize = 2;

/// The state publisher and its event, and the configuration's publisher.
pub struct IpcSink {
    state: Publisher<Ipc, StateSnapshot, ()>,
    /// Publishes the configuration once; kept for readers that come later
    /// (its history).
    config: Option<Publisher<Ipc, ConfigRecord, ()>>,
    state_event: Notifier<Ipc>,
    /// The chunks of the next snapshots, loaned after the last turn's sends so
    /// that loaning (and writing a default snapshot, 4.2 KB) is off the path from
    /// sample to snapshot, which fills a chunk in place. Two, for the samples
    /// that come together (two IMUs of one instant, or an IMU sample and a fix).
    loaned: [Option<LoanedSnapshot>; LOANED],
    publish_errors: u64,
}

impl IpcSink {
    fn open(
        node: &Node<Ipc>,
        names: &ServiceNames,
        max_readers: usize,
        config_text: Option<&str>,
    ) -> Result<Self, RunError> {
        let state = service::state_service(node, names, Some(max_readers))?;
        let state = match state.publisher_builder().max_loaned_samples(LOANED).create() {
            Ok(p) => p,
            // The state service allows one publisher: fusiond.
            Err(PublisherCreateError::ExceedsMaxSupportedPublishers) => {
                return Err(RunError::AlreadyRunning(names.namespace.clone()));
            }
            Err(e) => return Err(ipc("state publisher")(e)),
        };
        let state_event = service::event_service(node, &names.state)?;
        let state_event = state_event.notifier_builder().create().map_err(ipc("state notifier"))?;
        let config = match config_text.map(|t| (t, ConfigRecord::new(t, env!("CARGO_PKG_VERSION")))) {
            None => None,
            Some((text, None)) => {
                tracing::warn!(
                    bytes = text.len(),
                    "the configuration is longer than {MAX_CONFIG_TEXT} bytes: not published on {} (recordings of \
                     this run will not carry it)",
                    names.config
                );
                None
            }
            Some((_, Some(record))) => {
                let service = service::config_service(node, names, true)?;
                let publisher = service.publisher_builder().create().map_err(ipc("config publisher"))?;
                publisher.send_copy(record).map_err(ipc("config publisher"))?;
                Some(publisher)
            }
        };
        Ok(Self { state, config, state_event, loaned: [const { None }; LOANED], publish_errors: 0 })
    }
}

impl SnapshotSink for IpcSink {
    fn publish(&mut self, fill: impl FnOnce(&mut StateSnapshot)) -> bool {
        // Error texts are built only on failure.
        let loaned = match self.loaned.iter_mut().find_map(Option::take) {
            Some(s) => Ok(s),
            None => self.state.loan().map_err(|e| format!("loan: {e:?}")),
        };
        let sent = loaned.and_then(|mut chunk| {
            fill(chunk.payload_mut());
            chunk.send().map_err(|e| format!("send: {e:?}"))
        });
        match sent {
            Ok(_) => true,
            Err(e) => {
                if self.publish_errors == 0 {
                    tracing::warn!("cannot publish a snapshot: {e} (further failures are only counted)");
                }
                self.publish_errors += 1;
                false
            }
        }
    }

    fn flush(&mut self) {
        let _ = self.state_event.notify();
        // The readers have their snapshots: loan the next ones now, off the
        // latency path (if this fails, `publish` tries again and counts it).
        self.loan_ahead();
    }

    fn refresh(&mut self) {
        // Lets a reader that connected since the last send get the history sample.
        let _ = self.state.update_connections();
        if let Some(config) = &self.config {
            let _ = config.update_connections();
        }
    }

    /// Touches the loaned chunks of the next snapshots (loaning those not
    /// held) by rewriting their content: between samples a millisecond apart this
    /// memory otherwise leaves the caches, and the next sample pays the misses on
    /// its way to the reader.
    fn warm(&mut self) {
        self.loan_ahead();
        for chunk in self.loaned.iter_mut().flatten() {
            let snap = chunk.payload_mut();
            *snap = std::hint::black_box(*snap);
        }
    }
}

impl IpcSink {
    /// Loans a chunk into every empty place of `loaned`, as far as the
    /// publisher lends them.
    fn loan_ahead(&mut self) {
        for place in self.loaned.iter_mut().filter(|p| p.is_none()) {
            *place = self.state.loan().ok();
        }
    }
}

/// The loop's observer in `fusiond run`: summaries to the log thread, the
/// systemd watchdog, the stall fault.
struct Observer<'a> {
    summary: SummaryLogger,
    watchdog: Watchdog,
    stall: Option<crate::systemd::StallFault>,
    shutdown: &'a AtomicBool,
}

impl LoopObserver for Observer<'_> {
    fn summary(&mut self, summary: crate::summary::Summary) {
        self.summary.send(summary);
    }

    fn alive(&mut self, now_ns: u64, report: RunReport) {
        self.watchdog.pet(now_ns);
        if let Some(stall) = &self.stall {
            stall.check(report, self.shutdown);
        }
    }
}

fn run_model<M: Steps>(
    model: M,
    config: &Config,
    options: &RunOptions,
    shutdown: &AtomicBool,
) -> Result<RunReport, RunError> {
    let names = ServiceNames::new(&options.namespace)?;
    let iceoryx = service::iceoryx_config(None).map_err(|detail| RunError::Ipc { what: "config", detail })?;
    let node = service::create_node(&format!("fusiond.{}", names.namespace), &iceoryx)
        .map_err(|detail| RunError::Ipc { what: "node", detail })?;
    // The state publisher first: a second fusiond stops here.
    let mut sink = IpcSink::open(&node, &names, config.ipc.max_readers, options.config_text.as_deref())?;
    let mut source = IpcSource::open(&node, &names)?;
    let summary = SummaryLogger::start().map_err(RunError::Thread)?;
    // After the summary thread started: it must not inherit the loop's CPU.
    if let Some(cpu) = options.cpu {
        pin_current_thread(cpu)?;
    }
    let kinds: Vec<String> = SampleKind::ALL.iter().map(|&k| names.samples(k)).collect();
    tracing::info!(
        namespace = %names.namespace,
        model = fusion_shared::snapshot::model::name(M::CODE),
        form = config.filter.form.name(),
        wait = ?options.wait,
        cpu = ?options.cpu,
        "fusiond running: samples on {}, state on {}",
        kinds.join(", "),
        names.state
    );

    let engine = Engine::new(model, EngineConfig::from_config(config));
    let mut core = LiveCore::new(engine, config.health, options.summary_interval, fusion_shared::now_ns());
    let mut observer = Observer { summary, watchdog: Watchdog::from_env(), stall: options.stall, shutdown };
    crate::systemd::ready(&format!(
        "fusing in namespace {} ({})",
        names.namespace,
        fusion_shared::snapshot::model::name(M::CODE)
    ));
    let report = crate::live::run(&mut core, &mut source, &mut sink, options.wait, shutdown, &mut observer);
    crate::systemd::stopping();

    tracing::info!(
        received = report.received,
        snapshots = report.snapshots,
        publish_errors = sink.publish_errors,
        receive_errors = source.receive_errors,
        "fusiond stopping"
    );
    // The loaned chunks keep the publisher (and through it the node) alive: the
    // sink goes first, or the node would outlive the domain cleanup below.
    drop(sink);
    drop(source);
    drop(node);
    service::remove_domain_counter_if_last(&iceoryx);
    Ok(report)
}
