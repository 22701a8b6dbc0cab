//! The demo's live status line and the figures it reports per sensor.

use fusion_client::StateSnapshot;
use fusion_client::sim::Outage;

/// The health and why it is not ok, with the sensor an inconsistent NIS is
/// about (`degraded (nis out of bounds: odometry 0)`).
pub fn describe(snap: &StateSnapshot) -> String {
    let reasons = snap.health_reason_texts();
    let reasons = if reasons.is_empty() { String::new() } else { format!(" ({})", reasons.join(", ")) };
    format!("{}{reasons}", snap.health())
}

/// The rate of a sensor of `kind` that sent `received` samples over the
/// first `span_s` seconds of the drive, while it sent: a GNSS receiver's
/// outages are not counted (a 10 Hz receiver read "4 Hz" after a tunnel).
pub fn rate_hz(received: u64, span_s: f64, kind: fusion_shared::SampleKind, outages: &[Outage]) -> f64 {
    let dark_s: f64 = if Outage::darkens(kind) { outages.iter().map(|o| o.within_s(span_s)).sum() } else { 0.0 };
    received.saturating_sub(1) as f64 / (span_s - dark_s).max(1e-9)
}

/// The demo's live status: time, position, error, health, fixes and latency.
pub struct Status {
    /// Time into the drive, s.
    pub t: f64,
    /// The estimated position (east, north, up), m.
    pub pos: [f64; 3],
    /// The horizontal error against the truth, m.
    pub err: f64,
    /// The health and its reasons.
    pub health: String,
    /// Fixes fused.
    pub fused: u64,
    /// Fixes gated.
    pub gated: u64,
    /// Median latency, sample published to snapshot received, µs.
    pub p50_us: f64,
}

impl Status {
    /// The status line, fitting `width` columns if given (a terminal's): the
    /// full line where it fits, else a compact one (fixes as fused/gated), cut
    /// at the width at worst.
    pub fn line(&self, width: Option<usize>) -> String {
        let [e, n, u] = self.pos;
        let full = format!(
            "  t {:5.1} s  pos ({e:7.2},{n:7.2},{u:6.2}) m  err {:5.2} m  {:<28}  fixes {:3} fused {:2} gated  latency p50 {:5.0} us",
            self.t, self.err, self.health, self.fused, self.gated, self.p50_us
        );
        let Some(width) = width else { return full };
        // One column short of the width: a line that fills it makes some terminals wrap.
        let fits = |line: &str| line.chars().count() < width;
        if fits(&full) {
            return full;
        }
        // Without the position (the error says how good it is), the health
        // last, shortened by whole words ("degraded (velocity stale, …)").
        let head = format!(
            "t {:.1} s err {:.2} m fixes {}/{} p50 {:.0} us ",
            self.t, self.err, self.fused, self.gated, self.p50_us
        );
        let room = width.saturating_sub(1).saturating_sub(head.chars().count());
        let compact = format!("{head}{}", shorten(&self.health, room));
        compact.chars().take(width.saturating_sub(1)).collect()
    }
}

/// `text` in at most `room` characters, cut after a whole word with "…" (and
/// a bracket it opened closed); the first word alone, cut, if even that is
/// too long.
pub fn shorten(text: &str, room: usize) -> String {
    if text.chars().count() <= room {
        return text.to_string();
    }
    let close = |t: &str| if t.matches('(').count() > t.matches(')').count() { ")" } else { "" };
    // Every cut after a word, longest first, with what it needs after it.
    let cuts = text.char_indices().filter(|&(_, c)| c == ' ').map(|(i, _)| i).rev();
    for at in cuts {
        let kept = text[..at].trim_end_matches([',', ' ']);
        let shortened = format!("{kept} …{}", close(kept));
        if shortened.chars().count() <= room && !kept.is_empty() {
            return shortened;
        }
    }
    text.chars().take(room).collect()
}

/// Prints a report line wrapped at the terminal's width (when stdout is one)
/// between words, each further line indented under the first's text.
pub fn say(text: &str) {
    use std::io::IsTerminal;
    let width = std::io::stdout()
        .is_terminal()
        .then(|| ratatui::crossterm::terminal::size().ok())
        .flatten()
        .map(|(w, _)| usize::from(w));
    for line in text.split('\n') {
        println!("{}", wrap(line, width));
    }
}

