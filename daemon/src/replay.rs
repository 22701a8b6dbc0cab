//! `fusiond replay`: JSON lines in → engine → JSON lines out, the same engine as live.
//!
//! Input, one object per line in arrival order:
//!
//! ```text
//! {"imu": {"t_ns": 1000000, "sensor": 0, "seq": 0, "accel": [ax, ay, az], "gyro": [gx, gy, gz]}}
//! {"position": {"t_ns": 1100000, "sensor": 1, "seq": 0, "pos": [x, y, z], "cov": [9 numbers, row-major]}}
//! {"velocity": {"t_ns": 1100000, "sensor": 2, "seq": 0, "vel": [vx, vy, vz], "cov": [9 numbers, row-major]}}
//! ```
//!
//! Output, one object per processed sample in processing order, written when the
//! sample leaves the history (its estimate is final: no later sample can change it):
//!
//! ```text
//! {"t_ns": …, "kind": "imu"|"position"|"velocity", "sensor": …, "seq": …, "x": […], "P": [n·n, row-major],
//!  "nis": number|null, "accepted": true|false|null}
//! ```
//!
//! Without smoothing, memory is bounded by the history window. With smoothing the
//! whole run is kept for the backward pass.

pub mod bag;
pub mod recording;

use std::io::{BufRead, Write};

use fusion_shared::jsonl;
use serde::{Deserialize, Serialize};

use fusion_shared::Counters;
use fusion_shared::recording::EstimateJson;

use crate::config::{Config, ConfigError, WithModel, with_model};
use crate::engine::{Engine, EngineConfig, Entry, Insert};
use crate::measurement::Steps;
use crate::model::{Diagnostics, StepOutcome};
use crate::reorder::{Sample, SampleKey};

/// How many invalid lines the summary describes one by one.
pub const INVALID_LINES_REPORTED: usize = 10;

/// A replay that could not run or produced nothing.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// Reading the input or writing the output failed.
    #[error("i/o: {0}")]
    Io(#[from] std::io::Error),
    /// The configured model could not be built.
    #[error(transparent)]
    Model(#[from] ConfigError),
    /// No sample of the input could be processed: the summary says why, line
    /// by line (`fusiond replay` prints it).
    #[error("no sample could be processed ({})", nothing_processed(.0))]
    NothingProcessed(Box<ReplaySummary>),
}

/// Why a replay processed nothing, in brackets after the error's words.
fn nothing_processed(summary: &ReplaySummary) -> String {
    let unit = if summary.of_messages { "samples" } else { "lines" };
    match summary.read {
        0 => format!("the input holds no {unit}: an empty file, or one cut off before its first"),
        n => format!("{n} {unit} read; the reasons are above"),
    }
}

/// Counts of one replay, printed on stderr by `fusiond replay`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplaySummary {
    /// Non-blank lines read (of a bag: samples its messages gave).
    pub read: u64,
    /// `read` counts the samples of a bag's or a recording's messages, not
    /// lines (the summary says "samples" and names a refused one's message).
    pub of_messages: bool,
    /// What became of the samples, every sensor added up. Lines that were not
    /// samples at all (malformed JSON, wrong shape) count as `invalid` too.
    pub counts: Counters,
    /// Line number (1-based) and reason of the first invalid lines.
    pub invalid_lines: Vec<(u64, String)>,
    /// Times the filter re-initialised itself from the fixes after a lock-out
    /// ([`crate::model::lockout`]), at the end of the run.
    pub reinitialisations: u64,
    /// Line numbers of the first fixes after which it did.
    pub reinitialised_at: Vec<u64>,
    /// Times the vehicle was found standing still (`[model.standstill]`), and
    /// the standstill updates fused, at the end of the run.
    pub standstills: u64,
    /// Standstill updates fused.
    pub standstill_updates: u64,
    /// Whether the newest estimate so far stands still.
    standing: bool,
    /// How late the velocity sensors' stamps look beyond their configured
    /// offset at the end of the run: `(τ̂, σ_τ, samples)`, s
    /// ([`Diagnostics::velocity_time_offset`]).
    pub velocity_time_offset: Option<(f64, f64, u64)>,
    /// With `--smooth`: steps the smoothing could not pass back through (a
    /// prior covariance without a Cholesky factor, or a smoothed result that
    /// is not a covariance): each kept its filtered estimate, and the
    /// stretches on either side were smoothed apart.
    pub smoothing_breaks: u64,
    /// The times of the first of them, ns.
    pub smoothing_breaks_at: Vec<u64>,
    /// New timelines begun (the input's clock set ahead or back, or a real
    /// gap: [`fusion_core::engine::JUMP_CONFIRMATION`]).
    pub timelines_begun: u64,
    /// The first of them: the input's position of its first sample, and the
    /// step, ns (negative: back).
    pub new_timelines: Vec<(u64, i128)>,
    /// Re-initialisations and standstill updates of the timelines before the
    /// current one (each timeline's estimate starts over).
    carried: (u64, u64),
}

