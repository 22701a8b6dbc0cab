//! `fusionctl plot`: a report of a run, as SVG and PNG, from an MCAP recording
//! (`fusionctl record`) or a replay output (`fusiond replay --output`, with its
//! input for the fixes):
//!
//! - `trajectory`: the estimate east/north on equal scales, the fixes (gated ones as
//!   crosses; for `ins` the antenna positions as measured), the truth;
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
//! `report.json` lists the files and how many points each series has.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use anyhow::Context;
use fusion_shared::recording::{self, SnapshotJson};
use fusion_shared::{Sample, SampleKind};
use plotters::coord::Shift;
use plotters::prelude::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};

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

/// A position fix in the ENU frame; `gated` when the filter refused it.
#[derive(Debug, Clone, Copy)]
struct Fix {
    east: f64,
    north: f64,
    gated: bool,
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

/// Reads an MCAP recording: snapshots for the estimate, NIS and latency; the
/// sample messages for the fixes.
fn from_recording(path: &Path) -> anyhow::Result<Data> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut data = Data::default();
    let mut samples = Vec::new();
    let mut gated_fixes = HashMap::new();
    let mut previous_gated: HashMap<(String, u32), u64> = HashMap::new();
    let mut datum = None;
    for (messages, m) in mcap::MessageStream::new(&bytes)?.enumerate() {
        let m = match m {
            Ok(m) => m,
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
        // The input's NIS is its sensor's last NIS; it was gated if the
        // sensor's gated count went up.
        let Some(kind) = kind_of(&s.input.kind).filter(|k| *k != SampleKind::Imu) else { continue };
        let Some(c) = s.counters.iter().find(|c| c.kind == s.input.kind && c.sensor == s.input.sensor) else {
            continue;
        };
        let before = previous_gated.insert((c.kind.clone(), c.sensor), c.gated).unwrap_or(0);
        let gated = c.gated > before;
        gated_fixes.insert((kind, s.input.sensor, s.input.seq), gated);
        if let Some(value) = c.last_nis {
            let series = data.nis.entry(format!("{} {}", c.kind, c.sensor)).or_insert((dimension(kind), Vec::new()));
            series.1.push(Nis { t: s.input.t_ns as f64 * 1e-9, value, gated });
        }
    }
    for s in &samples {
        if let Some((east, north)) = fix_of(s, datum) {
            let gated = gated_fixes.get(&sample_key(s)).copied().unwrap_or(false);
            data.fixes.push(Fix { east, north, gated });
        }
    }
    Ok(data)
}

/// Reads a replay output and (for the fixes) its input.
fn from_replay(output: &Path, input: Option<&Path>) -> anyhow::Result<Data> {
    let text = std::fs::read_to_string(output).with_context(|| format!("cannot read {}", output.display()))?;
    let mut data = Data::default();
    let mut gated_fixes = HashMap::new();
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let v: serde_json::Value =
            serde_json::from_str(line).with_context(|| format!("{}:{}", output.display(), i + 1))?;
        let nums = |k: &str| -> Vec<f64> {
            v[k].as_array().map(|a| a.iter().filter_map(|x| x.as_f64()).collect()).unwrap_or_default()
        };
        let t_ns = v["t_ns"].as_u64().unwrap_or(0);
        data.smoothed |= v["smoothed"].as_bool() == Some(true);
        data.estimates.extend(estimate(t_ns, &nums("x"), &nums("P")));
        let (Some(kind), Some(sensor), Some(seq)) =
            (v["kind"].as_str().and_then(kind_of), v["sensor"].as_u64(), v["seq"].as_u64())
        else {
            continue;
        };
        let gated = v["accepted"].as_bool() == Some(false);
        gated_fixes.insert((kind, sensor as u32, seq), gated);
        if let Some(value) = v["nis"].as_f64() {
            let series = data.nis.entry(format!("{} {sensor}", kind.name())).or_insert((dimension(kind), Vec::new()));
            series.1.push(Nis { t: t_ns as f64 * 1e-9, value, gated });
        }
    }
    if let Some(input) = input {
        let text = std::fs::read_to_string(input).with_context(|| format!("cannot read {}", input.display()))?;
        for s in text.lines().filter_map(|l| fusion_shared::jsonl::parse_sample(l).ok()) {
            if let Some((east, north)) = fix_of(&s, None) {
                let gated = gated_fixes.get(&sample_key(&s)).copied().unwrap_or(false);
                data.fixes.push(Fix { east, north, gated });
            }
        }
    }
    Ok(data)
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

/// Every `k`-th item so that at most [`MAX_POINTS`] remain.
fn thin<T: Copy>(v: &[T]) -> Vec<T> {
    let step = v.len().div_ceil(MAX_POINTS).max(1);
    v.iter().step_by(step).copied().collect()
}

fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.filter(|v| v.is_finite()).fold((f64::MAX, f64::MIN), |(l, h), v| (l.min(v), h.max(v)));
    if lo > hi {
        return -1.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1e-9);
    lo - pad..hi + pad
}

