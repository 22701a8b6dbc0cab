//! Latency measurements over real processes: raw iceoryx2 ping-pong (the floor)
//! and fusiond end to end (sample published → snapshot of that sample received).

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fusion_client::{Client, ImuSample, now_ns};
use fusion_shared::service;
use hdrhistogram::Histogram;
use iceoryx2::port::listener::Listener;
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

/// One end of the raw ping-pong.
struct PingPongEnd {
    _node: Node<ipc::Service>,
    publisher: Publisher<ipc::Service, ImuSample, ()>,
    subscriber: Subscriber<ipc::Service, ImuSample, ()>,
    notifier: Notifier<ipc::Service>,
    listener: Listener<ipc::Service>,
}

impl PingPongEnd {
    /// `send_to`/`receive_from`: the two directions, `<base>/ping` and `<base>/pong`.
    fn open(base: &str, send_to: &str, receive_from: &str) -> anyhow::Result<Self> {
        let node = service::create_node("bench", &service::iceoryx_config(None).map_err(anyhow::Error::msg)?)
            .map_err(anyhow::Error::msg)?;
        let pubsub = |dir: &str| -> anyhow::Result<_> {
            let name: ServiceName = format!("{base}/{dir}").as_str().try_into()?;
            Ok(node.service_builder(&name).publish_subscribe::<ImuSample>().open_or_create()?)
        };
        let event = |dir: &str| -> anyhow::Result<_> {
            let name: ServiceName = format!("{base}/{dir}-event").as_str().try_into()?;
            Ok(node.service_builder(&name).event().open_or_create()?)
        };
        let publisher = pubsub(send_to)?.publisher_builder().create()?;
        let subscriber = pubsub(receive_from)?.subscriber_builder().create()?;
        let notifier = event(send_to)?.notifier_builder().create()?;
        let listener = event(receive_from)?.listener_builder().create()?;
        Ok(Self { _node: node, publisher, subscriber, notifier, listener })
    }

    fn send(&self, sample: ImuSample, mode: Mode) -> anyhow::Result<()> {
        self.publisher.send_copy(sample)?;
        if mode == Mode::Event {
            self.notifier.notify()?;
        }
        Ok(())
    }

    /// Waits for the next sample (up to 1 s).
    fn receive(&self, mode: Mode) -> anyhow::Result<Option<ImuSample>> {
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
                Mode::Event => {
                    self.listener.timed_wait(|_| {}, Duration::from_millis(100))?;
                }
            }
        }
    }
}

/// The pong side: echoes every sample until one with `seq == u64::MAX`.
pub fn pong(base: &str, mode: Mode) -> anyhow::Result<()> {
    let end = PingPongEnd::open(base, "pong", "ping")?;
    let idle_deadline = Instant::now() + Duration::from_secs(30);
    loop {
        match end.receive(mode)? {
            Some(s) if s.seq == u64::MAX => return Ok(()),
            Some(s) => end.send(s, mode)?,
            None if Instant::now() > idle_deadline => anyhow::bail!("pong: no ping for 30 s"),
            None => {}
        }
    }
}

/// Ends a child process however it is (kill, then reap).
pub struct ChildGuard(pub Child);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
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

/// Raw iceoryx2 ping-pong with an `ImuSample` payload between this process and
/// `pong_process` (already started on `base`), one ping per tick at `rate_hz`:
/// round-trip times, ns.
pub fn ping(
    base: &str,
    mode: Mode,
    count: u64,
    rate_hz: f64,
    _pong: &mut ChildGuard,
) -> anyhow::Result<Histogram<u64>> {
    let end = PingPongEnd::open(base, "ping", "pong")?;
    let mut rtt = histogram();
    // Let the pong side connect: retry the first ping until it answers.
    let started = Instant::now();
    loop {
        end.send(ImuSample { seq: u64::MAX - 1, ..Default::default() }, mode)?;
        if end.receive(mode)?.is_some() {
            break;
        }
        anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "pong did not answer");
    }
    let mut pacer = Pacer::new(rate_hz);
    for seq in 0..count {
        pacer.wait();
        let t0 = now_ns();
        end.send(ImuSample { seq, t_ns: t0, ..Default::default() }, mode)?;
        loop {
            match end.receive(mode)? {
                Some(s) if s.seq == seq => break,
                Some(_) => {}
                None => anyhow::bail!("ping {seq}: no answer"),
            }
        }
        rtt.record(now_ns() - t0)?;
    }
    end.send(ImuSample { seq: u64::MAX, ..Default::default() }, mode)?;
    Ok(rtt)
}

/// fusiond end to end: publishes `count` IMU samples at `rate_hz` (plus a position
/// fix every 100th), each time waiting for the snapshot that names the sample;
/// latency = snapshot received − sample sent, ns.
pub fn end_to_end(
    client: &Client,
    mode: Mode,
    count: u64,
    rate_hz: f64,
    imu_value: ([f64; 3], [f64; 3]),
) -> anyhow::Result<Histogram<u64>> {
    let mut imu = client.imu_publisher(0)?;
    let mut pos = client.position_publisher(1)?;
    // The daemon only needs waking in event mode.
    imu.set_wake(mode == Mode::Event);
    pos.set_wake(mode == Mode::Event);
    let mut state = client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER)?;
    let mut latency = histogram();
    let mut pacer = Pacer::new(rate_hz);
    let warmup = count / 10;
    for seq in 0..(count + warmup) {
        pacer.wait();
        let t = now_ns();
        if seq % 100 == 50 {
            pos.publish(t, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
        }
        imu.publish(t, imu_value.0, imu_value.1)?;
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            anyhow::ensure!(!left.is_zero(), "no snapshot for IMU sample {seq}");
            let snap = match mode {
                Mode::Spin => state.spin_next(left)?,
                Mode::Event => state.wait_next(left)?,
            };
            if let Some(s) = snap
                && s.input_kind == 0
                && s.input_seq == seq
            {
                let received = now_ns();
                if seq >= warmup {
                    latency.record(received.saturating_sub(s.input_sent_ns))?;
                }
                break;
            }
        }
    }
    Ok(latency)
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
