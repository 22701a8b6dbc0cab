//! The comparison of a recording's replay with its live snapshots
//! ([`LiveComparison`]): after each processed sample, the replayed estimate
//! (x, P, NIS, outcome) and every counter must equal the live snapshot's, bit
//! for bit.

use fusion_shared::SampleKind;
use fusion_shared::recording::{self, SnapshotJson};

use crate::engine::Engine;
use crate::health::HealthNow;
use crate::measurement::Steps;
use crate::reorder::Sample;
use crate::replay::ReplayCheck;
use crate::snapshot::{self, Input};

/// Differences described one by one in a [`ComparisonReport`].
pub const DIFFERENCES_REPORTED: usize = 10;

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
    /// The recording began in a run already going: the first recorded
    /// snapshot's number, and the samples fusiond had taken before it that the
    /// recording does not hold. A replay from the start cannot equal it.
    pub began_mid_run: Option<(u64, u64)>,
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
        if let Some((seq, taken)) = self.began_mid_run {
            writeln!(
                f,
                "  the recording began at snapshot {seq} of a run already going: fusiond had taken {taken} samples \
                 the recording does not hold, so a replay from its start cannot equal the live estimate (to \
                 compare, start fusionctl record before the sensors)"
            )?;
        }
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
            Some(Ok(live)) => {
                if self.report.compared == 0 {
                    // The first snapshot the recording holds: had fusiond taken
                    // samples the replay has not?
                    let taken: u64 = live.counters.iter().map(|c| c.counts.received).sum();
                    let replayed = engine.totals(None).received;
                    if taken > replayed {
                        self.report.began_mid_run = Some((live.snapshot_seq, taken - replayed));
                    }
                }
                live
            }
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
