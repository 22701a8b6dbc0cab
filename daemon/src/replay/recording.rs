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
use fusion_shared::mcap_scan::{self, Damage};
use fusion_shared::recording::{self, SAMPLE_TOPIC_PREFIX, SnapshotJson};

use super::{InputItem, ReplayError, ReplaySummary, replay_items, samples_read};
use crate::config::Config;

mod compare;
pub use compare::{ComparisonReport, DIFFERENCES_REPORTED, Difference, LiveComparison};

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
    /// The messages the file's summary counts, when it is sound (a damaged
    /// file's too): what the damage cost.
    message_count: Option<u64>,
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
        let scan = mcap_scan::scan(&map);
        let (readable, damage, message_count) = (scan.readable, scan.damage, scan.message_count);
        let whole = damage.is_none() && scan.summary_sound;
        let summary = if whole { mcap::Summary::read(&map).ok().flatten() } else { None };
        Ok(Self { map, readable, damage, message_count, summary, cut_off: AtomicBool::new(false) })
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

    /// What the damage cost, for a user: the bytes after it, and the messages
    /// the file held (when its summary says) of which `read` were read. `None`
    /// for a recording without damage.
    pub fn loss(&self, read: u64) -> Option<String> {
        let damage = self.damage.as_ref()?;
        let held = self.message_count.map_or(String::new(), |n| {
            format!(
                " (its summary counts {n} messages, samples and snapshots; {read} samples were read before the damage)"
            )
        });
        Some(format!("the {} bytes from the damage to the end of the file are not read{held}", damage.lost_bytes))
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
