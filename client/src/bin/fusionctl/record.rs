//! `fusionctl record`: every input sample and every snapshot of a namespace to
//! an MCAP file (topics and messages: `fusion_shared::recording`).
//!
//! The samples are written in the order fusiond processed them, each with the
//! time fusiond received it as its log time: the snapshots name their input and
//! its receive time, so each sample waits (at most [`MATCH_WAIT_NS`]) for the
//! snapshot that reports it. A sample no snapshot reports (fusiond refused it
//! before processing: invalid, duplicate, rate-limited) is written where the
//! recorder received it, by its own clock; one fusiond processed that the
//! recorder never got is counted as missed.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use fusion_client::{Client, ClientError, Sample, SampleKind, StateSnapshot, now_ns};
use fusion_shared::config_record::ConfigRecord;
use fusion_shared::recording::{self, SnapshotJson};
use fusion_shared::snapshot::INPUT_NONE;

/// Bytes of messages gathered before they are written as chunks of their own:
/// the samples and the snapshots go to separate chunks, so that a replay reads
/// (and decompresses) only the samples' chunks. What is gathered is also
/// written at every flush interval (`--flush-interval`).
const BATCH_BYTES: usize = 1 << 20;

/// Default of `fusionctl record --flush-interval`, s: at most this much of a
/// recording (plus the 250 ms a sample waits for its snapshot) is lost when the
/// recorder is killed or loses its power.
pub const DEFAULT_FLUSH_INTERVAL_S: f64 = 1.0;

/// Messages gathered for chunks of their own.
#[derive(Default)]
struct Batch {
    data: Vec<u8>,
    messages: Vec<(mcap::records::MessageHeader, std::ops::Range<usize>)>,
}

/// How long a sample waits for the snapshot that reports it, and a snapshot's
/// input for its sample, by the recorder's clock.
pub const MATCH_WAIT_NS: u64 = 250_000_000;

/// A sample's identity: kind code, sensor, sequence number, time.
type Key = (u32, u32, u64, u64);

fn key_of(s: &Sample) -> Key {
    (s.kind() as u32, s.sensor(), s.seq(), s.t_ns())
}

/// Whether `a` is another IMU sample of the instant of IMU sample `b` (several
/// IMUs averaged: fusiond publishes one snapshot per instant).
fn same_instant(a: Key, b: Key) -> bool {
    a.0 == SampleKind::Imu as u32 && b.0 == a.0 && a.3 == b.3 && a != b
}

/// A processed input, in fusiond's order, and its sample once received.
struct Input {
    key: Key,
    received_ns: u64,
    seen_ns: u64,
    sample: Option<Sample>,
    /// An IMU sample placed before the sample its instant's snapshot names
    /// (it had none of its own), until a snapshot of its own says otherwise.
    inferred: bool,
}

/// A received sample no snapshot has reported yet.
struct Unreported {
    sample: Sample,
    received_ns: u64,
}

/// What a recording counted.
#[derive(Debug, Default, Clone, Copy)]
pub struct Counts {
    /// Sample messages written.
    pub samples: u64,
    /// Snapshots written.
    pub snapshots: u64,
    /// Samples written that no snapshot reported (nor their IMU instant's).
    pub unreported: u64,
    /// Samples fusiond processed that the recorder never received.
    pub missed: u64,
    /// Gaps in a sensor's sequence numbers as the recorder received them.
    pub samples_lost: u64,
    /// Gaps in the snapshot sequence numbers.
    pub snapshots_lost: u64,
}

impl Counts {
    /// Whether the recording holds everything fusiond saw and published.
    pub fn complete(&self) -> bool {
        self.missed == 0 && self.samples_lost == 0 && self.snapshots_lost == 0
    }
}

struct Channels {
    samples: [u16; SampleKind::COUNT],
    state: u16,
    pose: u16,
    location: u16,
}

