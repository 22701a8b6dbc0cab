//! `fusionctl top`: a live dashboard of a running fusiond (`ratatui`): health
//! and its reasons, each sensor's rate and counters, the estimate with its
//! standard deviations (in as many columns as fit: the whole `ins` estimate at
//! 80×24), and the end-to-end latency percentiles, redrawn every [`REFRESH`];
//! `q` (or Esc, Ctrl-C) quits. Narrower than 120 columns the sensor table uses
//! short column names and adds duplicates, rate-limited samples and restarts up
//! as "other".

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use fusion_client::{Client, StateSnapshot, now_ns};
use fusion_shared::snapshot::{INPUT_NONE, health, model, rejection};
use ratatui::Frame;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Cell, Paragraph, Row, Table, Wrap};

/// How often the view is redrawn.
pub const REFRESH: Duration = Duration::from_millis(200);
/// Latencies kept for the percentiles: the most recent ones.
const LATENCY_WINDOW: usize = 5000;
/// Time over which sensor rates are measured.
const RATE_WINDOW: Duration = Duration::from_secs(2);

/// What the dashboard shows, gathered from the snapshots read.
#[derive(Default)]
pub struct View {
    /// Namespace shown in the title.
    pub namespace: String,
    /// The newest snapshot, if any.
    pub latest: Option<StateSnapshot>,
    /// Snapshots read.
    pub snapshots: u64,
    /// Of them, provisional ones (a late sample's correction still to land).
    pub provisional: u64,
    /// Per sensor (kind code, id): samples received per second.
    pub rates: HashMap<(u32, u32), f64>,
    /// Whether a fusiond runs in the namespace, as last looked (`None`: not looked yet).
    pub daemon_running: Option<bool>,
    /// Recent end-to-end latencies (sample sent → snapshot published), ns.
    latencies: VecDeque<u64>,
    /// Per sensor: (time, received) at the start of the rate window.
    rate_base: HashMap<(u32, u32), (Instant, u64)>,
}

impl View {
    /// An empty view of `namespace`.
    pub fn new(namespace: &str) -> Self {
        Self { namespace: namespace.to_string(), ..Self::default() }
    }

    /// Takes in one snapshot, read at `now`.
    pub fn add(&mut self, s: &StateSnapshot, now: Instant) {
        self.snapshots += 1;
        self.provisional += u64::from(!s.settled());
        if s.input_kind != INPUT_NONE && s.input_replayed == 0 && s.input_sent_ns > 0 {
            if self.latencies.len() == LATENCY_WINDOW {
                self.latencies.pop_front();
            }
            self.latencies.push_back(s.publish_ns.saturating_sub(s.input_sent_ns));
        }
        for c in s.sensor_counters() {
            let key = (c.kind, c.sensor);
            let base = *self.rate_base.entry(key).or_insert((now, c.counts.received));
            let elapsed = now.duration_since(base.0);
            if elapsed >= RATE_WINDOW {
                self.rates
                    .insert(key, (c.counts.received - base.1.min(c.counts.received)) as f64 / elapsed.as_secs_f64());
                self.rate_base.insert(key, (now, c.counts.received));
            }
        }
        self.latest = Some(*s);
    }

    /// Latency percentiles (p50, p90, p99, max) of the window, µs.
    pub fn latency_us(&self) -> Option<[f64; 4]> {
        if self.latencies.is_empty() {
            return None;
        }
        let mut v: Vec<u64> = self.latencies.iter().copied().collect();
        v.sort_unstable();
        let q = |p: f64| v[((v.len() - 1) as f64 * p) as usize] as f64 * 1e-3;
        Some([q(0.5), q(0.9), q(0.99), q(1.0)])
    }
}

/// Width of one column of the estimate panel: name, value, 1-sigma.
const ESTIMATE_COLUMN: u16 = 40;
/// From this width on the sensor table has a column per counter: its
/// columns' widths and the spaces between them (15 + 13 × 9 + 13).
const WIDE: u16 = 145;

