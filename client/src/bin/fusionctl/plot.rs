//! `fusionctl plot`: a report of a run, as SVG and PNG, from an MCAP recording
//! (`fusionctl record`) or a replay output (`fusiond replay --output`, with its
//! input for the fixes: the JSON-lines file, or the ROS bag, whose every
//! `sensor_msgs/NavSatFix` topic is drawn, fused or not):
//!
//! - `trajectory`: the estimate east/north on equal scales, the fixes (gated ones as
//!   crosses, ones fusiond did not fuse as rings; for `ins` the antenna positions
//!   as measured), the truth;
//! - `errors`: each position and velocity component's error with its ±3σ band
//!   (with truth), or the ±3σ band alone (the page says so);
//! - `attitude` (`ins`): the attitude error (with truth) or its ±3σ band, and each
//!   IMU bias estimate with its ±3σ band;
//! - `nis`: the NIS of each measuring sensor with its two-sided 95 % χ² bounds, the
//!   scale clipped to the fused values, gated measurements as crosses (beyond the
//!   scale: triangles on its edge);
//! - `latency` (a live recording): the histogram of sample sent → snapshot published.
//!
//! Times are seconds since the first estimate; each page's title gives that start
//! (CLOCK_MONOTONIC) and says whether the estimates are RTS-smoothed.
//! `report.json` lists the files, how many points each series has, and where
//! the gated fixes are (east, north).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use anyhow::Context;
use fusion_shared::recording::{self, SnapshotJson};
use fusion_shared::{Sample, SampleKind};
use plotters::coord::Shift;
use plotters::prelude::*;

mod pages;
mod replayed;
use pages::Result;
use replayed::from_replay;

/// Most points drawn of one time series; longer ones are thinned evenly.
const MAX_POINTS: usize = 4000;
const SIZE: (u32, u32) = (1200, 900);

/// The estimate at one time: position and velocity with standard deviations,
/// and for `ins` the attitude and the IMU biases.
#[derive(Debug, Clone, Copy)]
struct Estimate {
    t: f64,
    pv: [f64; 6],
    sd: [f64; 6],
    ins: Option<InsPart>,
}

/// The `ins` part of an estimate: attitude (body → ENU, `[w, x, y, z]`), its
/// error's σ about the body axes (rad), the biases (accelerometer m/s², then
/// gyroscope rad/s) and their σ.
#[derive(Debug, Clone, Copy)]
struct InsPart {
    q_wxyz: [f64; 4],
    att_sd: [f64; 3],
    bias: [f64; 6],
    bias_sd: [f64; 6],
}

/// A position fix in the ENU frame and what fusiond made of it.
#[derive(Debug, Clone, Copy)]
struct Fix {
    east: f64,
    north: f64,
    fate: Fate,
}

/// What fusiond made of a fix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fate {
    Fused,
    /// The filter refused it (χ² gate).
    Gated,
    /// Not in the output: a topic no `[[sensor]]` reads (a reference drawn
    /// beside the estimate), or a sample refused before the filter.
    NotFused,
}

impl Fate {
    /// The fate of a fix found in the output (`Some(gated)`) or not.
    fn of(gated: Option<bool>) -> Self {
        match gated {
            Some(false) => Fate::Fused,
            Some(true) => Fate::Gated,
            None => Fate::NotFused,
        }
    }
}

/// One measurement's NIS.
#[derive(Debug, Clone, Copy)]
struct Nis {
    t: f64,
    value: f64,
    gated: bool,
}

#[derive(Default)]
struct Data {
    /// The first estimate's time, CLOCK_MONOTONIC s: every time here is since it.
    t0: f64,
    /// The estimates are RTS-smoothed (a `fusiond replay --smooth` output).
    smoothed: bool,
    estimates: Vec<Estimate>,
    fixes: Vec<Fix>,
    /// Per sensor ("position 1"): its measurement dimension and NIS values.
    nis: BTreeMap<String, (usize, Vec<Nis>)>,
    /// (t, position and velocity, attitude `[w, x, y, z]` or NaN).
    truth: Vec<(f64, [f64; 6], [f64; 4])>,
    /// Sent → published, µs, of the samples processed in order.
    latency_us: Vec<f64>,
    /// The damage of a recording, and what the report still shows.
    damage: Option<String>,
}

/// The χ² degrees of freedom of a kind's NIS.
fn dimension(kind: SampleKind) -> usize {
    kind.innovation_dim()
}

fn kind_of(name: &str) -> Option<SampleKind> {
    SampleKind::from_name(name)
}