/// The MCAP writer and the matching of samples to snapshots.
pub struct Recorder<W: Write + std::io::Seek> {
    mcap: mcap::Writer<W>,
    channels: Channels,
    inputs: VecDeque<Input>,
    unreported: VecDeque<Unreported>,
    highest_seq: HashMap<(u32, u32), u64>,
    last_snapshot: Option<u64>,
    sequence: u32,
    buf: Vec<u8>,
    samples: Batch,
    snapshots: Batch,
    counts: Counts,
    /// The wall clock's lead over CLOCK_MONOTONIC at the start: added to every
    /// log and publish time (and the `foxglove.*` timestamps), so that other
    /// tools show the run's date and time.
    wall_offset_ns: u64,
}

impl<W: Write + std::io::Seek> Recorder<W> {
    /// Starts a recording in `out` with every channel declared, and the
    /// wall clock's lead over CLOCK_MONOTONIC (`wall_offset_ns`) in the
    /// metadata `fusion.clock`.
    pub fn new(out: W, compress: bool, wall_offset_ns: u64) -> anyhow::Result<Self> {
        let compression = compress.then_some(mcap::Compression::Zstd);
        let mut mcap = mcap::WriteOptions::new()
            .compression(compression)
            .profile("")
            .library(concat!("fusionctl ", env!("CARGO_PKG_VERSION")))
            .create(out)?;
        let none = BTreeMap::new();
        let mut channel = |topic: &str, name: &str, schema: &str| -> anyhow::Result<u16> {
            let id = mcap.add_schema(name, recording::SCHEMA_ENCODING, schema.as_bytes())?;
            Ok(mcap.add_channel(id, topic, recording::MESSAGE_ENCODING, &none)?)
        };
        let mut samples = [0; SampleKind::COUNT];
        for &kind in SampleKind::ALL {
            let (name, schema) = recording::sample_schema(kind);
            samples[kind.index()] = channel(&recording::sample_topic(kind), &name, &schema)?;
        }
        let channels = Channels {
            samples,
            state: channel(recording::STATE_TOPIC, recording::STATE_SCHEMA, &recording::state_schema())?,
            pose: channel(recording::POSE_TOPIC, recording::POSE_SCHEMA, recording::POSE_IN_FRAME_JSON_SCHEMA)?,
            location: channel(
                recording::LOCATION_TOPIC,
                recording::LOCATION_SCHEMA,
                recording::LOCATION_FIX_JSON_SCHEMA,
            )?,
        };
        let clock = [(recording::CLOCK_OFFSET_KEY.to_string(), wall_offset_ns.to_string())].into_iter().collect();
        mcap.write_metadata(&mcap::records::Metadata { name: recording::CLOCK_METADATA.into(), metadata: clock })?;
        Ok(Self {
            mcap,
            channels,
            wall_offset_ns,
            inputs: VecDeque::new(),
            unreported: VecDeque::new(),
            highest_seq: HashMap::new(),
            last_snapshot: None,
            sequence: 0,
            buf: Vec::with_capacity(8192),
            samples: Batch::default(),
            snapshots: Batch::default(),
            counts: Counts::default(),
        })
    }