/// `line` broken between words into lines shorter than `width` columns, the
/// later ones indented 4 more than the first; as it is without a width.
pub fn wrap(line: &str, width: Option<usize>) -> String {
    let Some(width) = width.filter(|&w| w > 20) else { return line.to_string() };
    let indent = line.chars().take_while(|c| *c == ' ').count();
    let mut out = String::new();
    let mut current = " ".repeat(indent);
    for word in line.split(' ').filter(|w| !w.is_empty()) {
        let fresh = current.trim().is_empty();
        if !fresh && current.chars().count() + 1 + word.chars().count() >= width {
            out.push_str(&current);
            out.push('\n');
            current = " ".repeat(indent + 4);
        }
        if !current.trim().is_empty() {
            current.push(' ');
        }
        current.push_str(word);
    }
    out.push_str(&current);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 Hz receiver through a 20 s outage of a 40 s drive reads 10 Hz;
    /// an IMU is not darkened.
    #[test]
    fn a_receivers_rate_leaves_its_outages_out() {
        use fusion_shared::SampleKind::{Geodetic, Imu};
        let tunnel = [Outage { at_s: 10.0, duration_s: 20.0 }];
        assert!((rate_hz(201, 40.0, Geodetic, &tunnel) - 10.0).abs() < 1e-9);
        assert!((rate_hz(4001, 40.0, Imu, &tunnel) - 100.0).abs() < 1e-9);
        // An outage past the span counts only in part.
        assert!((rate_hz(101, 25.0, Geodetic, &tunnel) - 10.0).abs() < 1e-9);
    }

    /// The compact line cuts the health after a whole reason, never within a
    /// word, and closes its bracket; the report's long lines wrap between
    /// words, every line shorter than the terminal.
    #[test]
    fn the_health_is_cut_after_whole_words_and_long_lines_wrap_between_words() {
        let status = Status {
            t: 12.5,
            pos: [75.39, 17.25, -1.01],
            err: 0.03,
            health: "degraded (velocity stale, geodetic stale, odometry stale)".into(),
            fused: 192,
            gated: 3,
            p50_us: 28.0,
        };
        let line = status.line(Some(70));
        assert!(line.ends_with("degraded (velocity stale …)"), "{line}");
        assert!(line.chars().count() < 70);
        let line = status.line(Some(60));
        assert!(line.ends_with("degraded …"), "{line}");
        assert_eq!(shorten("degraded (a b)", 30), "degraded (a b)");

        let long =
            format!("  {}", "the receiver's fix type: rtk fixed, rtk float, dgps, single (noise changes) ".repeat(3));
        let wrapped = wrap(long.trim_end(), Some(80));
        assert!(wrapped.lines().count() >= 3, "{wrapped}");
        for l in wrapped.lines() {
            assert!(l.chars().count() < 80, "{l:?}");
        }
        // Every word kept, whole, in order.
        let words = |t: &str| t.split_whitespace().map(String::from).collect::<Vec<_>>();
        assert_eq!(words(&wrapped), words(&long));
        assert_eq!(wrap("  short line", Some(80)), "  short line");
    }

    /// In an 80-column terminal the status line fits (it was ~135 columns and
    /// wrapped at every update), and still says health, error and latency.
    #[test]
    fn the_status_line_fits_the_terminal() {
        let status = Status {
            t: 20.0,
            pos: [75.39, 17.25, -1.01],
            err: 0.03,
            health: "degraded (samples lost), standing".into(),
            fused: 192,
            gated: 8,
            p50_us: 35.0,
        };
        let wide = status.line(None);
        assert!(wide.chars().count() > 120, "{wide}");
        assert_eq!(status.line(Some(200)), wide);
        let narrow = status.line(Some(80));
        assert!(narrow.chars().count() < 80, "{narrow}");
        for needle in ["t 20.0 s", "err 0.03 m", "samples lost", "192/8", "p50 35 us"] {
            assert!(narrow.contains(needle), "{needle:?} not in {narrow:?}");
        }
        assert!(status.line(Some(20)).chars().count() < 20);
    }
}