/// The `q` quantile of `values` (0 for none).
fn percentile(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.get(((v.len().max(1) - 1) as f64 * q) as usize).copied().unwrap_or(0.0)
}

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// `x` and `y` widened (about their middles) so that a metre is as long on
/// both axes of a plotting area of `w` × `h` pixels: a circle stays a circle.
fn equal_scales(x: std::ops::Range<f64>, y: std::ops::Range<f64>, (w, h): (u32, u32)) -> [std::ops::Range<f64>; 2] {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let per_px = ((x.end - x.start) / w).max((y.end - y.start) / h);
    let around = |r: std::ops::Range<f64>, px: f64| {
        let mid = 0.5 * (r.start + r.end);
        mid - 0.5 * per_px * px..mid + 0.5 * per_px * px
    };
    [around(x, w), around(y, h)]
}

fn draw_trajectory<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let est = thin(&d.estimates);
    let truth = thin(&d.truth);
    let xs = est.iter().map(|e| e.pv[0]).chain(d.fixes.iter().map(|f| f.east)).chain(truth.iter().map(|t| t.1[0]));
    let ys = est.iter().map(|e| e.pv[1]).chain(d.fixes.iter().map(|f| f.north)).chain(truth.iter().map(|t| t.1[1]));
    let (xs, ys) = (range(xs), range(ys));
    let builder = |x: std::ops::Range<f64>, y: std::ops::Range<f64>| {
        root.fill(&WHITE)?;
        ChartBuilder::on(root)
            .caption("trajectory (ENU), equal scales", ("sans-serif", 24))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x, y)
    };
    // Built once to learn the plotting area's size, then on equal scales.
    let area = builder(xs.clone(), ys.clone())?.plotting_area().dim_in_pixel();
    let [xs, ys] = equal_scales(xs, ys, area);
    counts.scale("trajectory.east_m_per_px", (xs.end - xs.start) / f64::from(area.0.max(1)));
    counts.scale("trajectory.north_m_per_px", (ys.end - ys.start) / f64::from(area.1.max(1)));
    let mut chart = builder(xs, ys)?;
    chart.configure_mesh().x_desc("east, m").y_desc("north, m").draw()?;
    if !truth.is_empty() {
        chart
            .draw_series(LineSeries::new(truth.iter().map(|t| (t.1[0], t.1[1])), BLACK.stroke_width(1)))?
            .label("truth")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    }
    let ins = d.estimates.first().is_some_and(|e| e.ins.is_some());
    chart
        .draw_series(LineSeries::new(est.iter().map(|e| (e.pv[0], e.pv[1])), BLUE.stroke_width(2)))?
        .label(if ins { "estimate (IMU)" } else { "estimate" })
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
    let fused: Vec<_> = d.fixes.iter().filter(|f| !f.gated).collect();
    let gated: Vec<_> = d.fixes.iter().filter(|f| f.gated).collect();
    // The ins model fuses fixes at their antenna through the lever arm: drawn
    // as measured, they lie a lever arm beside the IMU's track.
    let (fix, gated_fix) =
        if ins { ("fix (antenna, as measured)", "gated fix (antenna)") } else { ("fix", "gated fix") };
    chart
        .draw_series(fused.iter().map(|f| Circle::new((f.east, f.north), 3, GREEN.filled())))?
        .label(fix)
        .legend(|(x, y)| Circle::new((x + 10, y), 3, GREEN.filled()));
    chart
        .draw_series(gated.iter().map(|f| Cross::new((f.east, f.north), 6, RED.stroke_width(2))))?
        .label(gated_fix)
        .legend(|(x, y)| Cross::new((x + 10, y), 6, RED));
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    counts.insert("trajectory.estimate", est.len());
    counts.insert("trajectory.truth", truth.len());
    counts.insert("trajectory.fixes", fused.len());
    counts.insert("trajectory.gated", gated.len());
    root.present()?;
    Ok(())
}