    /// Keeps fusiond's configuration with the run: the MCAP metadata
    /// `fusion.config` (its TOML, fusiond's version, the snapshot wire type),
    /// written at the start of the file so that a cut-off recording has it too.
    pub fn write_config(&mut self, record: &ConfigRecord) -> anyhow::Result<()> {
        use fusion_shared::config_record as c;
        let text = record.text().context("fusiond's configuration is not UTF-8")?;
        let metadata = [
            (c::METADATA_TOML, text),
            (c::METADATA_VERSION, record.version().unwrap_or("unknown")),
            (c::METADATA_WIRE, c::snapshot_wire()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        self.mcap.write_metadata(&mcap::records::Metadata { name: c::METADATA_NAME.into(), metadata })?;
        Ok(())
    }

    /// What was counted so far.
    pub fn counts(&self) -> Counts {
        self.counts
    }

    /// Adds the message in `buf` to its batch, writing the batch when it is
    /// full. `log_time` and `publish_time` are CLOCK_MONOTONIC (0: unknown); the
    /// record gets them wall-clock.
    fn write(&mut self, channel_id: u16, log_time: u64, publish_time: u64) -> anyhow::Result<()> {
        let wall = |t: u64| if t == 0 { 0 } else { t.saturating_add(self.wall_offset_ns) };
        let (log_time, publish_time) = (wall(log_time), wall(publish_time));
        let header = mcap::records::MessageHeader { channel_id, sequence: self.sequence, log_time, publish_time };
        self.sequence = self.sequence.wrapping_add(1);
        let sample = self.channels.samples.contains(&channel_id);
        let batch = if sample { &mut self.samples } else { &mut self.snapshots };
        let start = batch.data.len();
        batch.data.extend_from_slice(&self.buf);
        batch.messages.push((header, start..batch.data.len()));
        if batch.data.len() >= BATCH_BYTES {
            Self::write_batch(&mut self.mcap, batch)?;
        }
        Ok(())
    }

    /// Writes `batch` as chunks of its own.
    fn write_batch(mcap: &mut mcap::Writer<W>, batch: &mut Batch) -> anyhow::Result<()> {
        for (header, range) in batch.messages.drain(..) {
            mcap.write_to_known_channel(&header, &batch.data[range])?;
        }
        batch.data.clear();
        mcap.flush()?;
        Ok(())
    }

    fn write_sample(&mut self, sample: &Sample, log_time: u64) -> anyhow::Result<()> {
        self.buf.clear();
        recording::write_sample(sample, &mut self.buf);
        self.write(self.channels.samples[sample.kind().index()], log_time, sample.sent_ns())?;
        self.counts.samples += 1;
        Ok(())
    }

    /// A sample received at `now`.
    pub fn sample(&mut self, sample: Sample, now: u64) {
        let stream = (sample.kind() as u32, sample.sensor());
        let seq = sample.seq();
        match self.highest_seq.get(&stream) {
            Some(&h) if seq > h => self.counts.samples_lost += seq - h - 1,
            Some(_) => {}
            None => {}
        }
        let highest = self.highest_seq.entry(stream).or_insert(seq);
        *highest = (*highest).max(seq);
        let key = key_of(&sample);
        if let Some(input) = self.inputs.iter_mut().find(|i| i.sample.is_none() && i.key == key) {
            input.sample = Some(sample);
            return;
        }
        // An IMU sample of an instant whose snapshot came first, named after
        // another of its samples: it was processed just before that one.
        match self.inputs.iter().position(|i| same_instant(i.key, key)) {
            Some(at) => {
                let received_ns = self.inputs[at].received_ns;
                let input = Input { key, received_ns, seen_ns: now, sample: Some(sample), inferred: true };
                self.inputs.insert(at, input);
            }
            None => self.unreported.push_back(Unreported { sample, received_ns: now }),
        }
    }

    /// A snapshot received at `now`: written at once, its input queued for its sample.
    pub fn snapshot(&mut self, s: &StateSnapshot, now: u64) -> anyhow::Result<()> {
        if let Some(last) = self.last_snapshot
            && s.seq > last + 1
        {
            self.counts.snapshots_lost += s.seq - last - 1;
        }
        self.last_snapshot = Some(s.seq);
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, &SnapshotJson::from(s))?;
        self.write(self.channels.state, s.publish_ns, s.publish_ns)?;
        self.counts.snapshots += 1;
        if s.input_kind == INPUT_NONE {
            return Ok(());
        }
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, &recording::pose_in_frame(s, self.wall_offset_ns))?;
        self.write(self.channels.pose, s.publish_ns, s.t_ns)?;
        if let Some(fix) = recording::location_fix(s, self.wall_offset_ns) {
            self.buf.clear();
            serde_json::to_writer(&mut self.buf, &fix)?;
            self.write(self.channels.location, s.publish_ns, s.t_ns)?;
        }
        let key = (s.input_kind, s.input_sensor, s.input_seq, s.input_t_ns);
        // Several IMUs averaged: the instant's snapshot names the sample that
        // completed it; the instant's other samples, processed before it, have
        // no snapshot of their own.
        while let Some(i) = self.unreported.iter().position(|u| same_instant(key_of(&u.sample), key)) {
            let u = self.unreported.remove(i).expect("found");
            let (received_ns, sample) = (u.received_ns, Some(u.sample));
            self.inputs.push_back(Input { key: key_of(&u.sample), received_ns, seen_ns: now, sample, inferred: true });
        }
        // A sample taken for an instant's earlier one that has a snapshot of
        // its own after all (the first instant, or one published at its due
        // time): it goes here.
        let inferred = self.inputs.iter().position(|i| i.inferred && i.key == key).and_then(|i| self.inputs.remove(i));
        let sample = inferred.and_then(|i| i.sample).or_else(|| {
            let at = self.unreported.iter().position(|u| key_of(&u.sample) == key)?;
            self.unreported.remove(at).map(|u| u.sample)
        });
        self.inputs.push_back(Input { key, received_ns: s.input_received_ns, seen_ns: now, sample, inferred: false });
        Ok(())
    }

