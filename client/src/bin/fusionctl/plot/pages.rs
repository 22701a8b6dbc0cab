//! The pages of `fusionctl plot`'s report (see the module docs of `plot`).

use plotters::coord::Shift;
use plotters::prelude::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};

use super::{Counts, Data, Fate, Fix, InsPart, MAX_POINTS, Nis, attitude_error_deg, truth_at};

/// The legend of a panel: upper right, on a white box.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(chart: &mut ChartContext<'a, DB, CT>) -> Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

/// An axis label as plotters writes it, but never `-0` (a tick at a
/// rounding error below zero).
pub(super) fn tick(v: &f64) -> String {
    use plotters::coord::ranged1d::ValueFormatter;
    let text = <plotters::coord::types::RangedCoordf64 as ValueFormatter<f64>>::format(v);
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => text,
    }
}

/// The corner of a plot (x and y ranges) with the fewest of `points` near
/// it, where a legend hides the least.
fn emptiest_corner(points: &[(f64, f64)], x: &std::ops::Range<f64>, y: &std::ops::Range<f64>) -> SeriesLabelPosition {
    let near = |right: bool, top: bool| {
        let (w, h) = (x.end - x.start, y.end - y.start);
        points
            .iter()
            .filter(|(px, py)| {
                let fx = (px - x.start) / w;
                let fy = (py - y.start) / h;
                (if right { fx > 0.6 } else { fx < 0.4 }) && (if top { fy > 0.6 } else { fy < 0.4 })
            })
            .count()
    };
    [
        (near(true, true), SeriesLabelPosition::UpperRight),
        (near(false, true), SeriesLabelPosition::UpperLeft),
        (near(true, false), SeriesLabelPosition::LowerRight),
        (near(false, false), SeriesLabelPosition::LowerLeft),
    ]
    .into_iter()
    .min_by_key(|(n, _)| *n)
    .map_or(SeriesLabelPosition::UpperRight, |(_, p)| p)
}

/// A band's outer edge: for each of `columns` equal stretches of `t`, its
/// middle time, the highest `centre + 3σ` and the lowest `centre − 3σ` in it
/// (stretches without a point left out).
pub(super) fn envelope(band: &[(f64, f64, f64)], t: std::ops::Range<f64>, columns: usize) -> Vec<(f64, f64, f64)> {
    let width = (t.end - t.start).max(1e-12) / columns as f64;
    let mut out: Vec<(usize, f64, f64)> = Vec::new();
    for &(time, centre, sigma3) in band {
        let column = (((time - t.start) / width).floor().max(0.0) as usize).min(columns - 1);
        let (hi, lo) = (centre + sigma3, centre - sigma3);
        match out.last_mut() {
            Some(last) if last.0 == column => (last.1, last.2) = (last.1.max(hi), last.2.min(lo)),
            _ => out.push((column, hi, lo)),
        }
    }
    out.into_iter().map(|(c, hi, lo)| (t.start + (c as f64 + 0.5) * width, hi, lo)).collect()
}

/// How much longer than the data the NIS panels' time axis is, for the legend
/// (about a third of a panel's width at 1200 px).
const LEGEND_ROOM: f64 = 0.45;

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

pub(super) type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

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

pub(super) fn draw_trajectory<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &Data,
    counts: &mut Counts,
) -> Result<()>
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
    let path: Vec<(f64, f64)> = est.iter().map(|e| (e.pv[0], e.pv[1])).collect();
    let corner = emptiest_corner(&path, &xs, &ys);
    let mut chart = builder(xs, ys)?;
    chart
        .configure_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("east, m")
        .y_desc("north, m")
        .draw()?;
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
    let [fused, gated, not_fused] = draw_fixes(&mut chart, d, ins)?;
    draw_ends(&mut chart, &path)?;
    chart.configure_series_labels().position(corner).background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    counts.insert("trajectory.estimate", est.len());
    counts.insert("trajectory.truth", truth.len());
    counts.insert("trajectory.fixes", fused);
    counts.insert("trajectory.gated", gated);
    counts.insert("trajectory.not_fused", not_fused);
    Ok(())
}

/// The trajectory's chart: east and north, m.
type Plane<'a, DB> =
    ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>>;