impl ReplaySummary {
    /// An input at `position` that gave no sample, or a refused sample, with
    /// its reason (the first [`INVALID_LINES_REPORTED`] are kept).
    fn invalid(&mut self, position: u64, reason: String) {
        if self.invalid_lines.len() < INVALID_LINES_REPORTED {
            self.invalid_lines.push((position, reason));
        }
    }

    /// Follows the model's [`Diagnostics`] after the input at `position`: the
    /// re-initialisations and where they happened, the standstills begun, the
    /// velocity time offset.
    fn follow(&mut self, position: u64, d: Diagnostics) {
        let reinitialisations = self.carried.0 + d.reinitialisations;
        if reinitialisations > self.reinitialisations && self.reinitialised_at.len() < INVALID_LINES_REPORTED {
            self.reinitialised_at.push(position);
        }
        self.reinitialisations = reinitialisations;
        self.standstills += u64::from(d.standing && !self.standing);
        (self.standing, self.standstill_updates) = (d.standing, self.carried.1 + d.standstill_updates);
        self.velocity_time_offset = d.velocity_time_offset;
    }

    /// A new timeline begun at `position` with a step of `step_ns`: the
    /// counts so far are carried past the estimate's new start.
    fn new_timeline(&mut self, position: u64, step_ns: i128) {
        self.timelines_begun += 1;
        if self.new_timelines.len() < INVALID_LINES_REPORTED {
            self.new_timelines.push((position, step_ns));
        }
        self.carried = (self.reinitialisations, self.standstill_updates);
    }
}

/// What the velocity time offset estimate (`τ̂` ± `σ_τ` s from `n` samples) says
/// to a user: the offset to add when it is clearly not 0
/// ([`fusion_shared::snapshot::time_offset_to_add_ms`]), that the configured one
/// is right otherwise; nothing from too few samples.
pub fn offset_advice(tau: f64, sd: f64, n: u64) -> Option<String> {
    if n < fusion_shared::snapshot::MIN_TIME_OFFSET_SAMPLES {
        return None;
    }
    let (ms, sd_ms) = (tau * 1e3, sd * 1e3);
    Some(if fusion_shared::snapshot::time_offset_to_add_ms(tau * 1e9, sd * 1e9, n).is_some() {
        format!(
            "velocity stamps {} by {:.0} ± {:.0} ms beyond their time_offset_ns ({n} samples): add about {:.0} ms \
             to the velocity sensor's time_offset_ns (an estimate that reads low: run again after)",
            if ms > 0.0 { "late" } else { "early" },
            ms.abs(),
            sd_ms,
            ms
        )
    } else {
        format!("velocity stamps match their time_offset_ns: {ms:+.1} ± {sd_ms:.1} ms ({n} samples)")
    })
}

/// The summary of a replay of samples (a recording's, a bag's), not lines.
pub(crate) fn samples_read(summary: ReplaySummary) -> ReplaySummary {
    ReplaySummary { of_messages: true, ..summary }
}

