//! Late data, measured live: a fix 100 ms late every 100th IMU tick, what it
//! costs the daemon and the IMU samples behind it.

use std::time::{Duration, Instant};

use fusion_client::{Client, SampleKind, now_ns};
use hdrhistogram::Histogram;

use super::*;

/// Late-data cost, measured live at 1 kHz.
#[derive(Debug)]
pub struct LateCost {
    /// Daemon time (snapshot published − sample received) of in-order IMU samples, ns.
    pub imu_processing: Histogram<u64>,
    /// Daemon time of the late fixes (rewind, replay, snapshot), ns.
    pub late_processing: Histogram<u64>,
    /// IMU samples replayed per late fix.
    pub replayed: Histogram<u64>,
    /// From a late fix's arrival to the publication of the first settled
    /// snapshot that includes it (its own, when the rewind runs inline), ns.
    pub landed: Histogram<u64>,
    /// End-to-end latency of the IMU sample sent right behind each late fix, ns.
    pub next_after_late: Histogram<u64>,
    /// Of those IMU samples' snapshots, the provisional ones.
    pub next_provisional: u64,
    /// The legs of those IMU samples' end-to-end times: trip in, daemon, trip
    /// out (as [`EndToEnd`]), ns.
    pub next_legs: [Histogram<u64>; 3],
    /// End-to-end latency of the other IMU samples, ns.
    pub normal: Histogram<u64>,
    /// Late fixes whose IMU sample's snapshot came first: the daemon took the
    /// IMU sample first (it had both, or looked at the fixes' subscriber just
    /// before the fix was published). Counted in `next_after_late` too.
    pub overtaken: u64,
}

/// Publishes IMU samples at `rate_hz`; every 100th tick a position fix whose time
/// of validity is `late_ns` old goes out just before the IMU sample, so the daemon
/// must rewind and replay about `late_ns × rate` IMU steps before it can process
/// that IMU sample.
pub fn late_data(
    client: &Client,
    mode: Mode,
    count: u64,
    rate_hz: f64,
    late_ns: u64,
    imu_value: ([f64; 3], [f64; 3]),
) -> anyhow::Result<LateCost> {
    let mut imu = client.imu_publisher(0)?;
    let mut pos = client.position_publisher(1)?;
    imu.set_wake(mode == Mode::Event);
    pos.set_wake(mode == Mode::Event);
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    let mut cost = LateCost {
        imu_processing: histogram(),
        late_processing: histogram(),
        replayed: histogram(),
        landed: histogram(),
        next_after_late: histogram(),
        next_provisional: 0,
        next_legs: [histogram(), histogram(), histogram()],
        normal: histogram(),
        overtaken: 0,
    };
    let mut pacer = Pacer::new(rate_hz);
    // The history must first reach back `late_ns`.
    let warmup = (late_ns as f64 * 1e-9 * rate_hz) as u64 + 100;
    let mut late_seq = 0;
    for seq in 0..(count + warmup) {
        // Stamped on the IMU's clock, the tick (see `Prober`).
        let t = pacer.wait();
        let with_late = seq >= warmup && seq % 100 == 0;
        if with_late {
            pos.publish(t - late_ns, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
        }
        imu.publish(t, imu_value.0, imu_value.1)?;
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut late_seen = !with_late;
        // When the late fix arrived, until the snapshot that settles it is seen.
        let mut landing: Option<u64> = None;
        let mut imu_seen = false;
        loop {
            let Some(s) = next_snapshot(&mut state, mode, deadline, seq)? else { continue };
            let received = now_ns();
            let processing = s.publish_ns.saturating_sub(s.input_received_ns);
            if s.input_kind == SampleKind::Position as u32 && with_late && s.input_seq == late_seq {
                late_seen = true;
                landing = Some(s.input_received_ns);
                cost.late_processing.record(processing)?;
                cost.replayed.record(u64::from(s.input_replayed).max(1))?;
            }
            if let Some(arrived) = landing
                && s.settled()
            {
                cost.landed.record(s.publish_ns.saturating_sub(arrived))?;
                landing = None;
            }
            if s.input_kind == SampleKind::Imu as u32 && s.input_seq == seq {
                imu_seen = true;
                if seq >= warmup {
                    let e2e = received.saturating_sub(s.input_sent_ns);
                    if with_late {
                        // The IMU sample's snapshot came before the fix's: the
                        // daemon took the IMU sample first.
                        cost.overtaken += u64::from(!late_seen);
                        cost.next_after_late.record(e2e)?;
                        cost.next_provisional += u64::from(!s.settled());
                        cost.next_legs[0].record(s.input_received_ns.saturating_sub(s.input_sent_ns))?;
                        cost.next_legs[1].record(processing)?;
                        cost.next_legs[2].record(received.saturating_sub(s.publish_ns))?;
                    } else {
                        cost.normal.record(e2e)?;
                        cost.imu_processing.record(processing)?;
                    }
                }
            }
            // Read on past the IMU sample's snapshot until the late fix's
            // correction has landed.
            if imu_seen && late_seen && landing.is_none() {
                break;
            }
        }
        if with_late {
            late_seq += 1;
        }
    }
    Ok(cost)
}