    /// Writes every message gathered so far as complete chunks, and hands them
    /// to the operating system.
    pub fn write_held(&mut self) -> anyhow::Result<()> {
        Self::write_batch(&mut self.mcap, &mut self.samples)?;
        Self::write_batch(&mut self.mcap, &mut self.snapshots)?;
        Ok(())
    }

    /// Writes the samples whose place is settled at `now` (all of them when
    /// `now` is `u64::MAX`): the processed ones in fusiond's order, the
    /// unreported ones before the first processed one fusiond received after
    /// them.
    pub fn flush(&mut self, now: u64) -> anyhow::Result<()> {
        let settled = |t: u64| t.saturating_add(MATCH_WAIT_NS) <= now;
        loop {
            // An input whose sample never came: fusiond had it, the recorder not.
            while let Some(i) = self.inputs.front()
                && i.sample.is_none()
                && settled(i.seen_ns)
            {
                self.inputs.pop_front();
                self.counts.missed += 1;
            }
            let input = self.inputs.front().filter(|i| i.sample.is_some());
            let unreported = self.unreported.front().filter(|u| settled(u.received_ns));
            match (input, unreported) {
                (Some(i), Some(u)) if u.received_ns < i.received_ns => self.write_unreported()?,
                (Some(i), _) if settled(i.received_ns.max(i.seen_ns)) => {
                    let i = self.inputs.pop_front().expect("front exists");
                    let sample = i.sample.expect("filtered on a sample");
                    self.write_sample(&sample, i.received_ns)?;
                }
                (None, Some(_)) if self.inputs.front().is_none() => self.write_unreported()?,
                _ => return Ok(()),
            }
        }
    }

    fn write_unreported(&mut self) -> anyhow::Result<()> {
        let u = self.unreported.pop_front().expect("front exists");
        self.write_sample(&u.sample, u.received_ns)?;
        self.counts.unreported += 1;
        Ok(())
    }

