//! Replay of an MCAP recording (`fusionctl record`; topics and messages in
//! `fusion_shared::recording`): the sample messages in file order, which is
//! the order fusiond processed them live, each with the time fusiond received
//! it (the message's log time) as the engine's clock, so that every decision
//! that depends on arrival (future and past timestamps) is taken again as it
//! was live.
//!
//! [`LiveComparison`] then holds the replay against the recorded snapshots:
//! after each processed sample, the replayed estimate (x, P, NIS, outcome) and
//! every counter must equal the live snapshot's, bit for bit.

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use fusion_shared::SampleKind;
use fusion_shared::mcap_scan::{self, Damage, Scan};
use fusion_shared::recording::{self, SAMPLE_TOPIC_PREFIX, SnapshotJson};

use super::{InputItem, ReplayCheck, ReplayError, ReplaySummary, replay_items, samples_read};
use crate::config::Config;
use crate::engine::Engine;
use crate::health::HealthNow;
use crate::measurement::Steps;
use crate::reorder::Sample;
use crate::snapshot::{self, Input};

/// Differences described one by one in a [`ComparisonReport`].
pub const DIFFERENCES_REPORTED: usize = 10;

/// The configuration a recording was made with ([`Recording::config`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedConfig {
    /// The TOML text of fusiond's configuration file.
    pub toml: String,
    /// fusiond's version.
    pub fusiond_version: String,
    /// The snapshot wire type fusiond published (`fusion.StateSnapshot.vN`).
    pub snapshot_wire: String,
}

/// An MCAP recording, mapped into memory.
///
/// A recording cut off (the recorder killed, or its power lost) has no summary
/// and ends in the middle of a record: it is read up to its last complete
/// record (every complete chunk), and [`Recording::was_cut_off`] says so.
pub struct Recording {
    map: memmap2::Mmap,
    /// The readable part of the map: all of it, or up to a damaged record.
    readable: usize,
    /// The damage that ends the readable part, if any.
    damage: Option<Damage>,
    /// The summary section, if the file has one (a cut-off recording has not).
    summary: Option<mcap::Summary>,
    /// A read of it ended at a record cut off by the end of the file.
    cut_off: AtomicBool,
}

/// Ends `messages` at a record cut off by the end of the file (a recording
/// whose writer was killed), setting `cut_off`; every other error stays one.
fn until_cut<'a, T>(
    messages: impl Iterator<Item = mcap::McapResult<T>> + 'a,
    cut_off: &'a AtomicBool,
) -> impl Iterator<Item = mcap::McapResult<T>> + 'a {
    messages.map_while(move |m| match m {
        Err(mcap::McapError::UnexpectedEof) => {
            cut_off.store(true, Ordering::Relaxed);
            None
        }
        m => Some(m),
    })
}

fn mcap_error(e: mcap::McapError) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, format!("MCAP: {e}"))
}

impl Recording {
    /// Opens `path`.
    pub fn open(path: &Path) -> std::io::Result<Self> {
        let file = File::open(path)?;
        // SAFETY: the map is only read. Another process truncating the file while
        // it is mapped would fault the reader (SIGBUS); a recording being replayed
        // is not written to (`fusionctl record` writes a new file).
        let map = unsafe { memmap2::Mmap::map(&file)? };
        // A damaged chunk is never handed to the mcap reader (it would believe
        // the sizes it declares): the recording is read up to it, without the
        // summary (whose index points past it).
        let Scan { readable, damage } = mcap_scan::scan(&map);
        let summary = if damage.is_none() { mcap::Summary::read(&map).ok().flatten() } else { None };
        Ok(Self { map, readable, damage, summary, cut_off: AtomicBool::new(false) })
    }

    /// The part of the file that is read.
    fn bytes(&self) -> &[u8] {
        &self.map[..self.readable]
    }

    /// The damage that ended the readable part of the file, if any: the
    /// recording is read up to it.
    pub fn damage(&self) -> Option<&Damage> {
        self.damage.as_ref()
    }

    /// Whether a read of the recording ended at a record cut off by the end of
    /// the file: the recorder was killed or lost its power, and what it had not
    /// yet written (at most its flush interval) is lost.
    pub fn was_cut_off(&self) -> bool {
        self.cut_off.load(Ordering::Relaxed)
    }