/// A panel of a value over time with its ±3σ band: `series` are (t, value)
/// (an error about 0, or an estimate), `band` (t, centre, 3σ). Both in the legend.
#[allow(clippy::too_many_arguments)]
fn draw_band_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    unit: &str,
    t: std::ops::Range<f64>,
    series: &[(f64, f64)],
    series_label: &str,
    band: &[(f64, f64, f64)],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    // The scale of the run after the start (the initial covariance and the
    // first errors would flatten everything; they run off the top): the 95th
    // percentile of |value| and the 75th of |centre ± 3σ|.
    let edge = band.iter().flat_map(|b| [(b.1 + b.2).abs(), (b.1 - b.2).abs()]);
    let top = 1.3 * percentile(series.iter().map(|e| e.1.abs()), 0.95).max(percentile(edge, 0.75)).max(1e-9);
    let y = -top..top;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(t, y)?;
    chart.configure_mesh().x_desc("t since start, s").y_desc(unit).draw()?;
    chart
        .draw_series(LineSeries::new(band.iter().map(|b| (b.0, b.1 + b.2)), RED.stroke_width(1)))?
        .label("±3σ")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED));
    chart.draw_series(LineSeries::new(band.iter().map(|b| (b.0, b.1 - b.2)), RED.stroke_width(1)))?;
    if !series.is_empty() {
        chart
            .draw_series(LineSeries::new(series.iter().copied(), BLUE.stroke_width(1)))?
            .label(series_label)
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

fn draw_errors<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let est = thin(&d.estimates);
    let names = ["east", "north", "up", "v east", "v north", "v up"];
    let with_truth = !d.truth.is_empty();
    let t = range(est.iter().map(|e| e.t));
    let root = if with_truth {
        root.clone()
    } else {
        root.titled("±3σ bands only: no truth was given (fusionctl plot --truth), so no errors", ("sans-serif", 16))?
    };
    for (i, area) in root.split_evenly((3, 2)).iter().enumerate() {
        // Panels column-major: position on the left, velocity on the right.
        let k = (i % 2) * 3 + i / 2;
        let errors: Vec<(f64, f64)> = if with_truth {
            est.iter().filter_map(|e| truth_at(&d.truth, e.t).map(|(tr, _)| (e.t, e.pv[k] - tr[k]))).collect()
        } else {
            Vec::new()
        };
        let band: Vec<(f64, f64, f64)> = est.iter().map(|e| (e.t, 0.0, 3.0 * e.sd[k])).collect();
        let title = if with_truth { format!("error {}", names[k]) } else { format!("±3σ {}", names[k]) };
        draw_band_panel(area, &title, if k < 3 { "m" } else { "m/s" }, t.clone(), &errors, "error", &band)?;
        counts.insert(&format!("errors.{k}.error"), errors.len());
        counts.insert(&format!("errors.{k}.band"), band.len());
    }
    root.present()?;
    Ok(())
}

