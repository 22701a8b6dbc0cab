//! `fusion-sim run --input FILE.jsonl`: a JSON-lines file published live, in
//! file order: in lockstep with fusiond (each sample after the snapshot of the
//! one before), or paced by its stamps; a file stamped on another clock is
//! moved onto this host's.

use std::io::BufRead;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use fusion_client::sim::player::sleep_until;
use fusion_client::{Client, Sample, SampleKind, SensorPublishers, StateSubscriber, now_ns};
use fusion_shared::jsonl::parse_sample;
use fusion_shared::snapshot::rejection;
use fusion_shared::time::DEFAULT_MAX_JUMP_NS;

use crate::bag;

/// How long `--input` waits for the snapshot of a sample before going on (a
/// rejected, duplicate or too-late sample produces none).
const ACK_TIMEOUT: Duration = Duration::from_millis(50);

/// How long `--input` goes on while fusiond answers none of its samples, before
/// it gives up: fusiond refuses them all.
const SILENCE: Duration = Duration::from_secs(2);

/// How far a file's samples are stamped before this host's clock allows
/// (fusiond's `[validation] max_past_ns` is 5 s by default), with room to spare.
const FOREIGN_CLOCK_PAST_NS: u64 = 4_000_000_000;

/// How a file is published (`fusion-sim run`'s flags).
#[derive(Debug, Clone, Copy)]
pub(crate) struct How {
    /// Paced by its stamps, not in lockstep (`--realtime`).
    pub realtime: bool,
    /// Its stamps as they are, of whatever clock (`--keep-stamps`).
    pub keep_stamps: bool,
    /// No error when no fusiond received it (`--allow-no-daemon`).
    pub allow_no_daemon: bool,
}

/// What became of the file's lines.
#[derive(Debug, Default)]
struct Tally {
    published: u64,
    delivered: u64,
    skipped: u64,
    unacknowledged: u64,
}

/// A line of the file, parsed once (`None`: blank), so that the next one can be looked at.
type Line = std::io::Result<Option<Result<Sample, serde_json::Error>>>;

/// Publishes a file in file order: paced by its timestamps (`realtime`), or in
/// lockstep with the daemon: each sample after the snapshot of the one before, so
/// the daemon sees exactly the file's order and any reader can keep up with the
/// snapshots.
pub(crate) fn publish_file(client: &Client, path: &Path, how: How, stop: &AtomicBool) -> anyhow::Result<()> {
    let file = std::io::BufReader::new(std::fs::File::open(path).with_context(|| path.display().to_string())?);
    let mut publishers = SensorPublishers::all(client)?;
    // Lockstep needs the daemon's snapshots; paced by the clock, it may start later.
    let state = match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
        Ok(s) => Some(s),
        Err(fusion_client::ClientError::DaemonNotRunning { .. }) if how.realtime || how.allow_no_daemon => None,
        Err(e) => return Err(e.into()),
    };
    let daemon_seen = state.is_some();
    // No daemon to keep step with (--allow-no-daemon): the file's own pace.
    let mut lockstep = state.filter(|_| !how.realtime).map(Lockstep::new);
    let mut clock = Clock { keep_stamps: how.keep_stamps, realtime: lockstep.is_none(), ..Clock::default() };
    let mut tally = Tally::default();
    let mut lines = file.lines().enumerate().map(|(i, line)| (i, parse(line))).peekable();
    while let Some((i, line)) = lines.next() {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let Some(mut sample) = sample_of(path, i, line, &mut tally)? else { continue };
        clock.stamp(path, i, &mut sample, stop);
        if stop.load(Ordering::Relaxed) {
            break;
        }
        tally.delivered += u64::from(publishers.publish(sample)?.is_some_and(|readers| readers > 0));
        tally.published += 1;
        if let Some(lockstep) = lockstep.as_mut() {
            let next = lines.peek().and_then(|(_, l)| l.as_ref().ok()).and_then(|p| p.as_ref()?.as_ref().ok());
            let same_instant = |n: &Sample| {
                sample.kind() == SampleKind::Imu && n.kind() == SampleKind::Imu && n.t_ns() == sample.t_ns()
            };
            lockstep.after(sample, next.is_some_and(same_instant), &mut tally)?;
        }
    }
    if let Some(restamp) = &clock.restamp.flatten() {
        eprint!("{}", restamp.jumps);
    }
    finish(client, path, &tally, daemon_seen, how.allow_no_daemon, stop)
}

