//! The four streams of a bridge, each on a thread of its own with its own
//! iceoryx2 node: snapshots out to Zenoh and in from it, samples out and in;
//! the wire types' bytes and their encoding, and what each stream counts.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use fusion_client::{Client, SampleSubscriber, SensorPublishers};
use fusion_shared::service::{self, ServiceNames};
use fusion_shared::{KindFn, KindVisitor, PayloadFn, Sample, SampleKind, StateSnapshot, WireSample};
use iceoryx2::prelude::ZeroCopySend;
use zenoh::Wait;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;

/// What one stream did, for the status lines and the last line.
#[derive(Default)]
pub struct Counts {
    pub forwarded: AtomicU64,
    pub refused: AtomicU64,
    /// `--state in`: snapshots missing from the sequence (the exporting side
    /// lagged behind fusiond, or the bridge restarted).
    pub gaps: AtomicU64,
}

impl Counts {
    pub fn line(&self) -> String {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        format!("forwarded {}, refused {}, gaps {}", get(&self.forwarded), get(&self.refused), get(&self.gaps))
    }
}

/// The Zenoh keys of one namespace.
#[derive(Clone)]
pub struct Keys {
    /// `<prefix>/<ns>`.
    pub prefix: String,
}

impl Keys {
    pub fn state(&self) -> String {
        format!("{}/state", self.prefix)
    }

    pub fn samples(&self, kind: SampleKind) -> String {
        format!("{}/samples/{}", self.prefix, kind.name())
    }
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
pub fn state_out(
    ns: &str,
    session: &zenoh::Session,
    key: &str,
    stop: &AtomicBool,
    counts: &Counts,
) -> anyhow::Result<()> {
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
pub fn state_in(
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
pub fn samples_out(
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
pub fn samples_in(
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