fn estimate(t_ns: u64, x: &[f64], p: &[f64]) -> Option<Estimate> {
    let n = (p.len() as f64).sqrt() as usize;
    if x.len() < 6 || n < 6 {
        return None;
    }
    let sd = |i: usize| p[i * n + i].max(0.0).sqrt();
    let mut e =
        Estimate { t: t_ns as f64 * 1e-9, pv: std::array::from_fn(|i| x[i]), sd: std::array::from_fn(sd), ins: None };
    // The ins layout: x = [p, v, q_wxyz, b_a, b_g], P over [δp, δv, δθ, δb_a, δb_g].
    if x.len() >= 16 && n >= 15 {
        e.ins = Some(InsPart {
            q_wxyz: [x[6], x[7], x[8], x[9]],
            att_sd: [sd(6), sd(7), sd(8)],
            bias: std::array::from_fn(|k| x[10 + k]),
            bias_sd: std::array::from_fn(|k| sd(9 + k)),
        });
    }
    Some(e)
}

/// A fix's east/north, given the datum for a geodetic one.
fn fix_of(sample: &Sample, datum: Option<fusion_shared::geodesy::Datum>) -> Option<(f64, f64)> {
    match sample {
        Sample::Position(p) => Some((p.pos_m[0], p.pos_m[1])),
        Sample::Geodetic(g) => datum.map(|d| d.to_enu(g.lat_deg, g.lon_deg, g.height_m)).map(|e| (e[0], e[1])),
        _ => None,
    }
}

fn sample_key(s: &Sample) -> (SampleKind, u32, u64) {
    (s.kind(), s.sensor(), s.seq())
}

/// A measurement sample waiting for its outcome.
#[derive(Debug, Clone, Copy)]
struct Pending {
    sensor: u32,
    seq: u64,
    t_ns: u64,
}

/// Each measurement's outcome (fused or gated, its NIS) from the snapshots'
/// counters. An in-order sample's outcome is in its own snapshot; a late one's
/// comes with a later snapshot, when the daemon has worked its rewind in (the
/// sensor's count of outcomes goes up then), in the order the late samples of
/// the sensor came.
///
/// A rewind can also change the decision on a sample it re-steps (counted as
/// one fused less and one gated more, or the reverse): that moves no count of
/// outcomes, and is not told apart from a new outcome in the same snapshot, so
/// the cross of such a sample stays where its first decision put it.
#[derive(Debug, Default)]
struct Outcomes {
    /// Per sensor: its fused, gated and refused counts in the last snapshot.
    counts: HashMap<(String, u32), [u64; 3]>,
    /// Per sensor: its late samples without an outcome yet, oldest first.
    waiting: HashMap<(String, u32), std::collections::VecDeque<Pending>>,
}

impl Outcomes {
    /// Takes in a snapshot with an input, calling `f(kind, sample, gated, nis)`
    /// for each measurement whose outcome it shows.
    fn snapshot(&mut self, s: &SnapshotJson, mut f: impl FnMut(SampleKind, Pending, bool, Option<f64>)) {
        let input = &s.input;
        let in_order = input.kind == s.kind && input.sensor == s.sensor && input.seq == s.seq;
        let measurement = kind_of(&input.kind).filter(|k| *k != SampleKind::Imu);
        let pending = Pending { sensor: input.sensor, seq: input.seq, t_ns: input.t_ns };
        if measurement.is_some() && !in_order {
            self.waiting.entry((input.kind.clone(), input.sensor)).or_default().push_back(pending);
        }
        for c in &s.counters {
            let Some(kind) = kind_of(&c.kind).filter(|k| *k != SampleKind::Imu) else { continue };
            let key = (c.kind.clone(), c.sensor);
            let n = &c.counts;
            let now = [n.fused, n.gated, n.refused];
            let [fused, gated, refused] = self.counts.insert(key.clone(), now).unwrap_or_default();
            // New outcomes (a changed decision moves none), and of them the gated.
            let outcomes = (n.fused + n.gated + n.refused).saturating_sub(fused + gated + refused);
            let mut new = (outcomes, n.gated.saturating_sub(gated).min(outcomes));
            let mut outcome = |new: &mut (u64, u64), fix: Pending, nis| {
                let gated = new.1 > 0;
                *new = (new.0 - 1, new.1.saturating_sub(1));
                f(kind, fix, gated, nis);
            };
            if in_order && c.kind == input.kind && c.sensor == input.sensor && new.0 > 0 {
                outcome(&mut new, pending, c.last_nis);
            }
            let Some(waiting) = self.waiting.get_mut(&key) else { continue };
            while new.0 > 0 {
                let Some(fix) = waiting.pop_front() else { break };
                // The sensor's last NIS is the newest one's: several outcomes
                // in one snapshot leave the older ones without a NIS point.
                let last = new.0 == 1;
                outcome(&mut new, fix, if last { c.last_nis } else { None });
            }
        }
    }
}