    /// The metadata record `name` (they are written at the start of the file:
    /// a cut-off recording has them too).
    fn metadata(&self, name: &str) -> Option<mcap::records::Metadata> {
        let records =
            mcap::read::LinearReader::new_with_options(self.bytes(), mcap::read::Options::IgnoreEndMagic.into());
        records.ok()?.map_while(Result::ok).find_map(|r| match r {
            mcap::records::Record::Metadata(m) if m.name == name => Some(m),
            _ => None,
        })
    }

    /// How far the log times are ahead of fusiond's clock (CLOCK_MONOTONIC):
    /// the recorder writes wall-clock log times and keeps the offset in the
    /// metadata `fusion.clock`; 0 for a recording without it (its log times
    /// are CLOCK_MONOTONIC).
    pub fn log_time_offset(&self) -> u64 {
        self.metadata(recording::CLOCK_METADATA)
            .and_then(|m| m.metadata.get(recording::CLOCK_OFFSET_KEY)?.parse().ok())
            .unwrap_or(0)
    }

    /// The configuration fusiond ran with, as the recorder kept it (the
    /// metadata `fusion.config`, at the start of the file: a cut-off recording
    /// has it too); `None` for a recording without one.
    pub fn config(&self) -> Option<RecordedConfig> {
        use fusion_shared::config_record as c;
        let metadata = self.metadata(c::METADATA_NAME)?;
        let get = |key: &str| metadata.metadata.get(key).cloned();
        Some(RecordedConfig {
            toml: get(c::METADATA_TOML)?,
            fusiond_version: get(c::METADATA_VERSION).unwrap_or_default(),
            snapshot_wire: get(c::METADATA_WIRE).unwrap_or_default(),
        })
    }

    /// Whether `bytes` start with the MCAP magic.
    pub fn is_mcap(bytes: &[u8]) -> bool {
        bytes.starts_with(mcap::MAGIC)
    }

    /// How many sample messages the recording's summary counts (`None` for a
    /// file without one: a recording that was cut off).
    pub fn sample_count(&self) -> Option<u64> {
        let summary = self.summary.as_ref()?;
        let stats = summary.stats.as_ref()?;
        let samples = stats
            .channel_message_counts
            .iter()
            .filter(|(id, _)| summary.channels.get(id).is_some_and(|c| c.topic.starts_with(SAMPLE_TOPIC_PREFIX)));
        Some(samples.map(|(_, n)| n).sum())
    }

    /// The messages of the sample topics, in the order of the file. With a
    /// summary, only the chunks that hold samples are read (`fusionctl record`
    /// keeps samples and snapshots in separate chunks); without one, the whole file.
    fn sample_messages<'s>(&'s self) -> std::io::Result<impl Iterator<Item = std::io::Result<mcap::Message<'s>>> + 's> {
        let messages: Box<dyn Iterator<Item = mcap::McapResult<mcap::Message<'s>>> + 's> = match &self.summary {
            Some(summary) if !summary.chunk_indexes.is_empty() => {
                let sample_channels: Vec<u16> = summary
                    .channels
                    .iter()
                    .filter(|(_, c)| c.topic.starts_with(SAMPLE_TOPIC_PREFIX))
                    .map(|(&id, _)| id)
                    .collect();
                let mut chunks: Vec<_> = summary
                    .chunk_indexes
                    .iter()
                    .filter(|c| c.message_index_offsets.keys().any(|id| sample_channels.contains(id)))
                    .collect();
                chunks.sort_by_key(|c| c.chunk_start_offset);
                Box::new(chunk_messages(summary, self.bytes(), chunks))
            }
            _ => {
                let stream = mcap::MessageStream::new(self.bytes()).map_err(mcap_error)?;
                // A stream's messages own their data ('static); the type says 's.
                #[allow(clippy::map_identity)]
                let stream = stream.map(|m| -> mcap::McapResult<mcap::Message<'s>> { m });
                Box::new(until_cut(stream, &self.cut_off))
            }
        };
        Ok(messages.filter_map(|m| match m {
            Ok(m) if m.channel.topic.starts_with(SAMPLE_TOPIC_PREFIX) => Some(Ok(m)),
            Ok(_) => None,
            Err(e) => Some(Err(mcap_error(e))),
        }))
    }

    /// The recorded snapshots that report a processed sample, in order.
    pub fn live_snapshots(&self) -> std::io::Result<impl Iterator<Item = std::io::Result<SnapshotJson>> + '_> {
        let stream = mcap::MessageStream::new(self.bytes()).map_err(mcap_error)?;
        Ok(until_cut(stream, &self.cut_off).filter_map(|m| {
            let m = match m {
                Ok(m) => m,
                Err(e) => return Some(Err(mcap_error(e))),
            };
            if m.channel.topic != recording::STATE_TOPIC {
                return None;
            }
            match serde_json::from_slice::<SnapshotJson>(&m.data) {
                Ok(s) if s.has_input() => Some(Ok(s)),
                Ok(_) => None,
                Err(e) => Some(Err(std::io::Error::new(std::io::ErrorKind::InvalidData, e))),
            }
        }))
    }
}