fn parse(line: std::io::Result<String>) -> Line {
    line.map(|l| (!l.trim().is_empty()).then(|| parse_sample(&l)))
}

/// The sample of line `i`, if it holds one (a blank line holds none; an
/// unreadable one is counted and said); an error if the file is no text.
fn sample_of(path: &Path, i: usize, line: Line, tally: &mut Tally) -> anyhow::Result<Option<Sample>> {
    let parsed = match line {
        Ok(parsed) => parsed,
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => anyhow::bail!(
            "{}: line {} is not text: the file is not JSON lines (`fusion-sim record` writes them; an MCAP \
             recording is replayed with `fusiond replay --input`)",
            path.display(),
            i + 1
        ),
        Err(e) => return Err(anyhow::Error::new(e).context(format!("cannot read {}", path.display()))),
    };
    match parsed {
        None => Ok(None),
        Some(Ok(s)) => Ok(Some(s)),
        Some(Err(e)) => {
            eprintln!("fusion-sim: line {}: {e}", i + 1);
            tally.skipped += 1;
            Ok(None)
        }
    }
}

/// When each sample goes out.
#[derive(Default)]
struct Clock {
    keep_stamps: bool,
    realtime: bool,
    /// Set at the first sample: the stamps moved onto this host's clock of a
    /// file stamped on another (`Some(None)`: stamped on this one).
    restamp: Option<Option<bag::Restamp>>,
    /// The first timestamp and the wall time of it (`realtime`).
    pace: Option<(u64, u64)>,
}

impl Clock {
    /// Restamps `sample` (line `i`) if the file is of another clock, and
    /// waits until it is due (`realtime`, or restamped).
    fn stamp(&mut self, path: &Path, i: usize, sample: &mut Sample, stop: &AtomicBool) {
        let keep = self.keep_stamps;
        let first_t = sample.t_ns();
        let restamped = self.restamp.get_or_insert_with(|| {
            let shift = (!keep).then(|| foreign_clock_shift(path, first_t)).flatten()?;
            Some(bag::Restamp::new(DEFAULT_MAX_JUMP_NS, 0, Some(shift), "line"))
        });
        if let Some(restamp) = restamped {
            let (t, paced) = restamp.stamp(i as u64 + 1, sample.t_ns());
            sample.header_mut().t_ns = t;
            // fusiond refuses stamps ahead of its clock: none goes out early
            // (a stamp far from the others goes at once, for fusiond to refuse).
            if paced {
                sleep_until(t, stop);
            }
        } else if self.realtime {
            let (t0, wall0) = *self.pace.get_or_insert((sample.t_ns(), now_ns()));
            sleep_until(wall0 + sample.t_ns().saturating_sub(t0), stop);
        }
    }
}

/// Keeping step with fusiond: each IMU instant's samples, then the snapshot
/// that answers one of them.
struct Lockstep {
    state: StateSubscriber,
    /// The IMU samples of one instant published so far: fusiond publishes one
    /// snapshot for the instant, after whichever of them completes it, so the
    /// lockstep waits once, after the instant's last one.
    instant: Vec<Sample>,
    /// fusiond's refusal counters, as its latest snapshot gave them.
    rejections: [u64; rejection::MAX],
    last_answer: Instant,
    unanswered: u64,
}

impl Lockstep {
    fn new(state: StateSubscriber) -> Self {
        Self { state, instant: Vec::new(), rejections: [0; rejection::MAX], last_answer: Instant::now(), unanswered: 0 }
    }

    /// After `sample` was published: waits for its snapshot, unless the next
    /// sample is of the same IMU instant; an error when fusiond has answered
    /// none for [`SILENCE`].
    fn after(&mut self, sample: Sample, more_of_instant: bool, tally: &mut Tally) -> anyhow::Result<()> {
        self.instant.push(sample);
        if more_of_instant {
            return Ok(());
        }
        let acknowledged = self.wait_answer()?;
        self.instant.clear();
        tally.unacknowledged += u64::from(!acknowledged);
        if acknowledged {
            (self.last_answer, self.unanswered) = (Instant::now(), 0);
            return Ok(());
        }
        self.unanswered += 1;
        if self.last_answer.elapsed() > SILENCE {
            return Err(self.silence());
        }
        Ok(())
    }

