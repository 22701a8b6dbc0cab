//! The floor: raw iceoryx2 ping-pong between this process and a pong process,
//! busy-polling or sleeping on an event, answering with an `ImuSample` or a whole
//! `StateSnapshot`.

use std::time::{Duration, Instant};

use fusion_client::{ImuSample, StateSnapshot, now_ns};
use fusion_shared::service;
use hdrhistogram::Histogram;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe;

use super::{Mode, Pacer, histogram};

/// A ping from this sensor id opens an instant of several samples and is
/// not answered: the pong side answers the instant's last one (the two-sample
/// baseline of the per-instant vehicle rows, [`Pinger::run_instants`]).
pub const OPENS_INSTANT: u32 = 100;

/// A payload of the raw ping-pong: it carries the sequence number it answers.
pub trait Payload: ZeroCopySend + Copy + std::fmt::Debug + Default + 'static {
    /// The sequence number.
    fn seq(&self) -> u64;
    /// Whether the pong side answers it (not a ping that opens an instant).
    fn answered(&self) -> bool {
        true
    }
    /// Its time stamp, ns.
    fn stamp(&self) -> u64;
    /// A payload with `seq`, stamped `t_ns`.
    fn with_seq(seq: u64, t_ns: u64) -> Self;
}

impl Payload for ImuSample {
    fn seq(&self) -> u64 {
        self.header.seq
    }
    fn stamp(&self) -> u64 {
        self.header.t_ns
    }
    fn answered(&self) -> bool {
        self.header.sensor != OPENS_INSTANT
    }
    fn with_seq(seq: u64, t_ns: u64) -> Self {
        ImuSample::new(t_ns, 0, seq, [0.0; 3], [0.0; 3])
    }
}