/// The kind of a sample topic, or why it is none of this version's.
fn sample_kind(topic: &str) -> Result<SampleKind, String> {
    recording::kind_of_topic(topic).ok_or_else(|| format!("{topic}: not a sample kind of this version"))
}

/// The replay input of the sample message at `position`.
fn to_item(position: u64, log_time: u64, kind: Result<SampleKind, String>, data: &[u8]) -> InputItem {
    let sample = kind.and_then(|kind| {
        recording::parse_sample(kind, data).map_err(|e| format!("{}: {e}", recording::sample_topic(kind)))
    });
    InputItem { position, received_ns: Some(log_time), sample }
}

/// A sample message read but not parsed: its position, log time, kind, and
/// its bytes in the batch.
type RawMessage = (u64, u64, Result<SampleKind, String>, std::ops::Range<usize>);

/// Sample messages read but not yet parsed, one buffer for all their bytes.
#[derive(Default)]
struct RawBatch {
    data: Vec<u8>,
    messages: Vec<std::io::Result<RawMessage>>,
}

/// The messages of `chunks`, in that order.
fn chunk_messages<'a>(
    summary: &'a mcap::Summary,
    map: &'a [u8],
    chunks: Vec<&'a mcap::records::ChunkIndex>,
) -> impl Iterator<Item = mcap::McapResult<mcap::Message<'a>>> + 'a {
    chunks.into_iter().flat_map(move |c| {
        let (messages, error) = match summary.stream_chunk(map, c) {
            Ok(messages) => (Some(messages), None),
            Err(e) => (None, Some(Err(e))),
        };
        messages.into_iter().flatten().chain(error)
    })
}

/// One field where the replay differs from the live run.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// The live snapshot's sequence number.
    pub snapshot_seq: u64,
    /// The sample processed (kind sensor #seq @ t).
    pub sample: String,
    /// Which field, e.g. `x[3]` or `counters[1].gated`.
    pub field: String,
    /// Its value live.
    pub live: String,
    /// Its value in the replay.
    pub replay: String,
}

/// The outcome of a [`LiveComparison`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ComparisonReport {
    /// Processed samples compared with a live snapshot.
    pub compared: u64,
    /// Of them, those where something differed.
    pub differing: u64,
    /// The first differences.
    pub differences: Vec<Difference>,
    /// IMU samples that had no snapshot of their own live: their instant's
    /// snapshot went out after a later sample ([`crate::frames::ImuConfig::instant_wait_ns`]).
    pub instant_held: u64,
    /// Processed samples in the replay with no live snapshot left to compare.
    pub replay_only: u64,
    /// Live snapshots with an input left when the replay ended.
    pub live_only: u64,
    /// The recording was cut off (or damaged): its samples and its snapshots
    /// end at different points, so what only one of them has is not compared.
    pub cut: bool,
}

impl ComparisonReport {
    /// Whether the replay equals the live run everywhere both have.
    pub fn equal(&self) -> bool {
        self.differing == 0 && (self.cut || (self.replay_only == 0 && self.live_only == 0))
    }
}