/// When t = 0 is (`t0`, s of the input's clock): seconds of CLOCK_MONOTONIC,
/// or, for stamps of the wall clock (a ROS bag's: past 10⁹ s, which no
/// uptime reaches), the UTC date and time.
fn time_zero(t0: f64) -> String {
    if t0 < 1.0e9 {
        return format!("{t0:.3} s of CLOCK_MONOTONIC");
    }
    let secs = t0.floor() as i64;
    let (days, day_s) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Days since 1970-01-01 to the civil date (H. Hinnant, "chrono-Compatible
    // Low-Level Date Algorithms", days_from_civil's inverse).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let seconds = (day_s % 60) as f64 + t0.fract();
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{seconds:06.3} UTC (the input's wall-clock stamps)",
        day_s / 3600,
        day_s % 3600 / 60
    )
}

/// Reads an MCAP recording: snapshots for the estimate, NIS and latency; the
/// sample messages for the fixes.
fn from_recording(path: &Path) -> anyhow::Result<Data> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut data = Data::default();
    let mut samples = Vec::new();
    let mut gated_fixes = HashMap::new();
    let mut outcomes = Outcomes::default();
    let mut datum = None;
    // A damaged chunk is never handed to the mcap reader (it would believe
    // the sizes it declares): the report shows what comes before it.
    let scan = fusion_shared::mcap_scan::scan(&bytes);
    for (messages, m) in mcap::MessageStream::new(&bytes[..scan.readable])?.enumerate() {
        let m = match m {
            Ok(m) => m,
            Err(mcap::McapError::UnexpectedEof) if let Some(damage) = &scan.damage => {
                let held = scan.message_count.map_or(String::new(), |n| format!(" of the {n} the file held"));
                data.damage = Some(format!(
                    "{} is {damage}: the report shows the {messages} messages before it{held}; the {} bytes after \
                     it are not read",
                    path.display(),
                    damage.lost_bytes
                ));
                break;
            }
            // Cut off by the end of the file (the recorder was killed or lost
            // its power): what its complete chunks hold is the report.
            Err(mcap::McapError::UnexpectedEof) => {
                eprintln!(
                    "fusionctl: {} was cut off (no summary: the recorder was killed or lost its power): the report \
                     shows its {messages} messages in complete chunks",
                    path.display()
                );
                break;
            }
            Err(e) => return Err(e.into()),
        };
        if let Some(kind) = recording::kind_of_topic(&m.channel.topic) {
            if let Ok(s) = recording::parse_sample(kind, &m.data) {
                samples.push(s);
            }
            continue;
        }
        if m.channel.topic != recording::STATE_TOPIC {
            continue;
        }
        let s: SnapshotJson = serde_json::from_slice(&m.data)?;
        if let Some(d) = &s.datum {
            datum = fusion_shared::geodesy::Datum::new(d.lat_deg, d.lon_deg, d.height_m).ok();
        }
        if !s.has_input() {
            continue;
        }
        data.estimates.extend(estimate(s.t_ns, &s.x, &s.p));
        if s.input.replayed == 0 && s.input.sent_ns > 0 && s.publish_ns > s.input.sent_ns {
            data.latency_us.push((s.publish_ns - s.input.sent_ns) as f64 * 1e-3);
        }
        outcomes.snapshot(&s, |kind, fix, gated, nis| {
            gated_fixes.insert((kind, fix.sensor, fix.seq), gated);
            if let Some(value) = nis {
                let series =
                    data.nis.entry(format!("{} {}", kind.name(), fix.sensor)).or_insert((dimension(kind), Vec::new()));
                series.1.push(Nis { t: fix.t_ns as f64 * 1e-9, value, gated });
            }
        });
    }
    for s in &samples {
        if let Some((east, north)) = fix_of(s, datum) {
            let gated = gated_fixes.get(&sample_key(s)).copied().unwrap_or(false);
            data.fixes.push(Fix { east, north, fate: Fate::of(Some(gated)) });
        }
    }
    Ok(data)
}

/// The text of `path`, or an error that says what the file should have been
/// (`what`) when it is not text.
fn read_text(path: &Path, what: &str) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    as_text(path, bytes, what)
}

