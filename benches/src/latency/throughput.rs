//! Throughput: the highest IMU rate the daemon takes with nothing lost.

use std::time::{Duration, Instant};

use fusion_client::{Client, now_ns};

use super::*;
use crate::latency::pingpong::RawRelay;

/// One throughput trial's result.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Trial {
    /// IMU samples published.
    pub published: u64,
    /// IMU samples of this sensor the daemon received (from the last snapshot).
    pub received: u64,
    /// Samples the daemon counted as lost (sequence gaps: overwritten in its buffer).
    pub lost: u64,
    /// Snapshots the reader missed (gaps in the snapshot sequence numbers).
    pub reader_missed: u64,
}

impl Trial {
    /// Everything published reached the daemon and every snapshot the reader.
    pub fn clean(&self) -> bool {
        self.received == self.published && self.lost == 0 && self.reader_missed == 0
    }
}

/// Publishes `published` IMU samples as sensor `sensor` at `rate_hz`, in slices
/// of 100 µs sent back to back, and between slices reads every snapshot
/// (busy-poll), until the daemon has accounted for all samples (or 3 s after the
/// last was sent). Publisher and reader share this thread, so the run needs two
/// busy cores (daemon and bench), not three.
pub fn throughput(
    client: &Client,
    sensor: u32,
    rate_hz: f64,
    published: u64,
    imu_value: ([f64; 3], [f64; 3]),
) -> anyhow::Result<Trial> {
    let mut imu = client.imu_publisher(sensor)?;
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    // Let the daemon's subscriber connect to the new publisher.
    let connect = Instant::now() + Duration::from_millis(100);
    while Instant::now() < connect {
        while state.try_next()?.is_some() {}
    }
    let mut last_seq: Option<u64> = None;
    let mut trial = Trial { published, received: 0, lost: 0, reader_missed: 0 };
    let read = |trial: &mut Trial| -> anyhow::Result<()> {
        while let Some(s) = state.try_next()? {
            if let Some(prev) = last_seq {
                trial.reader_missed += s.seq.saturating_sub(prev + 1);
            }
            last_seq = Some(s.seq);
            let count = (s.sensor_count as usize).min(s.sensors.len());
            if let Some(c) = s.sensors[..count]
                .iter()
                .find(|c| c.kind == fusion_shared::SampleKind::Imu as u32 && c.sensor == sensor)
            {
                trial.received = c.counts.received;
                trial.lost = c.counts.lost;
            }
        }
        Ok(())
    };
    let publish = || -> anyhow::Result<()> {
        imu.publish(now_ns(), imu_value.0, imu_value.1)?;
        Ok(())
    };
    paced(&mut trial, rate_hz, publish, read)?;
    Ok(trial)
}

/// The same trial through raw iceoryx2 ([`RawRelay`]: a relay process that
/// answers each sample with a snapshot-sized message, with fusiond's
/// buffers): the floor of [`throughput`], measured in the same run.
/// `received` counts the answers, `reader_missed` the gaps in their
/// sequence numbers (the relay keeps no count of its own).
pub fn raw_throughput(relay: &mut RawRelay, rate_hz: f64, published: u64) -> anyhow::Result<Trial> {
    // Answers to a previous trial's pings are not this one's.
    let first = relay.next_seq();
    let mut trial = Trial { published, ..Trial::default() };
    let mut last_seq: Option<u64> = None;
    let relay = std::cell::RefCell::new(relay);
    let read = |trial: &mut Trial| -> anyhow::Result<()> {
        relay.borrow_mut().read(|seq| {
            if seq < first {
                return;
            }
            if let Some(prev) = last_seq {
                trial.reader_missed += seq.saturating_sub(prev + 1);
            }
            last_seq = Some(seq);
            trial.received += 1;
        })
    };
    paced(&mut trial, rate_hz, || relay.borrow_mut().send(), read)?;
    Ok(trial)
}

/// `trial.published` calls of `publish` at `rate_hz`, in slices of 100 µs
/// sent back to back, with `read` busy-polled between slices and after the
/// last until `trial.received` reaches `trial.published` (or 3 s have passed).
fn paced(
    trial: &mut Trial,
    rate_hz: f64,
    mut publish: impl FnMut() -> anyhow::Result<()>,
    mut read: impl FnMut(&mut Trial) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let published = trial.published;
    let slice_ns = 100_000u64;
    let per_slice = rate_hz * slice_ns as f64 * 1e-9;
    let start = now_ns();
    let mut sent = 0u64;
    let mut slice = 0u64;
    while sent < published {
        let due = ((slice + 1) as f64 * per_slice).round() as u64;
        while sent < due.min(published) {
            publish()?;
            sent += 1;
        }
        slice += 1;
        let next = start + slice * slice_ns;
        while now_ns() < next {
            read(trial)?;
        }
    }
    let deadline = Instant::now() + Duration::from_secs(3);
    while trial.received < published && Instant::now() < deadline {
        read(trial)?;
    }
    read(trial)
}