    /// Whether a snapshot of one of the instant's samples comes within [`ACK_TIMEOUT`].
    fn wait_answer(&mut self) -> anyhow::Result<bool> {
        let deadline = Instant::now() + ACK_TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.state.wait_next(left)? {
                Some(s)
                    if self.instant.iter().any(|sample| {
                        s.input_kind == sample.kind() as u32
                            && s.input_sensor == sample.sensor()
                            && s.input_seq == sample.seq()
                            && s.input_t_ns == sample.t_ns()
                    }) =>
                {
                    return Ok(true);
                }
                Some(s) => self.rejections = s.rejections,
                None => return Ok(false),
            }
        }
    }

    /// fusiond answers nothing: why, from its refusal counters if they say.
    fn silence(&self) -> anyhow::Error {
        let unanswered = self.unanswered;
        let reasons: Vec<String> = rejection::ALL
            .iter()
            .filter(|(code, _)| self.rejections[*code as usize] > 0)
            .map(|(code, name)| format!("{} {name}: {}", self.rejections[*code as usize], rejection::advice(*code)))
            .collect();
        if !reasons.is_empty() {
            return anyhow::anyhow!(
                "fusiond answered none of the last {unanswered} samples in {:.0} s: its refusal counters \
                 (`fusionctl state`) say {}",
                SILENCE.as_secs_f64(),
                reasons.join("; ")
            );
        }
        anyhow::anyhow!(
            "fusiond answered none of the last {unanswered} samples in {:.0} s: it refuses them \
             (`fusionctl state` and its log say why; samples stamped on another clock than fusiond's, \
             as a recording's, are too far in the past: raise [validation] max_past_ns, or run \
             `fusiond replay` on the file)",
            SILENCE.as_secs_f64()
        )
    }
}

/// What was published, on stderr; an error if nothing was, or no fusiond received it.
fn finish(
    client: &Client,
    path: &Path,
    t: &Tally,
    daemon_seen: bool,
    allow_no_daemon: bool,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let done = format!(
        "published {} samples from {} ({} unreadable lines, {} without a snapshot, {} reached no reader)",
        t.published,
        path.display(),
        t.skipped,
        t.unacknowledged,
        t.published - t.delivered
    );
    if stop.load(Ordering::Relaxed) {
        return Err(fusion_shared::exit::Interrupted(format!("interrupted: {done} before the signal")).into());
    }
    eprintln!("fusion-sim: {done}");
    if t.published == 0 && t.skipped > 0 {
        anyhow::bail!("{}: none of its {} lines is a sample (see the lines above)", path.display(), t.skipped);
    }
    if t.published == 0 {
        anyhow::bail!("{}: no sample in it (an empty file)", path.display());
    }
    let daemon_seen = daemon_seen || crate::daemon_runs(client);
    if (t.delivered == 0 || !daemon_seen) && !allow_no_daemon {
        anyhow::bail!(
            "no fusiond received the samples: none runs in namespace {:?} (--allow-no-daemon to publish anyway)",
            client.names().namespace
        );
    }
    Ok(())
}

/// The shift onto this host's clock (CLOCK_MONOTONIC) of a file whose first
/// sample is stamped `first_t_ns`: `None` when that stamp is of this clock
/// (within [`FOREIGN_CLOCK_PAST_NS`] before now, not ahead of it); else the
/// file was stamped on another clock (a recording stamped from 1 s, as
/// `fusion-sim record` writes it), and its samples are moved to start 0.1 s
/// from now, said on stderr.
fn foreign_clock_shift(path: &Path, first_t_ns: u64) -> Option<i128> {
    let now = now_ns();
    if first_t_ns + FOREIGN_CLOCK_PAST_NS >= now && first_t_ns <= now + 50_000_000 {
        return None;
    }
    let start = now + 100_000_000;
    eprintln!(
        "fusion-sim: {} is stamped on another clock (its first sample at {:.3} s, this host's clock at {:.3} s): its \
         stamps are moved onto this host's clock, the first 0.1 s from now, and each sample is published at its \
         stamp",
        path.display(),
        first_t_ns as f64 * 1e-9,
        now as f64 * 1e-9
    );
    Some(i128::from(start) - i128::from(first_t_ns))
}