impl std::fmt::Display for ComparisonReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.equal() && self.cut {
            return writeln!(
                f,
                "live snapshots: {} compared, all equal bit for bit (x, P, NIS, counters); the recording was cut, so \
                 {} processed in the replay only and {} live only were not compared",
                self.compared, self.replay_only, self.live_only
            );
        }
        if self.equal() && self.instant_held > 0 {
            return writeln!(
                f,
                "live snapshots: {} compared, all equal bit for bit (x, P, NIS, counters); {} IMU samples had \
                 their instant's snapshot go out after a later sample of it",
                self.compared, self.instant_held
            );
        }
        if self.equal() {
            return writeln!(
                f,
                "live snapshots: {} compared, all equal bit for bit (x, P, NIS, counters)",
                self.compared
            );
        }
        writeln!(
            f,
            "live snapshots: {} compared, {} differ; {} processed in the replay only, {} live only",
            self.compared, self.differing, self.replay_only, self.live_only
        )?;
        for d in &self.differences {
            writeln!(
                f,
                "  snapshot {} ({}): {} live {} replay {}",
                d.snapshot_seq, d.sample, d.field, d.live, d.replay
            )?;
        }
        Ok(())
    }
}

/// Compares each processed sample of a replay with the next live snapshot.
///
/// The replay inserts as the live loop did ([`Engine::insert_deferred`]), and
/// before each input it re-steps stale entries until its count of idle-time
/// steps equals the one of the next live snapshot
/// ([`StateSnapshot::background_steps`](fusion_shared::StateSnapshot::background_steps)):
/// the live loop did those steps between samples, so the replay lands each
/// slice of a rewind where live did, and provisional snapshots compare bit for
/// bit like settled ones.
pub struct LiveComparison<I: Iterator> {
    live: std::iter::Peekable<I>,
    report: ComparisonReport,
    error: Option<std::io::Error>,
}

impl<I: Iterator<Item = std::io::Result<SnapshotJson>>> LiveComparison<I> {
    /// Compares with the snapshots of `live` (those with an input, in order).
    pub fn new(live: I) -> Self {
        Self { live: live.peekable(), report: ComparisonReport::default(), error: None }
    }

    /// The report, once the replay ended (counting the live snapshots left).
    pub fn finish(mut self) -> std::io::Result<ComparisonReport> {
        if let Some(e) = self.error {
            return Err(e);
        }
        for s in self.live.by_ref() {
            s?;
            self.report.live_only += 1;
        }
        Ok(self.report)
    }
}

/// Whether a snapshot's input is `sample` (its kind, sensor and sequence number).
fn names(input: &recording::InputJson, sample: &Sample) -> bool {
    input.kind == sample.kind().name() && input.sensor == sample.sensor() && input.seq == sample.seq()
}

/// A value as the JSON a recording holds it (for the differences' text).
fn json<T: serde::Serialize>(value: &T) -> serde_json::Value {
    serde_json::to_value(value).unwrap_or_default()
}

fn bits_differ(a: &[f64], b: &[f64]) -> Option<usize> {
    if a.len() != b.len() {
        return Some(a.len().min(b.len()));
    }
    a.iter().zip(b).position(|(x, y)| x.to_bits() != y.to_bits())
}

