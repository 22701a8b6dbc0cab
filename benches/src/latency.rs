//! Latency measurements over real processes: raw iceoryx2 ping-pong (the floor)
//! and fusiond end to end (sample published → snapshot of that sample received).

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fusion_client::{Client, ImuSample, StateSnapshot, now_ns};
use fusion_shared::service;
use hdrhistogram::Histogram;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

/// How both sides wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Busy-poll.
    Spin,
    /// Sleep on an iceoryx2 event.
    Event,
}

impl Mode {
    /// `spin` or `event`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Spin => "spin",
            Mode::Event => "event",
        }
    }

    /// Parses `spin` or `event`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "spin" => Some(Mode::Spin),
            "event" => Some(Mode::Event),
            _ => None,
        }
    }
}

/// A new latency histogram: 1 ns to 10 s, 3 significant digits.
pub fn histogram() -> Histogram<u64> {
    // Constant, valid bounds.
    Histogram::new_with_bounds(1, 10_000_000_000, 3).expect("valid histogram bounds")
}

/// A payload of the raw ping-pong: it carries the sequence number it answers.
pub trait Payload: ZeroCopySend + Copy + std::fmt::Debug + Default + 'static {
    /// The sequence number.
    fn seq(&self) -> u64;
    /// A payload with `seq`, stamped `t_ns`.
    fn with_seq(seq: u64, t_ns: u64) -> Self;
}

impl Payload for ImuSample {
    fn seq(&self) -> u64 {
        self.seq
    }
    fn with_seq(seq: u64, t_ns: u64) -> Self {
        ImuSample { seq, t_ns, ..Default::default() }
    }
}

/// The answer the size of what fusiond answers with (3.9 KB), every byte written.
impl Payload for StateSnapshot {
    fn seq(&self) -> u64 {
        self.seq
    }
    fn with_seq(seq: u64, t_ns: u64) -> Self {
        StateSnapshot { seq, publish_ns: t_ns, ..Default::default() }
    }
}

/// One end of the raw ping-pong: sends `S`, receives `R`.
struct PingPongEnd<S: Payload, R: Payload> {
    _node: Node<ipc::Service>,
    publisher: Publisher<ipc::Service, S, ()>,
    subscriber: Subscriber<ipc::Service, R, ()>,
    notifier: Notifier<ipc::Service>,
    listener: Listener<ipc::Service>,
}

impl<S: Payload, R: Payload> PingPongEnd<S, R> {
    /// `send_to`/`receive_from`: the two directions, `<base>/ping` and `<base>/pong`.
    fn open(base: &str, send_to: &str, receive_from: &str) -> anyhow::Result<Self> {
        let node = service::create_node("bench", &service::iceoryx_config(None).map_err(anyhow::Error::msg)?)
            .map_err(anyhow::Error::msg)?;
        let name = |dir: &str| -> anyhow::Result<ServiceName> { Ok(format!("{base}/{dir}").as_str().try_into()?) };
        let event = |dir: &str| -> anyhow::Result<_> {
            Ok(node.service_builder(&name(&format!("{dir}-event"))?).event().open_or_create()?)
        };
        let publisher = node
            .service_builder(&name(send_to)?)
            .publish_subscribe::<S>()
            .open_or_create()?
            .publisher_builder()
            .create()?;
        let subscriber = node
            .service_builder(&name(receive_from)?)
            .publish_subscribe::<R>()
            .open_or_create()?
            .subscriber_builder()
            .create()?;
        let notifier = event(send_to)?.notifier_builder().create()?;
        let listener = event(receive_from)?.listener_builder().create()?;
        Ok(Self { _node: node, publisher, subscriber, notifier, listener })
    }

    fn send(&self, sample: S, mode: Mode) -> anyhow::Result<()> {
        self.publisher.send_copy(sample)?;
        if mode == Mode::Event {
            self.notifier.notify()?;
        }
        Ok(())
    }