/// The estimate's rows: each state (name, value, 1-sigma), and for the `ins`
/// model roll, pitch and yaw in degrees.
fn estimate_rows(s: &StateSnapshot) -> Vec<[String; 3]> {
    let sd: Vec<f64> = s.std_devs().collect();
    let mut rows: Vec<[String; 3]> = crate::state_layout(s)
        .into_iter()
        .zip(s.state())
        .map(|((name, k), v)| {
            let sigma = k.and_then(|k| sd.get(k));
            // Gyroscope biases in deg/h, the unit of their data sheets (and of the plots).
            if let Some(short) = name.strip_suffix("rad/s") {
                let scale = 3600.0_f64.to_degrees();
                let sigma = sigma.map_or(String::new(), |v| format!("{:.2}", v * scale));
                return [format!("{short}deg/h"), format!("{:.2}", v * scale), sigma];
            }
            [name, format!("{v:.4}"), sigma.map_or(String::new(), |v| format!("{v:.4}"))]
        })
        .collect();
    if let (Some(rpy), Some(rpy_sd)) = (s.roll_pitch_yaw(), s.roll_pitch_yaw_std()) {
        for ((name, v), sd) in ["roll deg", "pitch deg", "yaw deg"].iter().zip(rpy).zip(rpy_sd) {
            rows.push([name.to_string(), format!("{:.3}", v.to_degrees()), format!("{:.3}", sd.to_degrees())]);
        }
    }
    rows
}

/// The header's lines for snapshot `s`: the health and its reasons, the
/// model, snapshot, time and counts; whether the estimate is settled; the
/// refusals with their settings.
fn header_lines(view: &View, s: &StateSnapshot) -> Vec<Line<'static>> {
    let refused = s.rejected();
    let colour = match s.health {
        health::OK => Color::Green,
        health::DEGRADED => Color::Red,
        _ => Color::Yellow,
    };
    let reasons = crate::health_reasons(s);
    let age_ms = now_ns().saturating_sub(s.publish_ns) as f64 * 1e-6;
    let line = Line::from(vec![
        Span::raw("health "),
        Span::styled(health::name(s.health), Style::default().fg(colour).add_modifier(Modifier::BOLD)),
        Span::raw(if reasons.is_empty() { String::new() } else { format!(" ({})", reasons.join(", ")) }),
        Span::raw(format!(
            "  model {}  snapshot {} ({age_ms:.0} ms ago)  t {:.3} s  rewinds {}  re-initialisations {}",
            model::name(s.model),
            s.seq,
            s.t_ns as f64 * 1e-9,
            s.rewinds,
            s.reinitialisations
        )),
    ]);
    let standing = if s.standing() { "; standing still (attitude held)" } else { "" };
    let settled = Line::from(if s.settled() {
        format!(
            "estimate settled (every sample received is in); {} of {} read were provisional{standing}",
            view.provisional, view.snapshots
        )
    } else {
        format!(
            "estimate provisional: lacks the late sample at t {:.3} s, {} later samples to re-process{standing}",
            s.pending_since_t_ns as f64 * 1e-9,
            s.pending_steps
        )
    });
    let mut lines = vec![line, settled];
    if refused > 0 {
        let reasons: Vec<String> = s
            .rejection_counts()
            .map(|(code, n)| match rejection::setting(code) {
                Some(setting) => format!("{} {n}: {setting}", rejection::name(code)),
                None => format!("{} {n}", rejection::name(code)),
            })
            .collect();
        lines.push(Line::styled(
            format!("refused in validation: {refused} ({})", reasons.join("; ")),
            Style::default().fg(Color::Red),
        ));
    }
    lines
}

/// A NIS in at most 4 characters up to 9999: three significant digits.
fn nis_text(nis: f64) -> String {
    match nis.abs() {
        v if v >= 100.0 => format!("{nis:.0}"),
        v if v >= 10.0 => format!("{nis:.1}"),
        _ => format!("{nis:.2}"),
    }
}

/// A line's text.
fn line_text(line: &Line<'_>) -> String {
    line.spans.iter().map(|s| s.content.as_ref()).collect()
}

/// The rows `text` takes wrapped between words in `width` columns (a word
/// longer than a row is cut).
fn wrapped_rows(text: &str, width: u16) -> u16 {
    let width = usize::from(width.max(1));
    let (mut rows, mut used) = (1u16, 0usize);
    for word in text.split_whitespace() {
        let n = word.chars().count();
        let need = if used == 0 { n } else { used + 1 + n };
        if need <= width {
            used = need;
        } else {
            rows += 1 + (n.saturating_sub(1) / width) as u16;
            used = n % width;
        }
    }
    rows
}