/// `bytes` (of `path`) as text, or an error that says what the file should
/// have been (`what`).
fn as_text(path: &Path, bytes: Vec<u8>, what: &str) -> anyhow::Result<String> {
    String::from_utf8(bytes).map_err(|_| anyhow::anyhow!("{}: not a text file (expected {what})", path.display()))
}

/// A truth entry: time, position and velocity, attitude `[w, x, y, z]` (NaN
/// when the truth has none).
type Truth = (f64, [f64; 6], [f64; 4]);

/// Reads `fusion-sim record --truth` lines.
fn read_truth(path: &Path) -> anyhow::Result<Vec<Truth>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut truth = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let v: serde_json::Value = serde_json::from_str(line)?;
        let get = |k: &str, i: usize| v[k][i].as_f64().unwrap_or(f64::NAN);
        let t = v["t_ns"].as_u64().context("truth line without t_ns")? as f64 * 1e-9;
        let pv = [get("pos", 0), get("pos", 1), get("pos", 2), get("vel", 0), get("vel", 1), get("vel", 2)];
        truth.push((t, pv, std::array::from_fn(|k| get("q_wxyz", k))));
    }
    truth.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(truth)
}

/// The truth's position and velocity at `t`, linearly interpolated, and the
/// attitude of the nearest earlier entry; `None` outside it.
fn truth_at(truth: &[Truth], t: f64) -> Option<([f64; 6], [f64; 4])> {
    let i = truth.partition_point(|(tt, _, _)| *tt < t);
    let b = truth.get(i)?;
    if b.0 == t || i == 0 {
        return (b.0 == t).then_some((b.1, b.2));
    }
    let a = truth[i - 1];
    let w = (t - a.0) / (b.0 - a.0);
    Some((std::array::from_fn(|k| a.1[k] + w * (b.1[k] - a.1[k])), a.2))
}

/// The attitude error `δθ` (deg, about the estimate's body axes) of the
/// estimate `q_est` against the truth `q_true`, both `[w, x, y, z]`:
/// `q_true = q_est ⊗ Exp(δθ)` (the filter's local error, Solà 2017 §5.3.3).
fn attitude_error_deg(q_est: [f64; 4], q_true: [f64; 4]) -> Option<[f64; 3]> {
    use nalgebra::{Quaternion, UnitQuaternion};
    if q_true.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let q = |c: [f64; 4]| UnitQuaternion::from_quaternion(Quaternion::new(c[0], c[1], c[2], c[3]));
    let d = (q(q_est).inverse() * q(q_true)).scaled_axis();
    Some([d.x.to_degrees(), d.y.to_degrees(), d.z.to_degrees()])
}

/// Points per series, and the scales of some panels, for `report.json`.
#[derive(Default)]
struct Counts(BTreeMap<String, usize>, BTreeMap<String, f64>);

impl Counts {
    fn insert(&mut self, k: &str, n: usize) {
        self.0.insert(k.to_string(), n);
    }

    fn scale(&mut self, k: &str, v: f64) {
        self.1.insert(k.to_string(), v);
    }
}

/// One page of the report.
#[derive(Debug, Clone, Copy)]
enum Page {
    Trajectory,
    Errors,
    Attitude,
    Nis,
    Latency,
}

impl Page {
    fn name(self) -> &'static str {
        match self {
            Page::Trajectory => "trajectory",
            Page::Errors => "errors",
            Page::Attitude => "attitude",
            Page::Nis => "nis",
            Page::Latency => "latency",
        }
    }

    fn draw<DB: DrawingBackend>(self, root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        // Every page says when its time 0 is and what its estimates are.
        root.fill(&WHITE)?;
        let title = format!(
            "{}: t = 0 at {}{}",
            self.name(),
            time_zero(d.t0),
            if d.smoothed { "; RTS-smoothed estimates (fusiond replay --smooth)" } else { "" }
        );
        let root = root.titled(&title, ("sans-serif", 18))?;
        match self {
            Page::Trajectory => pages::draw_trajectory(&root, d, counts),
            Page::Errors => pages::draw_errors(&root, d, counts),
            Page::Attitude => pages::draw_attitude(&root, d, counts),
            Page::Nis => pages::draw_nis(&root, d, counts),
            Page::Latency => pages::draw_latency(&root, d, counts),
        }?;
        root.present()?;
        Ok(())
    }
}