    /// Waits for the next sample (up to 1 s).
    fn receive(&self, mode: Mode) -> anyhow::Result<Option<R>> {
        let deadline = Instant::now() + Duration::from_secs(1);
        loop {
            if let Some(s) = self.subscriber.receive()? {
                return Ok(Some(*s));
            }
            if Instant::now() > deadline {
                return Ok(None);
            }
            match mode {
                Mode::Spin => std::hint::spin_loop(),
                Mode::Event => match self.listener.timed_wait(|_| {}, Duration::from_millis(100)) {
                    // A signal (SIGCONT after the bench paused this process) ends the wait early.
                    Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                    Err(e) => return Err(e.into()),
                },
            }
        }
    }
}

/// The pong side: answers every ping with an `R` of the same sequence number until
/// one with `seq == u64::MAX`; gives up after 30 s without a ping.
pub fn pong<R: Payload>(base: &str, mode: Mode) -> anyhow::Result<()> {
    let end = PingPongEnd::<R, ImuSample>::open(base, "pong", "ping")?;
    let mut last_ping = Instant::now();
    loop {
        match end.receive(mode)? {
            Some(s) if s.seq == u64::MAX => return Ok(()),
            Some(s) => {
                last_ping = Instant::now();
                end.send(R::with_seq(s.seq, s.t_ns), mode)?;
            }
            None if last_ping.elapsed() > Duration::from_secs(30) => anyhow::bail!("pong: no ping for 30 s"),
            None => {}
        }
    }
}

/// Ends a child process however it is (kill, then reap).
pub struct ChildGuard(pub Child);

impl ChildGuard {
    /// Sends `signal` (a `kill` name such as `STOP`) to the child.
    fn signal(&self, signal: &str) -> anyhow::Result<()> {
        let status = Command::new("kill").arg(format!("-{signal}")).arg(self.0.id().to_string()).status()?;
        anyhow::ensure!(status.success(), "kill -{signal} {} failed", self.0.id());
        Ok(())
    }

    /// Freezes the child (SIGSTOP): a busy-polling process stops taking a core.
    pub fn pause(&self) -> anyhow::Result<()> {
        self.signal("STOP")
    }

    /// Lets a paused child run again (SIGCONT).
    pub fn resume(&self) -> anyhow::Result<()> {
        self.signal("CONT")
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            // A paused child would not see SIGTERM, and SIGKILL leaves its files.
            let _ = self.signal("CONT");
            let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
            let deadline = Instant::now() + Duration::from_secs(5);
            while matches!(self.0.try_wait(), Ok(None)) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(10));
            }
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

/// Sends at a fixed rate: [`wait`](Self::wait) returns at the next tick, sleeping
/// while more than 200 µs remain and spinning the rest, so the sender is awake and
/// on time. Raw and end-to-end rows pace alike, so that they compare like with like
/// (an idle gap between messages costs both sides cache and wake-up state).
pub struct Pacer {
    period_ns: u64,
    next: u64,
}

impl Pacer {
    /// Ticks at `rate_hz`, the first 10 ms from now.
    pub fn new(rate_hz: f64) -> Self {
        Self { period_ns: (1e9 / rate_hz) as u64, next: now_ns() + 10_000_000 }
    }

    /// Waits for the next tick.
    pub fn wait(&mut self) {
        while now_ns() < self.next {
            if self.next.saturating_sub(now_ns()) > 200_000 {
                std::thread::sleep(Duration::from_micros(100));
            } else {
                std::hint::spin_loop();
            }
        }
        self.next += self.period_ns;
    }
}

/// The ping side of the raw iceoryx2 ping-pong with an `ImuSample` payload, against
/// a pong process (already started on `base`); it can ping in several blocks.
pub struct Pinger<R: Payload = ImuSample> {
    end: PingPongEnd<ImuSample, R>,
    mode: Mode,
    seq: u64,
}

