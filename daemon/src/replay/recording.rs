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

use fusion_shared::recording::{self, SnapshotJson};

use super::{InputItem, ReplayCheck, ReplayError, ReplaySummary, replay_items};
use crate::config::Config;
use crate::engine::Engine;
use crate::health::HealthNow;
use crate::model::Model;
use crate::reorder::Sample;
use crate::snapshot::{self, Input};

/// Differences described one by one in a [`ComparisonReport`].
pub const DIFFERENCES_REPORTED: usize = 10;

/// An MCAP recording, mapped into memory.
pub struct Recording {
    map: memmap2::Mmap,
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
        Ok(Self { map })
    }

    /// Whether `bytes` start with the MCAP magic.
    pub fn is_mcap(bytes: &[u8]) -> bool {
        bytes.starts_with(mcap::MAGIC)
    }

    /// How many sample messages the recording's summary counts (`None` for a
    /// file without one: a recording that was cut off).
    pub fn sample_count(&self) -> Option<u64> {
        let summary = mcap::Summary::read(&self.map).ok().flatten()?;
        let stats = summary.stats?;
        let samples = stats
            .channel_message_counts
            .iter()
            .filter(|(id, _)| summary.channels.get(id).is_some_and(|c| recording::kind_of_topic(&c.topic).is_some()));
        Some(samples.map(|(_, n)| n).sum())
    }

    /// The input samples, in the order of the file.
    pub fn samples(&self) -> std::io::Result<impl Iterator<Item = std::io::Result<InputItem>> + '_> {
        let stream = mcap::MessageStream::new(&self.map).map_err(mcap_error)?;
        let mut position = 0;
        Ok(stream.filter_map(move |m| {
            let m = match m {
                Ok(m) => m,
                Err(e) => return Some(Err(mcap_error(e))),
            };
            let topic = &m.channel.topic;
            let kind = recording::kind_of_topic(topic);
            if kind.is_none() && !topic.starts_with("/fusion/samples/") {
                return None;
            }
            position += 1;
            let sample = match kind {
                Some(kind) => recording::parse_sample(kind, &m.data).map_err(|e| format!("{topic}: {e}")),
                None => Err(format!("{topic}: not a sample kind of this version")),
            };
            Some(Ok(InputItem { position, received_ns: Some(m.log_time), sample }))
        }))
    }

    /// The recorded snapshots that report a processed sample, in order.
    pub fn live_snapshots(&self) -> std::io::Result<impl Iterator<Item = std::io::Result<SnapshotJson>> + '_> {
        let stream = mcap::MessageStream::new(&self.map).map_err(mcap_error)?;
        Ok(stream.filter_map(|m| {
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
    /// Processed samples in the replay with no live snapshot left to compare.
    pub replay_only: u64,
    /// Live snapshots with an input left when the replay ended.
    pub live_only: u64,
}

impl ComparisonReport {
    /// Whether the replay equals the live run everywhere.
    pub fn equal(&self) -> bool {
        self.differing == 0 && self.replay_only == 0 && self.live_only == 0
    }
}

impl std::fmt::Display for ComparisonReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
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
pub struct LiveComparison<I> {
    live: I,
    report: ComparisonReport,
    error: Option<std::io::Error>,
}

impl<I: Iterator<Item = std::io::Result<SnapshotJson>>> LiveComparison<I> {
    /// Compares with the snapshots of `live` (those with an input, in order).
    pub fn new(live: I) -> Self {
        Self { live, report: ComparisonReport::default(), error: None }
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
    field("nis", format!("{:?}", live.nis.map(f64::to_bits)), format!("{:?}", replay.nis.map(f64::to_bits)));
    field("accepted", format!("{:?}", live.accepted), format!("{:?}", replay.accepted));
    let input = |s: &SnapshotJson| {
        let i = &s.input;
        format!("{} {} {} {} received {} replayed {}", i.kind, i.sensor, i.seq, i.t_ns, i.received_ns, i.replayed)
    };
    field("input", input(live), input(replay));
    if live.counters.len() != replay.counters.len() {
        field("sensors", live.counters.len().to_string(), replay.counters.len().to_string());
    }
    for (i, (a, b)) in live.counters.iter().zip(&replay.counters).enumerate() {
        if a != b {
            field(&format!("counters[{i}] ({} {})", a.kind, a.sensor), format!("{a:?}"), format!("{b:?}"));
        }
    }
    field("rewinds", live.rewinds.to_string(), replay.rewinds.to_string());
    field("unknown_sensor", live.unknown_sensor.to_string(), replay.unknown_sensor.to_string());
    field("reinitialisations", live.reinitialisations.to_string(), replay.reinitialisations.to_string());
    out
}

impl<I: Iterator<Item = std::io::Result<SnapshotJson>>> ReplayCheck for LiveComparison<I> {
    fn processed<M: Model>(&mut self, engine: &Engine<M>, sample: &Sample, received_ns: Option<u64>, replayed: usize) {
        if self.error.is_some() {
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

/// Replays `recording` (see [`super::replay_items`]), calling `progress` with
/// each sample message; with `compare`, also against its live snapshots.
pub fn replay_recording(
    config: &Config,
    recording: &Recording,
    output: Option<impl Write>,
    smooth: bool,
    compare: bool,
    mut progress: impl FnMut(),
) -> Result<(ReplaySummary, Option<ComparisonReport>), ReplayError> {
    let samples = recording.samples()?.inspect(|_| progress());
    if !compare {
        return Ok((replay_items(config, samples, output, smooth, &mut super::NoCheck)?, None));
    }
    let mut comparison = LiveComparison::new(recording.live_snapshots()?);
    let summary = replay_items(config, samples, output, smooth, &mut comparison)?;
    Ok((summary, Some(comparison.finish()?)))
}