/// The `ins` page: the attitude error about each body axis (with truth) or its
/// ±3σ band, and each bias estimate inside its ±3σ band.
fn draw_attitude<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let est: Vec<(f64, InsPart)> = thin(&d.estimates).iter().filter_map(|e| Some((e.t, e.ins?))).collect();
    let t = range(est.iter().map(|e| e.0));
    let panels = root.split_evenly((3, 3));
    for axis in 0..3 {
        let errors: Vec<(f64, f64)> = est
            .iter()
            .filter_map(|(t, e)| {
                let (_, q_true) = truth_at(&d.truth, *t)?;
                Some((*t, attitude_error_deg(e.q_wxyz, q_true)?[axis]))
            })
            .collect();
        let band: Vec<(f64, f64, f64)> =
            est.iter().map(|(t, e)| (*t, 0.0, 3.0 * e.att_sd[axis].to_degrees())).collect();
        let name = ["x (roll)", "y (pitch)", "z (yaw)"][axis];
        let title = if errors.is_empty() {
            format!("±3σ attitude about body {name}")
        } else {
            format!("attitude error about body {name}")
        };
        draw_band_panel(&panels[axis], &title, "deg", t.clone(), &errors, "error", &band)?;
        counts.insert(&format!("attitude.{axis}.error"), errors.len());
        counts.insert(&format!("attitude.{axis}.band"), band.len());
    }
    let bias_names = ["accel bias x", "accel bias y", "accel bias z", "gyro bias x", "gyro bias y", "gyro bias z"];
    for k in 0..6 {
        // Gyroscope biases in deg/h, the unit of their data sheets.
        let scale = if k < 3 { 1.0 } else { 3600.0_f64.to_degrees() };
        let values: Vec<(f64, f64)> = est.iter().map(|(t, e)| (*t, e.bias[k] * scale)).collect();
        let band: Vec<(f64, f64, f64)> =
            est.iter().map(|(t, e)| (*t, e.bias[k] * scale, 3.0 * e.bias_sd[k] * scale)).collect();
        let unit = if k < 3 { "m/s²" } else { "deg/h" };
        draw_band_panel(&panels[3 + k], bias_names[k], unit, t.clone(), &values, "estimate", &band)?;
        counts.insert(&format!("attitude.bias{k}"), values.len());
    }
    root.present()?;
    Ok(())
}

fn draw_nis<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let n = d.nis.len().max(1);
    let t = range(d.estimates.iter().map(|e| e.t));
    for (area, (sensor, (dof, values))) in root.split_evenly((n, 1)).iter().zip(&d.nis) {
        let chi2 = ChiSquared::new(*dof as f64)?;
        let (lo, hi) = (chi2.inverse_cdf(0.025), chi2.inverse_cdf(0.975));
        let values = thin(values);
        let (gated, fused): (Vec<Nis>, Vec<Nis>) = values.iter().partition(|v| v.gated);
        // The scale of the fused values (gated outliers would squash them):
        // their 99th percentile, at least 1.5 × the upper bound.
        let top = (1.1 * percentile(fused.iter().map(|v| v.value), 0.99)).max(hi * 1.5);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("NIS {sensor} (dof {dof}, 95 % χ² bounds)"), ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t.clone(), 0.0..top)?;
        chart.configure_mesh().x_desc("t since start, s").y_desc("NIS (no unit)").draw()?;
        chart
            .draw_series(LineSeries::new([(t.start, hi), (t.end, hi)], RED.stroke_width(1)))?
            .label(format!("χ² 2.5 % and 97.5 % ({lo:.2}, {hi:.2})"))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED));
        chart.draw_series(LineSeries::new([(t.start, lo), (t.end, lo)], RED.stroke_width(1)))?;
        let (beyond, within): (Vec<Nis>, Vec<Nis>) = gated.iter().partition(|v| v.value > top);
        let above = fused.iter().filter(|v| v.value > top).count();
        chart
            .draw_series(
                fused.iter().filter(|v| v.value <= top).map(|v| Circle::new((v.t, v.value), 2, BLUE.filled())),
            )?
            .label(if above > 0 { format!("fused ({above} above the scale)") } else { "fused".to_string() })
            .legend(|(x, y)| Circle::new((x + 10, y), 2, BLUE.filled()));
        chart
            .draw_series(within.iter().map(|v| Cross::new((v.t, v.value), 5, RED.stroke_width(2))))?
            .label("gated")
            .legend(|(x, y)| Cross::new((x + 10, y), 5, RED));
        // Gated outliers beyond the scale: on its edge, as triangles.
        chart
            .draw_series(beyond.iter().map(|v| TriangleMarker::new((v.t, top * 0.97), 6, RED.filled())))?
            .label(format!("gated, beyond the scale ({})", beyond.len()))
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 6, RED.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()?;
        counts.insert(&format!("nis.{sensor}"), values.len());
        counts.insert(&format!("nis.{sensor}.gated"), gated.len());
        counts.insert(&format!("nis.{sensor}.beyond"), beyond.len());
        counts.scale(&format!("nis.{sensor}.top"), top);
    }
    root.present()?;
    Ok(())
}