impl<R: Payload> Pinger<R> {
    /// Connects to the pong side: retries a first ping until it answers.
    pub fn connect(base: &str, mode: Mode) -> anyhow::Result<Self> {
        let end = PingPongEnd::open(base, "ping", "pong")?;
        let started = Instant::now();
        loop {
            end.send(ImuSample { seq: u64::MAX - 1, ..Default::default() }, mode)?;
            if end.receive(mode)?.is_some() {
                break;
            }
            anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "pong did not answer");
        }
        Ok(Self { end, mode, seq: 0 })
    }

    /// One ping per tick at `rate_hz`, `count` of them: the round-trip times of
    /// all but the first `warmup` go to `rtt`, ns.
    pub fn run(&mut self, count: u64, warmup: u64, rate_hz: f64, rtt: &mut Histogram<u64>) -> anyhow::Result<()> {
        let mut pacer = Pacer::new(rate_hz);
        for k in 0..count {
            pacer.wait();
            let seq = self.seq;
            self.seq += 1;
            let t0 = now_ns();
            self.end.send(ImuSample { seq, t_ns: t0, ..Default::default() }, self.mode)?;
            loop {
                match self.end.receive(self.mode)? {
                    Some(s) if s.seq() == seq => break,
                    Some(_) => {}
                    None => anyhow::bail!("ping {seq}: no answer"),
                }
            }
            if k >= warmup {
                rtt.record(now_ns() - t0)?;
            }
        }
        Ok(())
    }

    /// Tells the pong side to exit.
    pub fn finish(self) -> anyhow::Result<()> {
        self.end.send(ImuSample { seq: u64::MAX, ..Default::default() }, self.mode)
    }
}

/// Raw iceoryx2 ping-pong between this process and a pong process (already
/// started on `base`), one ping per tick at `rate_hz`: round-trip times, ns.
pub fn ping(base: &str, mode: Mode, count: u64, rate_hz: f64) -> anyhow::Result<Histogram<u64>> {
    let mut pinger = Pinger::<ImuSample>::connect(base, mode)?;
    let mut rtt = histogram();
    pinger.run(count, 0, rate_hz, &mut rtt)?;
    pinger.finish()?;
    Ok(rtt)
}

/// The next snapshot, busy-polling or sleeping on the event as `mode` says; an
/// error once `deadline` has passed without the snapshot of IMU sample `seq`.
fn next_snapshot(
    state: &mut fusion_client::StateSubscriber,
    mode: Mode,
    deadline: Instant,
    seq: u64,
) -> anyhow::Result<Option<&fusion_client::StateSnapshot>> {
    let left = deadline.saturating_duration_since(Instant::now());
    anyhow::ensure!(!left.is_zero(), "no snapshot for IMU sample {seq}");
    Ok(match mode {
        Mode::Spin => state.spin_next(left)?,
        Mode::Event => state.wait_next(left)?,
    })
}

/// End-to-end latencies.
#[derive(Debug)]
pub struct EndToEnd {
    /// Snapshot received − sample sent, ns.
    pub latency: Histogram<u64>,
    /// The daemon's part of it: snapshot published − sample received (the
    /// daemon's clock), ns. The rest is the two trips through iceoryx2.
    pub daemon: Histogram<u64>,
}

impl EndToEnd {
    /// Empty histograms.
    pub fn new() -> Self {
        Self { latency: histogram(), daemon: histogram() }
    }
}

impl Default for EndToEnd {
    fn default() -> Self {
        Self::new()
    }
}

/// A client of fusiond that publishes IMU samples (plus a position fix every
/// 100th) and waits for the snapshot that names each; it can run in several
/// blocks, its sequence numbers going on from one to the next.
pub struct Prober {
    imu: fusion_client::ImuPublisher,
    pos: fusion_client::PositionPublisher,
    state: fusion_client::StateSubscriber,
    mode: Mode,
    imu_value: ([f64; 3], [f64; 3]),
    seq: u64,
}