/// The fixes on the trajectory, by what became of them (fused, gated, not
/// fused), each in the legend only if drawn; their counts.
fn draw_fixes<'a, DB: DrawingBackend + 'a>(chart: &mut Plane<'a, DB>, d: &Data, ins: bool) -> Result<[usize; 3]>
where
    DB::ErrorType: 'static,
{
    let of = |fate| d.fixes.iter().filter(move |f: &&Fix| f.fate == fate).collect::<Vec<_>>();
    let (fused, gated, not_fused) = (of(Fate::Fused), of(Fate::Gated), of(Fate::NotFused));
    // The ins model fuses fixes at their antenna through the lever arm: drawn
    // as measured, they lie a lever arm beside the IMU's track.
    let (fix, gated_fix) =
        if ins { ("fix (antenna, as measured)", "gated fix (antenna)") } else { ("fix", "gated fix") };
    // In the legend only what is drawn.
    if !fused.is_empty() {
        chart
            .draw_series(fused.iter().map(|f| Circle::new((f.east, f.north), 3, GREEN.filled())))?
            .label(fix)
            .legend(|(x, y)| Circle::new((x + 10, y), 3, GREEN.filled()));
    }
    if !gated.is_empty() {
        chart
            .draw_series(gated.iter().map(|f| Cross::new((f.east, f.north), 6, RED.stroke_width(2))))?
            .label(gated_fix)
            .legend(|(x, y)| Cross::new((x + 10, y), 6, RED));
    }
    if !not_fused.is_empty() {
        let ring = MAGENTA.mix(0.8).stroke_width(1);
        chart
            .draw_series(not_fused.iter().map(|f| Circle::new((f.east, f.north), 3, ring)))?
            .label("fix, not fused (a reference)")
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, ring));
    }
    Ok([fused.len(), gated.len(), not_fused.len()])
}

/// Where the drive began and where it ended.
fn draw_ends<'a, DB: DrawingBackend + 'a>(chart: &mut Plane<'a, DB>, path: &[(f64, f64)]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    if let (Some(&first), Some(&last)) = (path.first(), path.last()) {
        chart
            .draw_series([TriangleMarker::new(first, 9, GREEN.mix(0.9).filled())])?
            .label("start")
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 7, GREEN.filled()));
        chart
            // A square of 10 pixels about the end (one of no size in data
            // units would draw nothing).
            .draw_series([EmptyElement::at(last) + Rectangle::new([(-5, -5), (5, 5)], BLACK.filled())])?
            .label("end")
            .legend(|(x, y)| Rectangle::new([(x + 6, y - 4), (x + 14, y + 4)], BLACK.filled()));
    }
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
    chart
        .configure_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("t since start, s")
        .y_desc(unit)
        .draw()?;
    // The band as an area: a σ that falls at every fix and grows between them
    // drawn as two lines at a point a sample is a comb of bars; its outer edge
    // per pixel of time, filled, reads as the band it is.
    let columns = usize::try_from(chart.plotting_area().dim_in_pixel().0).unwrap_or(1000).max(1);
    let edge = envelope(band, chart.x_range(), columns);
    let outline: Vec<(f64, f64)> =
        edge.iter().map(|e| (e.0, e.1)).chain(edge.iter().rev().map(|e| (e.0, e.2))).collect();
    chart.draw_series([Polygon::new(outline, RED.mix(0.15).filled())])?;
    chart
        .draw_series(LineSeries::new(edge.iter().map(|e| (e.0, e.1)), RED.stroke_width(1)))?
        .label("±3σ")
        .legend(|(x, y)| Rectangle::new([(x, y - 4), (x + 20, y + 4)], RED.mix(0.3).filled()));
    chart.draw_series(LineSeries::new(edge.iter().map(|e| (e.0, e.2)), RED.stroke_width(1)))?;
    if !series.is_empty() {
        chart
            .draw_series(LineSeries::new(series.iter().copied(), BLUE.stroke_width(1)))?
            .label(series_label)
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
    }
    legend(&mut chart)
}

pub(super) fn draw_errors<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &Data,
    counts: &mut Counts,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
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
    Ok(())
}

/// The `ins` page: the attitude error about each body axis (with truth) or its
/// ±3σ band, and each bias estimate inside its ±3σ band.
pub(super) fn draw_attitude<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &Data,
    counts: &mut Counts,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
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
    Ok(())
}

pub(super) fn draw_nis<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &Data, counts: &mut Counts) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let n = d.nis.len().max(1);
    let t = range(d.estimates.iter().map(|e| e.t));
    // Room on the right for the legend (upper right): it covers no value.
    let t = t.start..t.end + LEGEND_ROOM * (t.end - t.start);
    counts.scale("nis.t_end", t.end);
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
        chart
            .configure_mesh()
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .x_desc("t since start, s")
            .y_desc("NIS (no unit)")
            .draw()?;
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
        legend(&mut chart)?;
        counts.insert(&format!("nis.{sensor}"), values.len());
        counts.insert(&format!("nis.{sensor}.gated"), gated.len());
        counts.insert(&format!("nis.{sensor}.beyond"), beyond.len());
        counts.scale(&format!("nis.{sensor}.top"), top);
    }
    Ok(())
}

pub(super) fn draw_latency<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &Data,
    counts: &mut Counts,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
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
    chart.configure_mesh().x_label_formatter(&tick).x_desc("µs").y_desc("samples").draw()?;
    chart.draw_series(
        hist.iter().enumerate().map(|(i, &n)| {
            Rectangle::new([(i as f64 * width, 0), ((i + 1) as f64 * width, n)], BLUE.mix(0.6).filled())
        }),
    )?;
    counts.insert("latency.samples", sorted.len());
    Ok(())
}
