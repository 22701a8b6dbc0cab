//! The low-rate summary: the fusion thread hands plain numbers over a bounded
//! crossbeam channel to a thread that formats and logs them, so the fusion
//! thread never formats a string or blocks on a log sink.

use std::thread::JoinHandle;

use crossbeam::channel::{Receiver, Sender, TrySendError, bounded};
use fusion_shared::snapshot::{health, rejection};
use fusion_shared::{Counters, SampleKind};

/// Number of sample kinds.
const KINDS: usize = SampleKind::COUNT;

/// Counts by rejection code ([`rejection`]; entry 0 unused).
pub type Rejections = [u64; rejection::MAX];

/// One summary interval.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Summary {
    /// Length of the interval, s.
    pub interval_s: f64,
    /// Counts in the interval per kind (index [`SampleKind::index`]).
    pub kinds: [Counters; KINDS],
    /// Snapshots published in the interval.
    pub snapshots: u64,
    /// Publish latency (sample sent → snapshot published), ns: p50, p99, max; `None` without samples.
    pub latency_ns: Option<(u64, u64, u64)>,
    /// Health state and reasons at the end of the interval.
    pub health: (u32, u32),
    /// Standing still at the end of the interval, and the standstill updates
    /// so far (`None` before any sample).
    pub standing: Option<(bool, u64)>,
    /// Samples refused in validation in the interval, by rejection code: every
    /// sensor's, those without a row (never counted in `kinds`) included.
    pub rejections: Rejections,
}

/// The summary thread and the sending half of its channel.
pub struct SummaryLogger {
    sender: Option<Sender<Summary>>,
    thread: Option<JoinHandle<()>>,
}

impl SummaryLogger {
    /// Starts the logging thread.
    pub fn start() -> std::io::Result<Self> {
        let (sender, receiver) = bounded::<Summary>(4);
        let thread = std::thread::Builder::new().name("fusiond-summary".into()).spawn(move || log_loop(receiver))?;
        Ok(Self { sender: Some(sender), thread: Some(thread) })
    }

    /// Hands a summary over without blocking; a summary that finds the channel
    /// full (the logger is stuck) is dropped rather than stall the fusion loop.
    pub fn send(&self, summary: Summary) {
        if let Some(s) = &self.sender
            && let Err(TrySendError::Full(_)) = s.try_send(summary)
        {
            tracing::debug!("summary channel full; summary dropped");
        }
    }
}

impl Drop for SummaryLogger {
    fn drop(&mut self) {
        self.sender.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The text of one summary line.
pub fn format(s: &Summary) -> String {
    let rate = |n: u64| n as f64 / s.interval_s.max(1e-9);
    let mut total = Counters::default();
    let mut rates = Vec::with_capacity(KINDS);
    for (k, c) in SampleKind::ALL.iter().zip(&s.kinds) {
        total.add(c);
        let r = rate(c.received);
        if *k == SampleKind::Imu || c.received > 0 {
            rates.push(if r >= 100.0 { format!("{} {r:.0}/s", k.name()) } else { format!("{} {r:.1}/s", k.name()) });
        }
    }
    let reasons: Vec<&str> = health::reason_names(s.health.1).collect();
    // Every refusal in validation, by reason (the per-kind `invalid` counts
    // miss the sensors without a row).
    let refused: u64 = s.rejections.iter().sum();
    let reasons_refused: Vec<String> = rejection::ALL
        .iter()
        .filter(|(code, _)| s.rejections[*code as usize] > 0)
        .map(|(code, name)| format!("{name} {}", s.rejections[*code as usize]))
        .collect();
    let invalid = if refused == 0 { "0".to_string() } else { format!("{refused} ({})", reasons_refused.join(", ")) };
    let latency = match s.latency_ns {
        Some((p50, p99, max)) => format!("{:.1}/{:.1}/{:.1} us", p50 as f64 / 1e3, p99 as f64 / 1e3, max as f64 / 1e3),
        None => "-".to_string(),
    };
    format!(
        "{}: fused {}, gated {}, refused {}, late {}, too late {}, duplicate {}, invalid {}, lost {}, rate-limited {}, \
         restarts {}; {} snapshots; publish latency p50/p99/max {}; health {}{}{}",
        rates.join(", "),
        total.fused,
        total.gated,
        total.refused,
        total.late,
        total.too_late,
        total.duplicate,
        invalid,
        total.lost,
        total.rate_limited,
        total.restarts,
        s.snapshots,
        latency,
        health::name(s.health.0),
        if reasons.is_empty() { String::new() } else { format!(" ({})", reasons.join(", ")) },
        match s.standing {
            Some((true, updates)) => format!("; standing still ({updates} standstill updates)"),
            _ => String::new(),
        },
    )
}

fn log_loop(receiver: Receiver<Summary>) {
    for s in receiver {
        tracing::info!(target: "fusiond::summary", "{}", format(&s));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Refusals of sensors without a row (all of them, when every sample is
    /// refused) show in the line by reason, though no kind counted them.
    #[test]
    fn refusals_show_by_reason_without_a_sensor_row() {
        let mut s = Summary { interval_s: 10.0, ..Default::default() };
        s.rejections[rejection::PAST_TIMESTAMP as usize] = 1072;
        s.rejections[rejection::NON_FINITE as usize] = 3;
        let line = format(&s);
        assert!(line.contains("invalid 1075 (non-finite value 3, timestamp too far in the past 1072)"), "{line}");
        assert!(format(&Summary { interval_s: 1.0, ..Default::default() }).contains("invalid 0,"));
    }

    /// Measurements the model refused (a disturbed magnetometer sample, a fix
    /// type the quality refuses) are added up over the kinds, beside the gated.
    #[test]
    fn model_refusals_are_counted_over_the_kinds() {
        let mut s = Summary { interval_s: 1.0, ..Default::default() };
        s.kinds[SampleKind::Magnetometer.index()].refused = 40;
        s.kinds[SampleKind::Geodetic.index()].refused = 2;
        s.kinds[SampleKind::Geodetic.index()].gated = 3;
        let line = format(&s);
        assert!(line.contains("gated 3, refused 42, late 0"), "{line}");
    }
}