impl Prober {
    /// Publishers (IMU sensor 0, position sensor 1) and a reader on `client`.
    pub fn new(client: &Client, mode: Mode, imu_value: ([f64; 3], [f64; 3])) -> anyhow::Result<Self> {
        let mut imu = client.imu_publisher(0)?;
        let mut pos = client.position_publisher(1)?;
        // The daemon only needs waking in event mode.
        imu.set_wake(mode == Mode::Event);
        pos.set_wake(mode == Mode::Event);
        let state = client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER)?;
        Ok(Self { imu, pos, state, mode, imu_value, seq: 0 })
    }

    /// `count` IMU samples at `rate_hz`; all but the first `warmup` are recorded.
    pub fn run(&mut self, count: u64, warmup: u64, rate_hz: f64, out: &mut EndToEnd) -> anyhow::Result<()> {
        let mut pacer = Pacer::new(rate_hz);
        for k in 0..count {
            let seq = self.seq;
            self.seq += 1;
            pacer.wait();
            let t = now_ns();
            if seq % 100 == 50 {
                self.pos.publish(t, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
            }
            self.imu.publish(t, self.imu_value.0, self.imu_value.1)?;
            let deadline = Instant::now() + Duration::from_secs(2);
            loop {
                let snap = next_snapshot(&mut self.state, self.mode, deadline, seq)?;
                if let Some(s) = snap
                    && s.input_kind == 0
                    && s.input_seq == seq
                {
                    let received = now_ns();
                    if k >= warmup {
                        out.latency.record(received.saturating_sub(s.input_sent_ns))?;
                        out.daemon.record(s.publish_ns.saturating_sub(s.input_received_ns))?;
                    }
                    break;
                }
            }
        }
        Ok(())
    }
}

/// Starts `fusiond run` from `bin` in `namespace` with `config` written to `dir`.
pub fn start_daemon(
    bin: &std::path::Path,
    dir: &std::path::Path,
    config: &str,
    namespace: &str,
    mode: Mode,
) -> anyhow::Result<ChildGuard> {
    let path = dir.join(format!("{namespace}.toml"));
    std::fs::write(&path, config)?;
    let child = Command::new(bin)
        .args(["run", "--namespace", namespace, "--wait", mode.name(), "--config"])
        .arg(&path)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()?;
    Ok(ChildGuard(child))
}

/// What the separate publisher process sends (the fan-out rows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PublisherPlan {
    /// IMU rate, Hz.
    pub rate_hz: f64,
    /// IMU samples to send.
    pub count: u64,
    /// IMU and position sensor id.
    pub sensor: u32,
    /// Notify the daemon's wake event (event mode).
    pub wake: bool,
}

impl PublisherPlan {
    /// The plan as environment variables for the re-executed bench binary.
    pub fn to_env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("FUSION_BENCH_RATE", self.rate_hz.to_string()),
            ("FUSION_BENCH_COUNT", self.count.to_string()),
            ("FUSION_BENCH_SENSOR", self.sensor.to_string()),
            ("FUSION_BENCH_WAKE", u8::from(self.wake).to_string()),
        ]
    }

    /// The plan from the environment (see [`to_env`](Self::to_env)).
    pub fn from_env() -> anyhow::Result<Self> {
        let var = |k: &str| std::env::var(k).map_err(|_| anyhow::anyhow!("{k} not set"));
        Ok(Self {
            rate_hz: var("FUSION_BENCH_RATE")?.parse()?,
            count: var("FUSION_BENCH_COUNT")?.parse()?,
            sensor: var("FUSION_BENCH_SENSOR")?.parse()?,
            wake: var("FUSION_BENCH_WAKE")? == "1",
        })
    }
}