/// The differing fields of two snapshots (live, replay), as (field, live, replay).
fn differences(live: &SnapshotJson, replay: &SnapshotJson) -> Vec<(String, String, String)> {
    let mut out = Vec::new();
    let mut field = |name: &str, a: String, b: String| {
        if a != b {
            out.push((name.to_string(), a, b));
        }
    };
    for (name, a, b) in [("x", &live.x, &replay.x), ("P", &live.p, &replay.p)] {
        if let Some(i) = bits_differ(a, b) {
            let show = |v: &[f64]| v.get(i).map_or("-".into(), |v| format!("{v:e}"));
            field(&format!("{name}[{i}]"), show(a), show(b));
        }
    }
    field("sample", format!("{} {} {} {}", live.kind, live.sensor, live.seq, live.t_ns), {
        format!("{} {} {} {}", replay.kind, replay.sensor, replay.seq, replay.t_ns)
    });
    // Bit for bit: two NaNs or -0 and 0 are not the same value here.
    let nis = |s: &SnapshotJson| s.nis.map_or("none".into(), |v| format!("{v:e} (bits {:#x})", v.to_bits()));
    if live.nis.map(f64::to_bits) != replay.nis.map(f64::to_bits) {
        field("nis", nis(live), nis(replay));
    }
    let accepted = |s: &SnapshotJson| s.accepted.map_or("none".into(), |a| a.to_string());
    field("accepted", accepted(live), accepted(replay));
    let input = |s: &SnapshotJson| {
        let i = &s.input;
        format!("{} {} {} {} received {} replayed {}", i.kind, i.sensor, i.seq, i.t_ns, i.received_ns, i.replayed)
    };
    field("input", input(live), input(replay));
    if live.counters.len() != replay.counters.len() {
        field("sensors", live.counters.len().to_string(), replay.counters.len().to_string());
    }
    // Each counter that differs by its own name, as JSON shows it.
    for (i, (a, b)) in live.counters.iter().zip(&replay.counters).enumerate() {
        if a == b {
            continue;
        }
        let (ja, jb) = (json(a), json(b));
        if let (Some(fa), Some(fb)) = (ja.as_object(), jb.as_object()) {
            for (key, va) in fa {
                let vb = fb.get(key).cloned().unwrap_or_default();
                field(&format!("counters[{i}] ({} {}).{key}", a.kind, a.sensor), va.to_string(), vb.to_string());
            }
        }
    }
    field("rewinds", live.rewinds.to_string(), replay.rewinds.to_string());
    field("pending", json(&live.pending).to_string(), json(&replay.pending).to_string());
    field("background_steps", live.background_steps.to_string(), replay.background_steps.to_string());
    field("standing", live.standing.to_string(), replay.standing.to_string());
    field("standstill_updates", live.standstill_updates.to_string(), replay.standstill_updates.to_string());
    field("velocity_offset", json(&live.velocity_offset).to_string(), json(&replay.velocity_offset).to_string());
    field("unknown_sensor", live.unknown_sensor.to_string(), replay.unknown_sensor.to_string());
    field("reinitialisations", live.reinitialisations.to_string(), replay.reinitialisations.to_string());
    out
}

impl<I: Iterator<Item = std::io::Result<SnapshotJson>>> ReplayCheck for LiveComparison<I> {
    fn deferred(&self) -> bool {
        true
    }

    fn before_insert<M: Steps>(&mut self, engine: &mut Engine<M>) {
        let Some(Ok(live)) = self.live.peek() else { return };
        while engine.stats().background_steps < live.background_steps && engine.settle_step() {}
        // The late samples' outcomes are in the counters compared; the health
        // they feed live is not.
        engine.take_first_outcomes(|_, _, _| {});
    }

    fn processed<M: Steps>(&mut self, engine: &Engine<M>, sample: &Sample, received_ns: Option<u64>, replayed: usize) {
        if self.error.is_some() {
            return;
        }
        // An IMU sample whose instant was still open live published nothing:
        // its instant's snapshot names a later sample. The live loop runs no
        // rewind slice while an instant is open, so the next snapshot's idle
        // steps were all done before this sample, as `before_insert` did them.
        if sample.kind() == SampleKind::Imu
            && let Some(Ok(live)) = self.live.peek()
            && !names(&live.input, sample)
        {
            self.report.instant_held += 1;
            return;
        }
        let live = match self.live.next() {
            Some(Ok(live)) => live,
            Some(Err(e)) => {
                self.error = Some(e);
                return;
            }
            None => {
                self.report.replay_only += 1;
                return;
            }
        };
        let mut snap = fusion_shared::StateSnapshot::default();
        let input = Input { sample, received_ns: received_ns.unwrap_or(0), replayed };
        snapshot::fill(&mut snap, engine, Some(input), HealthNow::INITIALISING);
        let replay = SnapshotJson::from(&snap);
        self.report.compared += 1;
        let found = differences(&live, &replay);
        if found.is_empty() {
            return;
        }
        self.report.differing += 1;
        for (field, live_value, replay_value) in found {
            if self.report.differences.len() < DIFFERENCES_REPORTED {
                self.report.differences.push(Difference {
                    snapshot_seq: live.snapshot_seq,
                    sample: format!(
                        "{} {} #{} @ {} ns",
                        live.input.kind, live.input.sensor, live.input.seq, live.input.t_ns
                    ),
                    field,
                    live: live_value,
                    replay: replay_value,
                });
            }
        }
    }
}