/// The answer the size of what fusiond answers with (4.2 KB), every byte written.
impl Payload for StateSnapshot {
    fn seq(&self) -> u64 {
        self.seq
    }
    fn stamp(&self) -> u64 {
        self.publish_ns
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
    /// `buffered`: with fusiond's own buffers (a subscriber's queue of
    /// [`service::SAMPLE_BUFFER`] pings, [`service::STATE_BUFFER`] pongs), for
    /// the throughput floor; else iceoryx2's defaults, for the latency floor.
    fn open(base: &str, send_to: &str, receive_from: &str, buffered: bool) -> anyhow::Result<Self> {
        // Plain `ipc::Service`, as an application using iceoryx2 directly would (fusiond's
        // ports use `fusion_shared::transport::Ipc`, the same with pooled loan state).
        let node = NodeBuilder::new()
            .name(&"bench".try_into()?)
            .config(&service::iceoryx_config(None).map_err(anyhow::Error::msg)?)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()?;
        let name = |dir: &str| -> anyhow::Result<ServiceName> { Ok(format!("{base}/{dir}").as_str().try_into()?) };
        let event = |dir: &str| -> anyhow::Result<_> {
            Ok(node.service_builder(&name(&format!("{dir}-event"))?).event().open_or_create()?)
        };
        let buffer = |dir: &str| match (buffered, dir) {
            (false, _) => None,
            (true, "ping") => Some(service::SAMPLE_BUFFER),
            (true, _) => Some(service::STATE_BUFFER),
        };
        let publisher = sized(node.service_builder(&name(send_to)?).publish_subscribe::<S>(), buffer(send_to))
            .open_or_create()?
            .publisher_builder()
            .create()?;
        let incoming = sized(node.service_builder(&name(receive_from)?).publish_subscribe::<R>(), buffer(receive_from))
            .open_or_create()?;
        let subscriber = match buffer(receive_from) {
            Some(n) => incoming.subscriber_builder().buffer_size(n),
            None => incoming.subscriber_builder(),
        }
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

    /// The next sample's sequence number, if one is there.
    fn try_receive(&self) -> anyhow::Result<Option<u64>> {
        Ok(self.subscriber.receive()?.map(|s| s.seq()))
    }

    /// Waits for the next sample (up to 1 s): its sequence number, time stamp
    /// and whether it is answered,
    /// read in shared memory as fusiond's readers read a snapshot (not copied out:
    /// copying a 4.2 KB answer would charge the floor for work a reader never does).
    fn receive(&self, mode: Mode) -> anyhow::Result<Option<(u64, u64, bool)>> {
        let deadline = Instant::now() + Duration::from_secs(1);
        loop {
            if let Some(s) = self.subscriber.receive()? {
                return Ok(Some((s.seq(), s.stamp(), s.answered())));
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

/// A service of subscriber queues of `buffer` samples and no history (else
/// iceoryx2's defaults).
fn sized<P: Payload>(
    builder: publish_subscribe::Builder<P, (), ipc::Service>,
    buffer: Option<usize>,
) -> publish_subscribe::Builder<P, (), ipc::Service> {
    match buffer {
        Some(n) => builder.subscriber_max_buffer_size(n).history_size(0),
        None => builder,
    }
}

/// The pong side: answers every ping with an `R` of the same sequence number until
/// one with `seq == u64::MAX`; gives up after 30 s without a ping. `buffered`:
/// with fusiond's buffers (the throughput floor's relay).
pub fn pong<R: Payload>(base: &str, mode: Mode, buffered: bool) -> anyhow::Result<()> {
    let end = PingPongEnd::<R, ImuSample>::open(base, "pong", "ping", buffered)?;
    let mut last_ping = Instant::now();
    loop {
        match end.receive(mode)? {
            Some((seq, _, _)) if seq == u64::MAX => return Ok(()),
            Some((seq, t_ns, answered)) => {
                last_ping = Instant::now();
                if answered {
                    end.send(R::with_seq(seq, t_ns), mode)?;
                }
            }
            None if last_ping.elapsed() > Duration::from_secs(30) => anyhow::bail!("pong: no ping for 30 s"),
            None => {}
        }
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
        let end = PingPongEnd::open(base, "ping", "pong", false)?;
        let started = Instant::now();
        loop {
            end.send(ImuSample::new(0, 0, u64::MAX - 1, [0.0; 3], [0.0; 3]), mode)?;
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
        self.run_instants(count, warmup, rate_hz, 1, rtt)
    }

    /// [`run`](Self::run) with `per_instant` pings a tick, as the samples of
    /// the IMUs of one instant: the first `per_instant − 1` are not answered
    /// ([`OPENS_INSTANT`]); the round trip is timed from the send of the last,
    /// as a per-instant fusiond row is timed from the instant's last sample.
    pub fn run_instants(
        &mut self,
        count: u64,
        warmup: u64,
        rate_hz: f64,
        per_instant: u32,
        rtt: &mut Histogram<u64>,
    ) -> anyhow::Result<()> {
        let mut pacer = Pacer::new(rate_hz);
        for k in 0..count {
            pacer.wait();
            let seq = self.seq;
            self.seq += 1;
            for _ in 1..per_instant {
                self.end.send(ImuSample::new(now_ns(), OPENS_INSTANT, seq, [0.0; 3], [0.0; 3]), self.mode)?;
            }
            let t0 = now_ns();
            self.end.send(ImuSample::new(t0, 0, seq, [0.0; 3], [0.0; 3]), self.mode)?;
            loop {
                match self.end.receive(self.mode)? {
                    Some((answered, _, _)) if answered == seq => break,
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
        self.end.send(ImuSample::new(0, 0, u64::MAX, [0.0; 3], [0.0; 3]), self.mode)
    }
}

/// The throughput floor: raw iceoryx2 through a relay process (a pong side
/// started `buffered` on `base`, answering each `ImuSample` with a 4.2 KB
/// `StateSnapshot`), with fusiond's own buffers: the path of fusiond's
/// throughput trials without the filter.
pub struct RawRelay {
    end: PingPongEnd<ImuSample, StateSnapshot>,
    seq: u64,
}

impl RawRelay {
    /// Connects to the relay: retries a first ping until it answers.
    pub fn connect(base: &str) -> anyhow::Result<Self> {
        let end = PingPongEnd::open(base, "ping", "pong", true)?;
        let started = Instant::now();
        loop {
            end.send(ImuSample::new(0, 0, u64::MAX - 1, [0.0; 3], [0.0; 3]), Mode::Spin)?;
            if end.receive(Mode::Spin)?.is_some() {
                break;
            }
            anyhow::ensure!(started.elapsed() < Duration::from_secs(20), "the relay did not answer");
        }
        Ok(Self { end, seq: 0 })
    }

    /// The sequence number of the next ping.
    pub fn next_seq(&self) -> u64 {
        self.seq
    }

    /// Sends the next ping.
    pub fn send(&mut self) -> anyhow::Result<()> {
        self.end.send(ImuSample::new(now_ns(), 0, self.seq, [0.0; 3], [0.0; 3]), Mode::Spin)?;
        self.seq += 1;
        Ok(())
    }

    /// Every answer there: `each(seq)`.
    pub fn read(&mut self, mut each: impl FnMut(u64)) -> anyhow::Result<()> {
        while let Some(seq) = self.end.try_receive()? {
            each(seq);
        }
        Ok(())
    }

    /// Tells the relay to exit.
    pub fn finish(self) -> anyhow::Result<()> {
        self.end.send(ImuSample::new(0, 0, u64::MAX, [0.0; 3], [0.0; 3]), Mode::Spin)
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