fn draw_latency<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut sorted = d.latency_us.clone();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted.get(((sorted.len() - 1) as f64 * p) as usize).copied().unwrap_or(0.0);
    // Up to the 99.9th percentile, in 100 bins.
    let top = q(0.999).max(1e-3);
    let bins = 100;
    let width = top / bins as f64;
    let mut hist = vec![0u32; bins];
    for v in sorted.iter().filter(|v| **v <= top) {
        hist[((v / width) as usize).min(bins - 1)] += 1;
    }
    let caption = format!("latency sent → published: p50 {:.1} µs, p99 {:.1} µs, n {}", q(0.5), q(0.99), sorted.len());
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..top, 0u32..hist.iter().copied().max().unwrap_or(1) + 1)?;
    chart.configure_mesh().x_desc("µs").y_desc("samples").draw()?;
    chart.draw_series(
        hist.iter().enumerate().map(|(i, &n)| {
            Rectangle::new([(i as f64 * width, 0), ((i + 1) as f64 * width, n)], BLUE.mix(0.6).filled())
        }),
    )?;
    counts.insert("latency.samples", sorted.len());
    root.present()?;
    Ok(())
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
            "{}: t = 0 at {:.3} s of CLOCK_MONOTONIC{}",
            self.name(),
            d.t0,
            if d.smoothed { "; RTS-smoothed estimates (fusiond replay --smooth)" } else { "" }
        );
        let root = root.titled(&title, ("sans-serif", 18))?;
        match self {
            Page::Trajectory => draw_trajectory(&root, d, counts),
            Page::Errors => draw_errors(&root, d, counts),
            Page::Attitude => draw_attitude(&root, d, counts),
            Page::Nis => draw_nis(&root, d, counts),
            Page::Latency => draw_latency(&root, d, counts),
        }
    }
}

/// Writes the report of `input` (a recording, or a replay output with
/// `samples` its input) into `dir`; returns the files written.
pub fn run(input: &Path, samples: Option<&Path>, truth: Option<&Path>, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow::anyhow!("the embedded font does not load"))?;
    let mut head = [0u8; 8];
    let n = std::fs::File::open(input)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .with_context(|| format!("cannot read {}", input.display()))?;
    let mut data =
        if head[..n].starts_with(mcap::MAGIC) { from_recording(input)? } else { from_replay(input, samples)? };
    anyhow::ensure!(!data.estimates.is_empty(), "{} has no estimates to plot", input.display());
    if let Some(truth) = truth {
        data.truth = read_truth(truth)?;
    }
    // Times since the first estimate (CLOCK_MONOTONIC seconds say nothing).
    data.t0 = data.estimates.iter().map(|e| e.t).fold(f64::INFINITY, f64::min);
    let t0 = data.t0;
    data.estimates.iter_mut().for_each(|e| e.t -= t0);
    data.truth.iter_mut().for_each(|t| t.0 -= t0);
    data.nis.values_mut().flat_map(|(_, v)| v.iter_mut()).for_each(|v| v.t -= t0);
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
        page.draw(&SVGBackend::new(&path, SIZE).into_drawing_area(), &data, &mut counts)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        files.push(path);
        let path = dir.join(format!("{}.png", page.name()));
        page.draw(&BitMapBackend::new(&path, SIZE).into_drawing_area(), &data, &mut counts)
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
    });
    std::fs::write(&report, serde_json::to_string_pretty(&json)?)?;
    files.push(report);
    Ok(files)
}