/// Samples per batch handed from the reading thread to the replay.
const READ_BATCH: usize = 4096;

/// Replays `recording` (see [`super::replay_items`]), calling `progress` with
/// each sample message; with `compare`, also against its live snapshots.
///
/// A second thread reads the recording (the decompression) while this one
/// parses the messages and runs the engine: batches of raw messages pass
/// between them through a bounded channel, in order.
pub fn replay_recording(
    config: &Config,
    recording: &Recording,
    output: Option<impl Write>,
    smooth: bool,
    compare: bool,
    mut progress: impl FnMut(),
) -> Result<(ReplaySummary, Option<ComparisonReport>), ReplayError> {
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded::<RawBatch>(8);
        // The engine's clock is fusiond's: log times back to CLOCK_MONOTONIC.
        let offset = recording.log_time_offset();
        scope.spawn(move || {
            let messages = match recording.sample_messages() {
                Ok(messages) => messages,
                Err(e) => {
                    let _ = tx.send(RawBatch { data: Vec::new(), messages: vec![Err(e)] });
                    return;
                }
            };
            let mut batch = RawBatch::default();
            for (i, m) in messages.enumerate() {
                batch.messages.push(m.map(|m| {
                    let start = batch.data.len();
                    batch.data.extend_from_slice(&m.data);
                    (
                        i as u64 + 1,
                        m.log_time.saturating_sub(offset),
                        sample_kind(&m.channel.topic),
                        start..batch.data.len(),
                    )
                }));
                // The replay stopped (an error) when the channel is closed.
                if batch.messages.len() == READ_BATCH && tx.send(std::mem::take(&mut batch)).is_err() {
                    return;
                }
            }
            let _ = tx.send(batch);
        });
        let samples = rx
            .into_iter()
            .flat_map(|batch| {
                let RawBatch { data, messages } = batch;
                messages.into_iter().map(move |m| {
                    let (position, log_time, kind, range) = m?;
                    Ok(to_item(position, log_time, kind, &data[range]))
                })
            })
            .inspect(|_| progress());
        if !compare {
            return Ok((replay_items(config, samples, output, smooth, &mut super::NoCheck).map(samples_read)?, None));
        }
        let mut comparison = LiveComparison::new(recording.live_snapshots()?);
        let summary = replay_items(config, samples, output, smooth, &mut comparison).map(samples_read)?;
        let mut report = comparison.finish()?;
        report.cut = recording.was_cut_off() || recording.damage().is_some();
        Ok((summary, Some(report)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fusion_shared::StateSnapshot;

    /// The differences read as a recording does (names, numbers), not as
    /// Rust's Debug output (`CountersJson { … }`, `Some(…)`).
    #[test]
    fn differences_name_each_field_in_json_words() {
        let mut live = StateSnapshot { sensor_count: 1, nis: 2.5, ..Default::default() };
        live.sensors[0].kind = SampleKind::Position as u32;
        live.sensors[0].sensor = 1;
        live.sensors[0].counts.gated = 3;
        let mut replay = live;
        replay.sensors[0].counts.gated = 4;
        replay.nis = 2.75;
        replay.pending_steps = 7;
        let d = differences(&SnapshotJson::from(&live), &SnapshotJson::from(&replay));
        let text: Vec<String> = d.iter().map(|(f, a, b)| format!("{f}: {a} / {b}")).collect();
        assert!(text.contains(&"counters[0] (position 1).gated: 3 / 4".to_string()), "{text:?}");
        assert!(text.iter().any(|t| t.starts_with("nis: 2.5e0 (bits")), "{text:?}");
        assert!(text.iter().all(|t| !t.contains("Json {") && !t.contains("Some(")), "{text:?}");
    }
}