    /// Writes what is still held, the counts as metadata (`fusion.recording`)
    /// and the MCAP summary.
    pub fn finish(mut self) -> anyhow::Result<Counts> {
        self.flush(u64::MAX)?;
        for _ in self.inputs.drain(..) {
            self.counts.missed += 1;
        }
        while !self.unreported.is_empty() {
            self.write_unreported()?;
        }
        let c = self.counts;
        let metadata = [
            ("samples", c.samples),
            ("snapshots", c.snapshots),
            ("unreported", c.unreported),
            ("missed", c.missed),
            ("samples_lost", c.samples_lost),
            ("snapshots_lost", c.snapshots_lost),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        Self::write_batch(&mut self.mcap, &mut self.samples)?;
        Self::write_batch(&mut self.mcap, &mut self.snapshots)?;
        self.mcap.write_metadata(&mcap::records::Metadata { name: "fusion.recording".into(), metadata })?;
        self.mcap.finish()?;
        Ok(c)
    }
}

/// The state service of fusiond in `namespace`, waiting for one to run (said
/// once on stderr) until `duration` or a signal.
fn wait_for_fusiond(
    client: &Client,
    namespace: &str,
    duration: Option<Duration>,
    stop: &AtomicBool,
) -> anyhow::Result<fusion_client::StateSubscriber> {
    let mut waited = false;
    let waiting_since = Instant::now();
    loop {
        match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
            Ok(s) => return Ok(s),
            Err(ClientError::DaemonNotRunning { .. }) if !stop.load(Ordering::Relaxed) => {
                if let Some(d) = duration
                    && waiting_since.elapsed() >= d
                {
                    anyhow::bail!(
                        "no fusiond ran in namespace {namespace:?} within the {:.1} s of --duration: nothing recorded \
                         (is the namespace right? `fusionctl state --namespace NS` asks one)",
                        d.as_secs_f64()
                    );
                }
                if !waited {
                    eprintln!("fusionctl: waiting for fusiond in namespace {namespace:?} …");
                    waited = true;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
            Err(e) => return Err(e.into()),
        }
    }
}

/// The progress line: what was recorded, at what rate since `last` (then now).
fn progress<W: std::io::Write + std::io::Seek>(
    recorder: &Recorder<W>,
    output: &Path,
    last: &mut (Instant, u64),
    terminal: bool,
) {
    let c = recorder.counts();
    let rate = (c.samples - last.1) as f64 / last.0.elapsed().as_secs_f64();
    *last = (Instant::now(), c.samples);
    let line = format!(
        "recording {}: {} samples, {} snapshots, {:.1} MB, {rate:.0} samples/s, lost {}",
        output.display(),
        c.samples,
        c.snapshots,
        std::fs::metadata(output).map_or(0, |m| m.len()) as f64 / 1e6,
        c.samples_lost + c.snapshots_lost + c.missed
    );
    if terminal {
        eprint!("\r{line}\x1b[K");
    } else {
        eprintln!("{line}");
    }
}

/// Records namespace `namespace` to `output` until `stop` is set or `duration`
/// passes, with a progress line on stderr. Every `flush_interval` what was
/// gathered is written as complete chunks and synced to the disk: a recorder
/// killed or without power loses at most that (a reader uses every complete
/// chunk of a cut-off file).
pub fn run(
    namespace: &str,
    output: &Path,
    duration: Option<Duration>,
    compress: bool,
    flush_interval: Duration,
    stop: &AtomicBool,
) -> anyhow::Result<Counts> {
    let client = Client::connect(namespace)?;
    let mut samples = client.sample_subscriber()?;
    let mut state = wait_for_fusiond(&client, namespace, duration, stop)?;
    let file = File::create(output).with_context(|| format!("cannot create {}", output.display()))?;
    // The same open file, for syncing what was written to the disk.
    let sync = file.try_clone()?;
    let wall_offset = fusion_shared::time::wall_minus_monotonic_ns();
    let mut recorder = Recorder::new(BufWriter::with_capacity(1 << 20, file), compress, wall_offset)?;
    match client.fusiond_config(Duration::from_secs(2))? {
        Some(config) => recorder.write_config(&config)?,
        None => eprintln!(
            "fusionctl: fusiond in namespace {namespace:?} publishes no configuration (a version before it did): the \
             recording will not carry it, and its replay needs --config"
        ),
    }
    let mut next_flush = Instant::now() + flush_interval;
    let started = Instant::now();
    let terminal = std::io::stderr().is_terminal();
    let mut next_progress = started + Duration::from_secs(1);
    let mut last = (started, 0u64);
    while !stop.load(Ordering::Relaxed) && duration.is_none_or(|d| started.elapsed() < d) {
        let mut busy = false;
        while let Some(s) = samples.try_next()? {
            recorder.sample(s, now_ns());
            busy = true;
        }
        while let Some(s) = state.try_next()? {
            recorder.snapshot(s, now_ns())?;
            busy = true;
        }
        recorder.flush(now_ns())?;
        if Instant::now() >= next_flush {
            recorder.write_held()?;
            sync.sync_data().with_context(|| format!("cannot sync {}", output.display()))?;
            next_flush = Instant::now() + flush_interval;
        }
        if Instant::now() >= next_progress {
            progress(&recorder, output, &mut last, terminal);
            next_progress += Duration::from_secs(if terminal { 1 } else { 5 });
        }
        if !busy {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    // What arrived until now, then everything held.
    while let Some(s) = samples.try_next()? {
        recorder.sample(s, now_ns());
    }
    while let Some(s) = state.try_next()? {
        recorder.snapshot(s, now_ns())?;
    }
    let counts = recorder.finish()?;
    if terminal {
        eprintln!();
    }
    Ok(counts)
}