/// The publisher process: IMU samples at the plan's rate, plus a position fix
/// every 100th, into `namespace`. Samples carry `t_ns = sent_ns = now`.
pub fn publisher(namespace: &str, plan: PublisherPlan, imu_value: ([f64; 3], [f64; 3])) -> anyhow::Result<()> {
    let client = Client::connect(namespace)?;
    let mut imu = client.imu_publisher(plan.sensor)?;
    let mut pos = client.position_publisher(plan.sensor)?;
    imu.set_wake(plan.wake);
    pos.set_wake(plan.wake);
    // Let the daemon's subscribers connect to the new publishers.
    std::thread::sleep(Duration::from_millis(200));
    let mut pacer = Pacer::new(plan.rate_hz);
    for seq in 0..plan.count {
        pacer.wait();
        let t = now_ns();
        if seq % 100 == 50 {
            pos.publish(t, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
        }
        imu.publish(t, imu_value.0, imu_value.1)?;
    }
    Ok(())
}

/// The fan-out reader: every snapshot of an IMU sample from `sensor` with
/// `seq ≥ skip`, until `count` are recorded or the stream has been quiet for a
/// second: received − sent, ns.
pub fn fan_out_reader(
    client: &Client,
    mode: Mode,
    sensor: u32,
    skip: u64,
    count: u64,
) -> anyhow::Result<Histogram<u64>> {
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    let mut latency = histogram();
    let mut idle_since = Instant::now();
    while latency.len() < count {
        let snap = match mode {
            Mode::Spin => state.spin_next(Duration::from_millis(100))?,
            Mode::Event => state.wait_next(Duration::from_millis(100))?,
        };
        let Some(s) = snap else {
            // The publisher sent `skip + count` samples; a few may have left no
            // snapshot of their own (e.g. refused); once it is quiet, stop.
            if !latency.is_empty() && idle_since.elapsed() > Duration::from_secs(1) {
                break;
            }
            anyhow::ensure!(idle_since.elapsed() < Duration::from_secs(5), "no snapshot for 5 s");
            continue;
        };
        let received = now_ns();
        idle_since = Instant::now();
        if s.input_kind == 0 && s.input_sensor == sensor && s.input_seq >= skip {
            latency.record(received.saturating_sub(s.input_sent_ns))?;
        }
    }
    Ok(latency)
}

/// Late-data cost, measured live at 1 kHz.
#[derive(Debug)]
pub struct LateCost {
    /// Daemon time (snapshot published − sample received) of in-order IMU samples, ns.
    pub imu_processing: Histogram<u64>,
    /// Daemon time of the late fixes (rewind, replay, snapshot), ns.
    pub late_processing: Histogram<u64>,
    /// IMU samples replayed per late fix.
    pub replayed: Histogram<u64>,
    /// End-to-end latency of the IMU sample sent right behind each late fix, ns.
    pub next_after_late: Histogram<u64>,
    /// End-to-end latency of the other IMU samples, ns.
    pub normal: Histogram<u64>,
}

/// Publishes IMU samples at `rate_hz`; every 100th tick a position fix whose time
/// of validity is `late_ns` old goes out just before the IMU sample, so the daemon
/// must rewind and replay about `late_ns × rate` IMU steps before it can process
/// that IMU sample.
pub fn late_data(
    client: &Client,
    mode: Mode,
    count: u64,
    rate_hz: f64,
    late_ns: u64,
    imu_value: ([f64; 3], [f64; 3]),
) -> anyhow::Result<LateCost> {
    let mut imu = client.imu_publisher(0)?;
    let mut pos = client.position_publisher(1)?;
    imu.set_wake(mode == Mode::Event);
    pos.set_wake(mode == Mode::Event);
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    let mut cost = LateCost {
        imu_processing: histogram(),
        late_processing: histogram(),
        replayed: histogram(),
        next_after_late: histogram(),
        normal: histogram(),
    };
    let mut pacer = Pacer::new(rate_hz);
    // The history must first reach back `late_ns`.
    let warmup = (late_ns as f64 * 1e-9 * rate_hz) as u64 + 100;
    let mut late_seq = 0;
    for seq in 0..(count + warmup) {
        pacer.wait();
        let t = now_ns();
        let with_late = seq >= warmup && seq % 100 == 0;
        if with_late {
            pos.publish(t - late_ns, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
        }
        imu.publish(t, imu_value.0, imu_value.1)?;
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut late_seen = !with_late;
        loop {
            let Some(s) = next_snapshot(&mut state, mode, deadline, seq)? else { continue };
            let received = now_ns();
            let processing = s.publish_ns.saturating_sub(s.input_received_ns);
            if s.input_kind == 1 && with_late && s.input_seq == late_seq {
                late_seen = true;
                cost.late_processing.record(processing)?;
                cost.replayed.record(u64::from(s.input_replayed).max(1))?;
            }
            if s.input_kind == 0 && s.input_seq == seq {
                if seq >= warmup {
                    let e2e = received.saturating_sub(s.input_sent_ns);
                    if with_late {
                        anyhow::ensure!(late_seen, "the IMU sample overtook the late fix");
                        cost.next_after_late.record(e2e)?;
                    } else {
                        cost.normal.record(e2e)?;
                        cost.imu_processing.record(processing)?;
                    }
                }
                break;
            }
        }
        if with_late {
            late_seq += 1;
        }
    }
    Ok(cost)
}

/// One throughput trial's result.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Trial {
    /// IMU samples published.
    pub published: u64,
    /// IMU samples of this sensor the daemon received (from the last snapshot).
    pub received: u64,
    /// Samples the daemon counted as lost (sequence gaps: overwritten in its buffer).
    pub lost: u64,
    /// Snapshots the reader missed (gaps in the snapshot sequence numbers).
    pub reader_missed: u64,
}

impl Trial {
    /// Everything published reached the daemon and every snapshot the reader.
    pub fn clean(&self) -> bool {
        self.received == self.published && self.lost == 0 && self.reader_missed == 0
    }
}

/// Publishes `published` IMU samples as sensor `sensor` at `rate_hz`, in slices
/// of 100 µs sent back to back, and between slices reads every snapshot
/// (busy-poll), until the daemon has accounted for all samples (or 3 s after the
/// last was sent). Publisher and reader share this thread, so the run needs two
/// busy cores (daemon and bench), not three.
pub fn throughput(
    client: &Client,
    sensor: u32,
    rate_hz: f64,
    published: u64,
    imu_value: ([f64; 3], [f64; 3]),
) -> anyhow::Result<Trial> {
    let mut imu = client.imu_publisher(sensor)?;
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    // Let the daemon's subscriber connect to the new publisher.
    let connect = Instant::now() + Duration::from_millis(100);
    while Instant::now() < connect {
        while state.try_next()?.is_some() {}
    }
    let mut last_seq: Option<u64> = None;
    let mut trial = Trial { published, received: 0, lost: 0, reader_missed: 0 };
    let mut read = |state: &mut fusion_client::StateSubscriber, trial: &mut Trial| -> anyhow::Result<()> {
        while let Some(s) = state.try_next()? {
            if let Some(prev) = last_seq {
                trial.reader_missed += s.seq.saturating_sub(prev + 1);
            }
            last_seq = Some(s.seq);
            let count = (s.sensor_count as usize).min(s.sensors.len());
            if let Some(c) = s.sensors[..count].iter().find(|c| c.kind == 0 && c.sensor == sensor) {
                trial.received = c.received;
                trial.lost = c.lost;
            }
        }
        Ok(())
    };
    let slice_ns = 100_000u64;
    let per_slice = rate_hz * slice_ns as f64 * 1e-9;
    let start = now_ns();
    let mut sent = 0u64;
    let mut slice = 0u64;
    while sent < published {
        let due = ((slice + 1) as f64 * per_slice).round() as u64;
        while sent < due.min(published) {
            imu.publish(now_ns(), imu_value.0, imu_value.1)?;
            sent += 1;
        }
        slice += 1;
        let next = start + slice * slice_ns;
        while now_ns() < next {
            read(&mut state, &mut trial)?;
        }
    }
    let deadline = Instant::now() + Duration::from_secs(3);
    while trial.received < published && Instant::now() < deadline {
        read(&mut state, &mut trial)?;
    }
    read(&mut state, &mut trial)?;
    Ok(trial)
}