/// Draws the dashboard of `view` into `frame`: at 80×24 the whole `ins`
/// estimate (in columns) and up to six sensors show.
pub fn draw(frame: &mut Frame, view: &View) {
    let area = frame.area();
    let columns = (area.width / ESTIMATE_COLUMN).max(1) as usize;
    let estimate_height = view.latest.as_ref().map_or(0, |s| estimate_rows(s).len().div_ceil(columns));
    let title = match (&view.latest, view.daemon_running) {
        (Some(_), Some(false)) => format!(" fusiond · namespace {} · STOPPED: its last snapshot ", view.namespace),
        _ => format!(" fusiond · namespace {} ", view.namespace),
    };
    let lines = status_lines(view);
    // The header's lines wrap between words: as tall as they need.
    let header_height = 1 + lines.iter().map(|l| wrapped_rows(&line_text(l), area.width)).sum::<u16>();
    let [header, sensors, lower, footer] = Layout::vertical([
        Constraint::Length(header_height),
        Constraint::Min(4),
        Constraint::Length(estimate_height as u16 + 2),
        Constraint::Length(1),
    ])
    .areas(area);
    let paragraph = Paragraph::new(lines).wrap(Wrap { trim: true });
    frame.render_widget(paragraph.block(Block::new().borders(Borders::TOP).title(title)), header);
    let Some(s) = &view.latest else {
        frame.render_widget(Paragraph::new(" q: quit"), footer);
        return;
    };
    frame.render_widget(sensor_table(view, s, sensors.height, area.width >= WIDE), sensors);
    draw_estimate(frame, s, lower, columns);
    let latency = match view.latency_us() {
        Some([p50, p90, p99, max]) => format!(
            "latency sent → published: p50 {p50:.1} p90 {p90:.1} p99 {p99:.1} max {max:.1} µs (last {})",
            view.latencies.len()
        ),
        None => "latency: no sample with a send time yet".into(),
    };
    frame.render_widget(Paragraph::new(format!(" q: quit · {} snapshots · {latency}", view.snapshots)), footer);
}

/// The header's lines: the latest snapshot's, or what the dashboard waits for.
fn status_lines(view: &View) -> Vec<Line<'static>> {
    match &view.latest {
        Some(s) => header_lines(view, s),
        None if view.daemon_running == Some(false) => vec![Line::from(format!(
            "no fusiond runs in namespace {:?}: waiting for one (is the namespace right? `fusionctl state \
             --namespace NS` asks one)",
            view.namespace
        ))],
        None => vec![Line::from(format!(
            "fusiond runs in namespace {:?}: waiting for its first snapshot (no sample has reached it yet) …",
            view.namespace
        ))],
    }
}

/// One row per sensor of `s`, in `height` rows (the rest said, not dropped);
/// `wide`: every counter in its own column.
fn sensor_table(view: &View, s: &StateSnapshot, height: u16, wide: bool) -> Table<'static> {
    let head: &[&str] = if wide {
        &[
            "sensor", "rate Hz", "received", "fused", "gated", "refused", "late", "too late", "dup", "invalid", "lost",
            "limited", "restarts", "last NIS",
        ]
    } else {
        // Narrow: duplicates, rate-limited and restarts added up as "other".
        &["sensor", "Hz", "recv", "fused", "gated", "refus", "late", "2late", "inval", "lost", "other", "NIS"]
    };
    let stale_rows: Vec<(u32, u32)> = s.stale_sensor_counters().map(|c| (c.kind, c.sensor)).collect();
    let mut rows: Vec<Row> = s
        .sensor_counters()
        .iter()
        .map(|c| sensor_row(view, c, stale_rows.contains(&(c.kind, c.sensor)), wide))
        .collect();
    // Rows below the area's bottom are said, not dropped in silence.
    let room = usize::from(height.saturating_sub(2));
    let count = rows.len();
    let mut title = " sensors ".to_string();
    if count > room {
        rows.truncate(room.saturating_sub(1));
        let hidden = count - rows.len();
        rows.push(Row::new([Cell::from(format!("… {hidden} more"))]));
        title = format!(" sensors ({} of {count} shown: a taller terminal shows the rest) ", rows.len() - 1);
    }
    let widths: Vec<Constraint> = if wide {
        std::iter::once(15).chain([9; 13]).map(Constraint::Length).collect()
    } else {
        // 80 columns: "magnetometer 12", the counts up to 6 digits, the NIS
        // in what is left (at least 4: `nis_text`).
        let fixed = [15, 5, 6, 6, 5, 5, 4, 5, 5, 4, 5].map(Constraint::Length);
        fixed.into_iter().chain([Constraint::Fill(1)]).collect()
    };
    Table::new(rows, widths)
        .header(Row::new(head.to_vec()).style(Style::default().add_modifier(Modifier::BOLD)))
        .block(Block::new().borders(Borders::TOP).title(title))
}

