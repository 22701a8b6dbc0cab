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
        // Without the position (the error says how good it is), the health last.
        let compact = format!(
            "t {:.1} s err {:.2} m fixes {}/{} p50 {:.0} us {}",
            self.t, self.err, self.fused, self.gated, self.p50_us, self.health
        );
        compact.chars().take(width.saturating_sub(1)).collect()
    }
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