impl std::fmt::Display for ReplaySummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = &self.counts;
        writeln!(
            f,
            "read {} {}: processed {}, fused {}, gated {}, refused {}, fused late {}, dropped too late {}, duplicates {}, \
             invalid {}, rate-limited {}, sensor restarts {}",
            self.read,
            if self.of_messages { "samples" } else { "lines" },
            c.processed,
            c.fused,
            c.gated,
            c.refused,
            c.late,
            c.too_late,
            c.duplicate,
            c.invalid,
            c.rate_limited,
            c.restarts
        )?;
        // A bag's or a recording's positions are its messages', a file's its lines'.
        let at = if self.of_messages { "message" } else { "line" };
        for (line, reason) in &self.invalid_lines {
            writeln!(f, "  {at} {line}: {reason}")?;
        }
        if c.invalid > self.invalid_lines.len() as u64 {
            writeln!(f, "  … and {} more invalid lines", c.invalid - self.invalid_lines.len() as u64)?;
        }
        if self.standstills > 0 {
            writeln!(
                f,
                "stood still {} ({} standstill updates: zero velocity and rate, attitude held)",
                if self.standstills == 1 { "once".to_string() } else { format!("{} times", self.standstills) },
                self.standstill_updates
            )?;
        }
        if let Some(line) = self.velocity_time_offset.and_then(|(tau, sd, n)| offset_advice(tau, sd, n)) {
            writeln!(f, "{line}")?;
        }
        if self.reinitialisations > 0 {
            let lines: Vec<String> = self.reinitialised_at.iter().map(u64::to_string).collect();
            writeln!(
                f,
                "filter re-initialised {} times after a lock-out: from the fixes, or reset by the samples of a kind \
                 gated for [gating] lockout_ns (at line {})",
                self.reinitialisations,
                lines.join(", ")
            )?;
        }
        for (position, step) in &self.new_timelines {
            writeln!(
                f,
                "the input's clock was set {} by {:.3} s at {at} {position} (or the input has a gap there): a new \
                 timeline began, the estimate started over from the initial state after the {} samples before it \
                 were refused ([validation] max_jump_ns)",
                if *step < 0 { "back" } else { "ahead" },
                step.unsigned_abs() as f64 * 1e-9,
                fusion_core::engine::JUMP_CONFIRMATION
            )?;
        }
        if self.timelines_begun > self.new_timelines.len() as u64 {
            writeln!(f, "  … and {} more new timelines", self.timelines_begun - self.new_timelines.len() as u64)?;
        }
        if self.smoothing_breaks > 0 {
            let at: Vec<String> = self.smoothing_breaks_at.iter().map(|t| format!("{:.3}", *t as f64 * 1e-9)).collect();
            writeln!(
                f,
                "smoothing could not pass back through {} steps (a prior covariance that is not positive definite): \
                 each keeps its filtered estimate and the stretches on either side were smoothed apart (at t = {} s{})",
                self.smoothing_breaks,
                at.join(", "),
                if self.smoothing_breaks > at.len() as u64 { ", …" } else { "" }
            )?;
        }
        Ok(())
    }
}

/// Parses one input line into a sample; the error is a reason for the summary.
pub fn parse_line(line: &str) -> Result<Sample, String> {
    jsonl::parse_sample(line).map_err(|e| e.to_string())
}

/// One output line: the estimate after a sample ([`EstimateJson`], whose
/// fields it gives as its own: `line.x`), and whether it is smoothed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputLine {
    /// The estimate: time of validity, the sample's kind, sensor and sequence
    /// number, `x` and `P` after it, the NIS of a measurement and whether it
    /// was fused (`null` for IMU samples).
    #[serde(flatten)]
    pub estimate: EstimateJson,
    /// `true` on the lines of a smoothed replay (`--smooth`); absent otherwise.
    #[serde(default)]
    pub smoothed: bool,
}

impl std::ops::Deref for OutputLine {
    type Target = EstimateJson;

    fn deref(&self) -> &EstimateJson {
        &self.estimate
    }
}