/// Writes the report of `input` (a recording, or a replay output with
/// `samples` its input) into `dir`; returns the files written, and the
/// damage of a recording read only up to it.
pub fn run(
    input: &Path,
    samples: Option<&Path>,
    truth: Option<&Path>,
    dir: &Path,
) -> anyhow::Result<(Vec<PathBuf>, Option<String>)> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow::anyhow!("the embedded font does not load"))?;
    let mut head = [0u8; 8];
    let n = std::fs::File::open(input)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .with_context(|| format!("cannot read {}", input.display()))?;
    let named_mcap = input.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    anyhow::ensure!(
        !named_mcap || head[..n].starts_with(mcap::MAGIC),
        "{}: named .mcap but not an MCAP file (it does not start with the MCAP magic bytes)",
        input.display()
    );
    let mut data =
        if head[..n].starts_with(mcap::MAGIC) { from_recording(input)? } else { from_replay(input, samples)? };
    if data.estimates.is_empty() {
        return Err(match data.damage {
            Some(damage) => {
                fusion_shared::exit::InputDamaged(format!("{damage}: no estimate before it to plot")).into()
            }
            None => anyhow::anyhow!("{} has no estimates to plot", input.display()),
        });
    }
    if let Some(path) = truth {
        data.truth = read_truth(path)?;
        check_truth_covers(&data, path)?;
    }
    // Times since the first estimate (CLOCK_MONOTONIC seconds say nothing).
    data.t0 = data.estimates.iter().map(|e| e.t).fold(f64::INFINITY, f64::min);
    let t0 = data.t0;
    data.estimates.iter_mut().for_each(|e| e.t -= t0);
    data.truth.iter_mut().for_each(|t| t.0 -= t0);
    data.nis.values_mut().flat_map(|(_, v)| v.iter_mut()).for_each(|v| v.t -= t0);
    let files = write_pages(input, &data, dir)?;
    Ok((files, data.damage))
}

/// Whether the truth at `path` covers the estimates: an error if it covers
/// none, a word on stderr if less than half.
fn check_truth_covers(data: &Data, path: &Path) -> anyhow::Result<()> {
    let covered = data.estimates.iter().filter(|e| truth_at(&data.truth, e.t).is_some()).count();
    let span = |t: &mut dyn Iterator<Item = f64>| {
        t.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)))
    };
    let (e0, e1) = span(&mut data.estimates.iter().map(|e| e.t));
    let (t0, t1) = span(&mut data.truth.iter().map(|t| t.0));
    anyhow::ensure!(
        covered > 0,
        "{}: the truth covers t = {t0:.3}..{t1:.3} s and the estimates t = {e0:.3}..{e1:.3} s (CLOCK_MONOTONIC): \
         no estimate falls within it, so there is no error to plot (is it this run's truth?)",
        path.display()
    );
    if covered * 2 < data.estimates.len() {
        eprintln!(
            "fusionctl: {} covers {covered} of the {} estimates (t = {t0:.3}..{t1:.3} s of the estimates' \
             {e0:.3}..{e1:.3} s): the error panels show those",
            path.display(),
            data.estimates.len()
        );
    }
    Ok(())
}

/// Writes each page (SVG and PNG) and `report.json` into `dir`; the files written.
fn write_pages(input: &Path, data: &Data, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut pages = vec![Page::Trajectory, Page::Errors, Page::Nis];
    if data.estimates.iter().any(|e| e.ins.is_some()) {
        pages.insert(2, Page::Attitude);
    }
    if !data.latency_us.is_empty() {
        pages.push(Page::Latency);
    }
    let mut counts = Counts::default();
    let mut files = Vec::new();
    for page in pages {
        let path = dir.join(format!("{}.svg", page.name()));
        page.draw(&SVGBackend::new(&path, SIZE).into_drawing_area(), data, &mut counts)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        files.push(path);
        let path = dir.join(format!("{}.png", page.name()));
        page.draw(&BitMapBackend::new(&path, SIZE).into_drawing_area(), data, &mut counts)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        files.push(path);
    }
    let report = dir.join("report.json");
    let names: Vec<String> = files.iter().filter_map(|f| f.file_name()).map(|f| f.to_string_lossy().into()).collect();
    let json = serde_json::json!({
        "input": input.display().to_string(),
        "files": names,
        "t0_s": data.t0,
        "smoothed": data.smoothed,
        "points": counts.0,
        "scales": counts.1,
        "gated_fixes": data.fixes.iter().filter(|f| f.fate == Fate::Gated).map(|f| [f.east, f.north]).collect::<Vec<_>>(),
    });
    std::fs::write(&report, serde_json::to_string_pretty(&json)?)?;
    files.push(report);
    Ok(files)
}

#[cfg(test)]
mod tests;