/// One sensor's row (red while its stream is stale).
fn sensor_row(view: &View, c: &fusion_shared::snapshot::SensorCounters, stale: bool, wide: bool) -> Row<'static> {
    let n = &c.counts;
    let rate = view.rates.get(&(c.kind, c.sensor)).map_or("-".into(), |r| format!("{r:.1}"));
    let nis = if c.last_nis.is_finite() { nis_text(c.last_nis) } else { "-".into() };
    let style = if stale { Style::default().fg(Color::Red) } else { Style::default() };
    let name = format!("{} {}", crate::kind_name(c.kind), c.sensor);
    let [received, fused, gated, refused, late, too_late, invalid, lost] =
        [n.received, n.fused, n.gated, n.refused, n.late, n.too_late, n.invalid, n.lost].map(|v| v.to_string());
    let cells = if wide {
        let [dup, limited, restarts] = [n.duplicate, n.rate_limited, n.restarts].map(|v| v.to_string());
        vec![name, rate, received, fused, gated, refused, late, too_late, dup, invalid, lost, limited, restarts, nis]
    } else {
        let other = (n.duplicate + n.rate_limited + n.restarts).to_string();
        vec![name, rate, received, fused, gated, refused, late, too_late, invalid, lost, other, nis]
    };
    Row::new(cells.into_iter().map(Cell::from)).style(style)
}

/// The estimate in as many columns as fit, filled top to bottom.
fn draw_estimate(frame: &mut Frame, s: &StateSnapshot, area: Rect, columns: usize) {
    let rows = estimate_rows(s);
    let per_column = rows.len().div_ceil(columns).max(1);
    let parts = Layout::horizontal(vec![Constraint::Length(ESTIMATE_COLUMN); columns]).split(area);
    for (i, chunk) in rows.chunks(per_column).enumerate() {
        let table =
            Table::new(chunk.iter().map(|r| Row::new(r.clone().map(Cell::from))), [18, 11, 9].map(Constraint::Length))
                .header(Row::new(["state", "value", "1-sigma"]).style(Style::default().add_modifier(Modifier::BOLD)));
        let block = Block::new().borders(Borders::TOP);
        let block = if i == 0 { block.title(" estimate ") } else { block };
        frame.render_widget(table.block(block), parts[i]);
    }
}

/// Runs the dashboard on the terminal until `q` or `stop`; without a terminal
/// on standard input and output (ssh without `-t`, a unit, cron), an error that
/// says what to use instead.
pub fn run(namespace: &str, stop: &AtomicBool) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    for (name, is) in
        [("standard output", std::io::stdout().is_terminal()), ("standard input", std::io::stdin().is_terminal())]
    {
        if !is {
            anyhow::bail!(
                "the dashboard needs a terminal and {name} is not one (ssh -t gives one); \
                 `fusionctl state` prints the latest snapshot, `fusionctl echo` every one"
            );
        }
    }
    let client = Client::connect(namespace)?;
    let mut view = View::new(namespace);
    let mut state = None;
    let mut terminal = ratatui::init();
    let result = (|| -> anyhow::Result<()> {
        loop {
            if state.is_none() {
                // fusiond may start after the dashboard.
                match client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER) {
                    Ok(s) => {
                        view.daemon_running = Some(s.fusiond_publishes());
                        state = Some(s);
                    }
                    Err(fusion_client::ClientError::DaemonNotRunning { .. }) => view.daemon_running = Some(false),
                    Err(e) => return Err(e.into()),
                }
            }
            if let Some(reader) = &mut state {
                while let Some(s) = reader.try_next()? {
                    view.add(s, Instant::now());
                }
                // fusiond stopped (readers keep its service): say so, and look
                // for a new one from the next turn on.
                if !reader.fusiond_publishes() {
                    (state, view.daemon_running) = (None, Some(false));
                }
            }
            terminal.draw(|frame| draw(frame, &view))?;
            let deadline = Instant::now() + REFRESH;
            while let Some(left) = deadline.checked_duration_since(Instant::now()) {
                if stop.load(Ordering::Relaxed) {
                    return Ok(());
                }
                if event::poll(left.min(Duration::from_millis(50)))?
                    && let Event::Key(key) = event::read()?
                    && key.kind == KeyEventKind::Press
                    && (matches!(key.code, KeyCode::Char('q') | KeyCode::Esc)
                        || (key.code == KeyCode::Char('c') && key.modifiers.contains(KeyModifiers::CONTROL)))
                {
                    return Ok(());
                }
            }
        }
    })();
    ratatui::restore();
    result
}

#[cfg(test)]
mod tests;