/// An output line as written: the estimate borrowed.
#[derive(Serialize)]
struct OutputRef<'a> {
    #[serde(flatten)]
    estimate: EstimateJson<&'static str, &'a [f64]>,
    /// Only on smoothed lines (`true`): filtered output is as it was.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    smoothed: bool,
}

fn write_output(
    out: &mut impl Write,
    key: &SampleKey,
    outcome: &StepOutcome,
    (x, p): (&[f64], &[f64]),
    smoothed: bool,
) -> std::io::Result<()> {
    let estimate = EstimateJson {
        t_ns: key.t_ns,
        kind: key.kind.name(),
        sensor: key.sensor,
        seq: key.seq,
        x,
        p,
        nis: outcome.nis(),
        accepted: outcome.accepted(),
    };
    let line = OutputRef { estimate, smoothed };
    serde_json::to_writer(&mut *out, &line)?;
    out.write_all(b"\n")
}

/// Replays `input` (JSON lines) through the engine configured by `config`,
/// writing estimates to `output` (if given); with `smooth`, the estimates are
/// RTS-smoothed over the whole run.
pub fn replay(
    config: &Config,
    input: impl BufRead,
    output: Option<impl Write>,
    smooth: bool,
) -> Result<ReplaySummary, ReplayError> {
    replay_items(config, jsonl_items(input), output, smooth, &mut NoCheck)
}

/// One input of a replay: a sample (or why there is none) at a position of
/// the input (a line number, a message number).
#[derive(Debug, Clone, PartialEq)]
pub struct InputItem {
    /// Line or message number, from 1.
    pub position: u64,
    /// The daemon's clock when it received the sample live (a recording), or
    /// `None` (a file without arrival times: time jumps are judged by the
    /// samples alone).
    pub received_ns: Option<u64>,
    /// The sample, or why the input is not one.
    pub sample: Result<Sample, String>,
}

/// The non-blank lines of a JSON-lines input as [`InputItem`]s. Lines are
/// read as bytes: a line that is not UTF-8 is one bad line, not the end of the run.
pub fn jsonl_items(input: impl BufRead) -> impl Iterator<Item = std::io::Result<InputItem>> {
    input.split(b'\n').enumerate().filter_map(|(i, line)| {
        let line = match line {
            Ok(line) => line,
            Err(e) => return Some(Err(e)),
        };
        if line.trim_ascii().is_empty() {
            return None;
        }
        let sample = std::str::from_utf8(&line).map_err(|_| "not UTF-8 text".to_string()).and_then(parse_line);
        Some(Ok(InputItem { position: i as u64 + 1, received_ns: None, sample }))
    })
}

/// Looks at the engine after each sample a replay processed (a comparison
/// with the live snapshots of a recording).
pub trait ReplayCheck {
    /// Whether the replay inserts as the live loop does, leaving a late sample's
    /// rewind to [`before_insert`](Self::before_insert) ([`Engine::insert_deferred`])
    /// instead of settling it at once ([`Engine::insert`]).
    fn deferred(&self) -> bool {
        false
    }
    /// Called before each input is inserted: a deferring check does here the
    /// rewind steps the live loop did in its idle time before that input.
    fn before_insert<M: Steps>(&mut self, _engine: &mut Engine<M>) {}
    /// Called after `sample`, received at `received_ns`, was processed.
    fn processed<M: Steps>(&mut self, engine: &Engine<M>, sample: &Sample, received_ns: Option<u64>, replayed: usize);
}

/// No check.
pub struct NoCheck;

impl ReplayCheck for NoCheck {
    fn processed<M: Steps>(&mut self, _: &Engine<M>, _: &Sample, _: Option<u64>, _: usize) {}
}

/// Replays `items` through the engine configured by `config`, writing
/// estimates to `output` (if given) and showing `check` each processed sample;
/// with `smooth`, the estimates are RTS-smoothed over the whole run.
pub fn replay_items(
    config: &Config,
    items: impl Iterator<Item = std::io::Result<InputItem>>,
    output: Option<impl Write>,
    smooth: bool,
    check: &mut impl ReplayCheck,
) -> Result<ReplaySummary, ReplayError> {
    struct Replay<'a, I, W, C>(&'a Config, I, Option<W>, bool, &'a mut C);
    impl<I: Iterator<Item = std::io::Result<InputItem>>, W: Write, C: ReplayCheck> WithModel for Replay<'_, I, W, C> {
        type Output = Result<ReplaySummary, ReplayError>;
        fn run<M: Steps>(self, model: M) -> Self::Output {
            replay_model(model, self.0, self.1, self.2, self.3, self.4)
        }
    }
    with_model(config, Replay(config, items, output, smooth, check))
}

/// Where final entries go: straight to the output, or kept for the smoother.
///
/// The smoother needs each step's prior and transition, which the history does not
/// keep (it holds compact filter states). The final samples in processing order
/// are kept instead and re-run through [`Model::step_recorded`] from the initial
/// state after the stream: every step is a pure function of the state before it
/// and the sample, so the re-run reproduces the engine's states bit for bit.
struct Sink<M: Steps, W: Write> {
    output: Option<W>,
    finals: Option<Vec<(SampleKey, StepOutcome, Sample)>>,
    /// Where in `finals` each new timeline begins (its estimate starts over).
    timelines: Vec<usize>,
    error: Option<std::io::Error>,
    /// The covariance of the entry being written.
    cov: Vec<f64>,
    _model: std::marker::PhantomData<M>,
}

impl<M: Steps, W: Write> Sink<M, W> {
    fn take(&mut self, e: &Entry<M::State>) {
        match &mut self.finals {
            Some(finals) => finals.push((e.key, e.outcome, e.sample)),
            None if self.error.is_none() => {
                if let Some(output) = &mut self.output {
                    self.cov.resize(M::COV_DIM * M::COV_DIM, 0.0);
                    M::write_covariance(&e.state, &mut self.cov);
                    if let Err(err) = write_output(output, &e.key, &e.outcome, (M::x(&e.state), &self.cov), false) {
                        self.error = Some(err);
                    }
                }
            }
            None => {}
        }
    }

    fn check(&mut self) -> std::io::Result<()> {
        self.error.take().map_or(Ok(()), Err)
    }
}

fn replay_model<M: Steps>(
    model: M,
    config: &Config,
    items: impl Iterator<Item = std::io::Result<InputItem>>,
    output: Option<impl Write>,
    smooth: bool,
    check: &mut impl ReplayCheck,
) -> Result<ReplaySummary, ReplayError> {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut summary = ReplaySummary::default();
    // Smoothing needs every final sample; without an output there is nothing to smooth.
    let smooth = smooth && output.is_some();
    let mut sink = Sink::<M, _> {
        output,
        finals: smooth.then(Vec::new),
        timelines: Vec::new(),
        error: None,
        cov: Vec::new(),
        _model: Default::default(),
    };
    // Inputs that never became a sample; the engine counts the rest.
    let mut unreadable = 0;
    for item in items {
        let InputItem { position, received_ns, sample } = item?;
        summary.read += 1;
        let sample = match sample {
            Ok(s) => s,
            Err(reason) => {
                unreadable += 1;
                summary.invalid(position, reason);
                continue;
            }
        };
        check.before_insert(&mut engine);
        let inserted = if check.deferred() {
            engine.insert_deferred(&sample, received_ns, &mut |e| sink.take(e))
        } else {
            engine.insert(&sample, received_ns, &mut |e| sink.take(e))
        };
        if engine.stats().new_timelines > summary.timelines_begun {
            // Everything before it was handed out final in this insert.
            summary.new_timeline(position, engine.stats().last_timeline_step_ns);
            sink.timelines.push(sink.finals.as_ref().map_or(0, Vec::len));
        }
        match inserted {
            Insert::Rejected(r) => summary.invalid(position, r.reason().to_string()),
            Insert::Processed { replayed, .. } | Insert::Placed { replayed } => {
                check.processed(&engine, &sample, received_ns, replayed)
            }
            _ => {}
        }
        summary.follow(position, engine.latest().map(|e| M::diagnostics(&e.state)).unwrap_or_default());
        sink.check()?;
    }
    engine.flush(&mut |e| sink.take(e));
    sink.check()?;
    if let Some(finals) = sink.finals.take() {
        let smoothed = smooth_run(engine.model(), &finals, &sink.timelines, &mut summary);
        if let Some(output) = &mut sink.output {
            for ((key, outcome, _), record) in finals.iter().zip(&smoothed) {
                write_output(output, key, outcome, M::record_output(record), true)?;
            }
        }
    }
    if let Some(output) = &mut sink.output {
        output.flush()?;
    }
    summary.counts = engine.totals(None);
    // A sample refused for a full sensor table has no sensor to be counted on.
    summary.counts.invalid += unreadable + engine.stats().unknown_sensor;
    if summary.counts.processed == 0 {
        return Err(ReplayError::NothingProcessed(Box::new(summary)));
    }
    Ok(summary)
}

/// Re-runs the final samples of a run through `model`, keeping each step's
/// record, and smooths them (RTS). A re-initialisation cuts the run: the
/// estimate after it owes nothing to the one before, so each stretch between
/// them is smoothed alone; so does a new timeline (at the indices
/// `timelines`), where the engine started over from the initial state. The
/// steps the smoothing could not pass back through are counted in `summary`.
fn smooth_run<M: Steps>(
    model: &M,
    finals: &[(SampleKey, StepOutcome, Sample)],
    timelines: &[usize],
    summary: &mut ReplaySummary,
) -> Vec<M::Record> {
    let mut state = model.initial_state();
    let mut smoothed: Vec<M::Record> = Vec::with_capacity(finals.len());
    let mut stretches = vec![0];
    for (i, (_, outcome, sample)) in finals.iter().enumerate() {
        if timelines.contains(&i) && i > 0 {
            state = model.initial_state();
            stretches.push(i);
        }
        let before = M::diagnostics(&state).reinitialisations;
        let (again, record) = model.step_recorded(&mut state, sample);
        debug_assert_eq!(again, *outcome, "the re-run reproduces the engine");
        smoothed.push(record);
        if M::diagnostics(&state).reinitialisations > before {
            stretches.push(i);
        }
    }
    stretches.push(smoothed.len());
    for pair in stretches.windows(2) {
        for k in M::smooth(&mut smoothed[pair[0]..pair[1]]) {
            summary.smoothing_breaks += 1;
            if summary.smoothing_breaks_at.len() < INVALID_LINES_REPORTED {
                summary.smoothing_breaks_at.push(finals[pair[0] + k].0.t_ns);
            }
        }
    }
    smoothed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_lines_have_reasons() {
        let reasons = [
            (r#"{"imu": {"t_ns": 1, "sensor": 0, "seq": 0, "accel": [1, 2], "gyro": [0, 0, 0]}}"#, "length"),
            (r#"{"imu": {"t_ns": 1, "sensor": 0, "seq": 0, "accel": [1, 2, 3]}}"#, "gyro"),
            (r#"{"gps": {}}"#, "gps"),
            (r#"{"imu": {"t_ns": -1, "sensor": 0, "seq": 0, "accel": [1, 2, 3], "gyro": [0, 0, 0]}}"#, "-1"),
            (r#"{"imu": {"t_ns": 1, "sensor": 0, "seq": 0, "accel": [1e999, 2, 3], "gyro": [0, 0, 0]}}"#, "range"),
            (r#"{"imu": {"t_ns": 1, "sensor": 0, "seq": 0, "accel": [NaN, 2, 3], "gyro": [0, 0, 0]}}"#, "line 1"),
            (
                r#"{"imu": {"t_ns": 1, "sensor": 0, "seq": 0, "accel": [1, 2, 3], "gyro": [0, 0, 0], "x": 1}}"#,
                "unknown field",
            ),
            ("not json", "expected"),
        ];
        for (line, needle) in reasons {
            let err = parse_line(line).unwrap_err();
            assert!(err.contains(needle), "{line}: {err}");
        }
    }
}
