//! Latency measurements over real processes: raw iceoryx2 ping-pong (the floor,
//! [`pingpong`]) and fusiond end to end (sample published → snapshot of that sample
//! received).

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fusion_client::{Client, SampleKind, now_ns};
use fusion_shared::service;
use hdrhistogram::Histogram;

mod late;
mod throughput;
pub use late::{LateCost, late_data};
pub use throughput::{Trial, raw_throughput, throughput};

mod pacer;
pub mod pingpong;

/// The `linear` config of the live benchmarks (at rest, gating on).
pub const LINEAR_CONFIG: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
    initial_covariance_diagonal = [100,100,100,10,10,10]\n[gating]\nprobability = 0.999\n";
/// The `ins` config of the live benchmarks (at rest, level, gating on).
pub const INS_CONFIG: &str = "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
    initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
    initial_covariance_diagonal = [1,1,1, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
    [gating]\nprobability = 0.999\n";

/// The `ins` config of the vehicle rows with the GNSS antenna's kinds (a TOML
/// array): [`INS_CONFIG`] with a datum, two IMUs averaged (one in FRD axes turned
/// 90° in yaw), a GNSS antenna 1.5 m from them and wheel odometry on the rear axle.
macro_rules! vehicle_config {
    ($gnss_kinds:literal) => {
        concat!(
            "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
    accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
    initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
    initial_covariance_diagonal = [1,1,1, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n\
    [gating]\nprobability = 0.999\n\
    [datum]\nlatitude_deg = 48.1316\nlongitude_deg = 11.5494\nheight_m = 519.0\n\
    [[sensor]]\nname = \"imu-a\"\nid = 0\nkinds = [\"imu\"]\naxes = \"frd\"\nrotation_rpy_deg = [0, 0, 90]\n\
    [[sensor]]\nname = \"imu-b\"\nid = 1\nkinds = [\"imu\"]\n\
    [[sensor]]\nname = \"gnss\"\nid = 3\nkinds = ",
            $gnss_kinds,
            "\nlever_arm_m = [1.0, 0.5, 1.0]\n\
    [[sensor]]\nname = \"wheels\"\nid = 0\nkinds = [\"odometry\"]\nlever_arm_m = [-1.3, 0.0, -0.3]\n"
        )
    };
}

/// The `ins` config of the vehicle rows (see `vehicle_config!`), GNSS positions only.
pub const VEHICLE_CONFIG: &str = vehicle_config!("[\"geodetic\"]");

/// The samples of the vehicle set ([`VEHICLE_CONFIG`]) at instant `k` (time
/// `t`), in the order the vehicle prober publishes them: a geodetic fix every
/// 100th instant (at 50), an odometry speed every 20th (at 10), then both IMUs,
/// of a vehicle at rest, level.
pub fn vehicle_instant(t: u64, k: u64) -> Vec<fusion_shared::Sample> {
    use fusion_shared::{GeodeticSample, ImuSample, OdometrySample, Sample};
    let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
    let mut out = Vec::with_capacity(4);
    if k % 100 == 50 {
        out.push(Sample::Geodetic(GeodeticSample::new(t, 3, k / 100, 48.1316, 11.5494, 519.0, cov)));
    }
    if k % 20 == 10 {
        out.push(Sample::Odometry(OdometrySample::new(t, 0, k / 20, 0.0, 0.01)));
    }
    out.push(Sample::Imu(ImuSample::new(t, 0, k, VEHICLE_IMUS_AT_REST[0], [0.0; 3])));
    out.push(Sample::Imu(ImuSample::new(t, 1, k, VEHICLE_IMUS_AT_REST[1], [0.0; 3])));
    out
}

/// The config of the largest state (21 error states): [`VEHICLE_CONFIG`] with
/// the odometry's scale factor as a state, a barometer (its bias a state) and
/// a localiser's poses in a map frame estimated as four states. The vehicle
/// set's samples plus a pressure every 20th instant and a pose every 100th
/// ([`vehicle21_extras`]).
pub const VEHICLE21_CONFIG: &str = concat!(
    vehicle_config!("[\"geodetic\"]"),
    "[model.odometry_scale]\n\
    [[sensor]]\nname = \"baro\"\nid = 0\nkinds = [\"barometer\"]\n\
    [[sensor]]\nname = \"slam\"\nid = 0\nkinds = [\"pose\"]\nlever_arm_m = [0.5, 0.0, 1.2]\n"
);

/// The samples [`VEHICLE21_CONFIG`]'s sensors add to the vehicle set's at
/// instant `k` (time `t`): a static pressure at sea level every 20th instant
/// (at 15), a pose at the map origin every 100th (at 30), both of a vehicle at
/// rest, level, heading east.
pub fn vehicle21_extras(t: u64, k: u64) -> Option<fusion_shared::Sample> {
    use fusion_shared::{BarometerSample, ISA_SEA_LEVEL_PA, PoseSample, Sample};
    if k % 20 == 15 {
        return Some(Sample::Barometer(BarometerSample::new(t, 0, k / 20, ISA_SEA_LEVEL_PA, 4.0)));
    }
    if k % 100 == 30 {
        let mut cov = [0.0; 36];
        for i in 0..6 {
            cov[i * 7] = if i < 3 { 0.01 } else { 1e-4 };
        }
        return Some(Sample::Pose(PoseSample::new(t, 0, k / 100, [0.0; 3], [1.0, 0.0, 0.0, 0.0], cov, 0)));
    }
    None
}

/// The config of the late vehicle stream: [`VEHICLE_CONFIG`] with the GNSS
/// receiver's Doppler velocity (same antenna) as well.
pub const VEHICLE_LATE_CONFIG: &str = vehicle_config!("[\"geodetic\", \"velocity\"]");

/// What the two IMUs of [`VEHICLE_CONFIG`] read at rest, level: IMU 0 (FRD, turned
/// 90°) sees gravity along its −z, IMU 1 along its +z.
pub const VEHICLE_IMUS_AT_REST: [[f64; 3]; 2] = [[0.0, 0.0, -9.80665], [0.0, 0.0, 9.80665]];

pub use pacer::Pacer;
pub use pingpong::{Payload, Pinger, ping, pong};

/// How both sides wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Busy-poll.
    Spin,
    /// Sleep on an iceoryx2 event.
    Event,
}

impl Mode {
    /// `spin` or `event`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Spin => "spin",
            Mode::Event => "event",
        }
    }

    /// Parses `spin` or `event`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "spin" => Some(Mode::Spin),
            "event" => Some(Mode::Event),
            _ => None,
        }
    }
}

/// A new latency histogram: 1 ns to 10 s, 3 significant digits.
pub fn histogram() -> Histogram<u64> {
    // Constant, valid bounds.
    Histogram::new_with_bounds(1, 10_000_000_000, 3).expect("valid histogram bounds")
}

/// Ends a child process however it is (kill, then reap).
pub struct ChildGuard(pub Child);

impl ChildGuard {
    /// Sends `signal` (a `kill` name such as `STOP`) to the child.
    fn signal(&self, signal: &str) -> anyhow::Result<()> {
        let status = Command::new("kill").arg(format!("-{signal}")).arg(self.0.id().to_string()).status()?;
        anyhow::ensure!(status.success(), "kill -{signal} {} failed", self.0.id());
        Ok(())
    }

    /// Freezes the child (SIGSTOP): a busy-polling process stops taking a core.
    pub fn pause(&self) -> anyhow::Result<()> {
        self.signal("STOP")
    }

    /// Lets a paused child run again (SIGCONT).
    pub fn resume(&self) -> anyhow::Result<()> {
        self.signal("CONT")
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            // A paused child would not see SIGTERM, and SIGKILL leaves its files.
            let _ = self.signal("CONT");
            let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
            let deadline = Instant::now() + Duration::from_secs(5);
            while matches!(self.0.try_wait(), Ok(None)) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(10));
            }
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

/// The next snapshot, busy-polling or sleeping on the event as `mode` says; an
/// error once `deadline` has passed without the snapshot of IMU sample `seq`.
fn next_snapshot(
    state: &mut fusion_client::StateSubscriber,
    mode: Mode,
    deadline: Instant,
    seq: u64,
) -> anyhow::Result<Option<&fusion_client::StateSnapshot>> {
    let left = deadline.saturating_duration_since(Instant::now());
    anyhow::ensure!(!left.is_zero(), "no snapshot for IMU sample {seq}");
    Ok(match mode {
        Mode::Spin => state.spin_next(left)?,
        Mode::Event => state.wait_next(left)?,
    })
}

/// End-to-end latencies and their three legs (the processes share
/// CLOCK_MONOTONIC, so the legs are differences of stamps taken in different
/// processes).
#[derive(Debug, Clone)]
pub struct EndToEnd {
    /// Snapshot received − sample sent, ns.
    pub latency: Histogram<u64>,
    /// Sample taken off fusiond's subscriber − sample sent: the trip in, ns.
    pub to_daemon: Histogram<u64>,
    /// The daemon's part: snapshot published − sample received (the daemon's
    /// clock), ns.
    pub daemon: Histogram<u64>,
    /// Snapshot received − snapshot published: the trip out (the send included), ns.
    pub from_daemon: Histogram<u64>,
    /// Timed snapshots that were provisional (a late sample's correction still
    /// to land, [`fusion_client::StateSnapshot::settled`]).
    pub provisional: u64,
}

impl EndToEnd {
    /// Empty histograms.
    pub fn new() -> Self {
        Self {
            latency: histogram(),
            to_daemon: histogram(),
            daemon: histogram(),
            from_daemon: histogram(),
            provisional: 0,
        }
    }

    /// Adds `other`'s recordings to these.
    pub fn add(&mut self, other: &Self) -> anyhow::Result<()> {
        self.latency.add(&other.latency)?;
        self.to_daemon.add(&other.to_daemon)?;
        self.daemon.add(&other.daemon)?;
        self.from_daemon.add(&other.from_daemon)?;
        self.provisional += other.provisional;
        Ok(())
    }
}

impl Default for EndToEnd {
    fn default() -> Self {
        Self::new()
    }
}

/// A client of fusiond that publishes IMU samples (plus a position fix every
/// 100th) and waits for the snapshot that names each; it can run in several
/// blocks, its sequence numbers going on from one to the next. With
/// [`Prober::vehicle`], the sensor set of [`VEHICLE_CONFIG`] instead: two IMUs at
/// the same instants, a geodetic fix every 100th instant (10 Hz at 1 kHz) and an
/// odometry speed every 20th (50 Hz); each instant is timed from the send of its
/// last IMU sample to the first snapshot with both samples in.
/// With [`Prober::vehicle_late`], a real vehicle's stream ([`VEHICLE_LATE_CONFIG`]):
/// the GNSS fix and Doppler velocity arrive 80–120 ms after their time of
/// validity and the odometry 10–30 ms after, each published just before the IMU
/// samples of the instant it arrives at.
///
/// The IMU samples are stamped on the IMU's own clock: the pacer's tick, on a
/// grid a period apart, as a sensor with hardware timestamps stamps them
/// ([`Prober::stamped_on_receipt`]: with the host's clock when sent instead,
/// a driver that stamps on receipt). Either way the latency is timed from the send.
pub struct Prober {
    imu: fusion_client::ImuPublisher,
    pos: fusion_client::PositionPublisher,
    vehicle: Option<VehiclePublishers>,
    state: fusion_client::StateSubscriber,
    mode: Mode,
    imu_value: ([f64; 3], [f64; 3]),
    seq: u64,
    /// IMU samples stamped with the host's clock at their send, not the tick.
    on_receipt: bool,
}

/// The further publishers of the vehicle rows.
struct VehiclePublishers {
    imu_b: fusion_client::ImuPublisher,
    geodetic: fusion_client::SamplePublisher<fusion_shared::GeodeticSample>,
    odometry: fusion_client::SamplePublisher<fusion_shared::OdometrySample>,
    /// The late stream: the GNSS velocity publisher, and the samples arrive late.
    late: Option<fusion_client::SamplePublisher<fusion_shared::VelocitySample>>,
    /// The largest state's barometer and pose publishers ([`vehicle21_extras`]).
    extras: Option<Extras>,
}

/// The publishers of [`vehicle21_extras`]' samples.
struct Extras {
    barometer: fusion_client::SamplePublisher<fusion_shared::BarometerSample>,
    pose: fusion_client::SamplePublisher<fusion_shared::PoseSample>,
}

impl Extras {
    /// Publishes one of [`vehicle21_extras`]' samples as its sensor's next one.
    fn publish(&mut self, sample: fusion_shared::Sample) -> anyhow::Result<()> {
        use fusion_shared::Sample;
        match sample {
            Sample::Barometer(b) => self.barometer.publish_next(b)?,
            Sample::Pose(p) => self.pose.publish_next(p)?,
            other => anyhow::bail!("no extra publisher for a {} sample", other.kind().name()),
        };
        Ok(())
    }
}

/// How late a late-stream sample arrives: `min_ms..=max_ms`, spread evenly
/// and deterministically over the sequence numbers.
fn lateness_ns(seq: u64, min_ms: u64, max_ms: u64) -> u64 {
    let span = max_ms - min_ms + 1;
    (min_ms + (seq.wrapping_mul(7919) ^ (seq >> 3)) % span) * 1_000_000
}

impl Prober {
    /// Publishers (IMU sensor 0, position sensor 1) and a reader on `client`.
    pub fn new(client: &Client, mode: Mode, imu_value: ([f64; 3], [f64; 3])) -> anyhow::Result<Self> {
        let mut imu = client.imu_publisher(0)?;
        let mut pos = client.position_publisher(1)?;
        // The daemon only needs waking in event mode.
        imu.set_wake(mode == Mode::Event);
        pos.set_wake(mode == Mode::Event);
        let state = client.state_subscriber_with_buffer(fusion_shared::service::STATE_BUFFER)?;
        Ok(Self { imu, pos, vehicle: None, state, mode, imu_value, seq: 0, on_receipt: false })
    }

    /// The vehicle prober (see the type's docs; the daemon runs [`VEHICLE_CONFIG`]).
    pub fn vehicle(client: &Client, mode: Mode) -> anyhow::Result<Self> {
        let mut p = Self::new(client, mode, (VEHICLE_IMUS_AT_REST[0], [0.0; 3]))?;
        let mut v = VehiclePublishers {
            imu_b: client.imu_publisher(1)?,
            geodetic: client.publisher(3)?,
            odometry: client.publisher(0)?,
            late: None,
            extras: None,
        };
        v.imu_b.set_wake(mode == Mode::Event);
        v.geodetic.set_wake(mode == Mode::Event);
        v.odometry.set_wake(mode == Mode::Event);
        p.vehicle = Some(v);
        Ok(p)
    }

    /// The late vehicle prober (see the type's docs; the daemon runs
    /// [`VEHICLE_LATE_CONFIG`]).
    pub fn vehicle_late(client: &Client, mode: Mode) -> anyhow::Result<Self> {
        let mut p = Self::vehicle(client, mode)?;
        let mut velocity = client.publisher(3)?;
        velocity.set_wake(mode == Mode::Event);
        if let Some(v) = &mut p.vehicle {
            v.late = Some(velocity);
        }
        Ok(p)
    }

    /// The prober of the largest state (the daemon runs [`VEHICLE21_CONFIG`]):
    /// the vehicle set's samples and [`vehicle21_extras`].
    pub fn vehicle21(client: &Client, mode: Mode) -> anyhow::Result<Self> {
        let mut p = Self::vehicle(client, mode)?;
        let mut extras = Extras { barometer: client.publisher(0)?, pose: client.publisher(0)? };
        extras.barometer.set_wake(mode == Mode::Event);
        extras.pose.set_wake(mode == Mode::Event);
        if let Some(v) = &mut p.vehicle {
            v.extras = Some(extras);
        }
        Ok(p)
    }

    /// The prober with its IMU samples stamped with the host's clock when sent
    /// (a few µs off the tick, different at each), not on the IMU's clock.
    pub fn stamped_on_receipt(mut self) -> Self {
        self.on_receipt = true;
        self
    }

    /// `count` IMU samples at `rate_hz`; all but the first `warmup` are recorded.
    pub fn run(&mut self, count: u64, warmup: u64, rate_hz: f64, out: &mut EndToEnd) -> anyhow::Result<()> {
        self.run_paced(count, warmup, Pacer::new(rate_hz), out)
    }

    /// [`run`](Self::run), paced by `pacer`.
    pub fn run_paced(&mut self, count: u64, warmup: u64, mut pacer: Pacer, out: &mut EndToEnd) -> anyhow::Result<()> {
        for k in 0..count {
            let seq = self.seq;
            self.seq += 1;
            let tick = pacer.wait();
            let t = if self.on_receipt { now_ns() } else { tick };
            let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
            match &mut self.vehicle {
                None if seq % 100 == 50 => {
                    self.pos.publish(t, [0.0; 3], cov)?;
                }
                None => {}
                Some(v) => {
                    // In the late stream, what arrives now was valid that long ago.
                    let (gnss_t, odometry_t) = match v.late {
                        Some(_) => (t - lateness_ns(seq / 100, 80, 120), t - lateness_ns(seq / 20, 10, 30)),
                        None => (t, t),
                    };
                    if seq % 100 == 50 {
                        let fix =
                            fusion_shared::GeodeticSample::new(gnss_t, 3, seq / 100, 48.1316, 11.5494, 519.0, cov);
                        v.geodetic.publish_next(fix)?;
                        if let Some(velocity) = &mut v.late {
                            let vel_cov = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04];
                            velocity
                                .publish_next(fusion_shared::VelocitySample::new(gnss_t, 3, 0, [0.0; 3], vel_cov))?;
                        }
                    }
                    if seq % 20 == 10 {
                        let speed = fusion_shared::OdometrySample::new(odometry_t, 0, seq / 20, 0.0, 0.01);
                        v.odometry.publish_next(speed)?;
                    }
                    if let Some(e) = &mut v.extras
                        && let Some(sample) = vehicle21_extras(t, seq)
                    {
                        e.publish(sample)?;
                    }
                }
            }
            self.imu.publish(t, self.imu_value.0, self.imu_value.1)?;
            // The vehicle's second IMU sample: the instant's last one sent,
            // from which the instant is timed.
            let last_sent = match &mut self.vehicle {
                Some(v) => {
                    let sent = now_ns();
                    v.imu_b.publish(t, VEHICLE_IMUS_AT_REST[1], [0.0; 3])?;
                    Some(sent)
                }
                None => None,
            };
            let deadline = Instant::now() + Duration::from_secs(2);
            loop {
                let snap = next_snapshot(&mut self.state, self.mode, deadline, seq)?;
                let Some(s) = snap.filter(|s| s.input_kind == SampleKind::Imu as u32 && s.input_seq == seq) else {
                    continue;
                };
                let received = now_ns();
                // One IMU: its sample's snapshot. Two: the first snapshot with
                // both samples of the instant in (fusiond publishes one per
                // instant, named after whichever sample completed it; a build
                // that publishes one per sample is timed by its second).
                let (done, sent) = match last_sent {
                    None => (true, s.input_sent_ns),
                    Some(sent) => (imus_received(s) >= 2 * (seq + 1), sent),
                };
                if !done {
                    continue;
                }
                if k >= warmup {
                    out.latency.record(received.saturating_sub(sent))?;
                    out.to_daemon.record(s.input_received_ns.saturating_sub(s.input_sent_ns))?;
                    out.daemon.record(s.publish_ns.saturating_sub(s.input_received_ns))?;
                    out.from_daemon.record(received.saturating_sub(s.publish_ns))?;
                    out.provisional += u64::from(!s.settled());
                }
                break;
            }
        }
        Ok(())
    }
}

/// The IMU samples a snapshot's sensor counters say fusiond took in, all IMUs.
fn imus_received(s: &fusion_client::StateSnapshot) -> u64 {
    let imus = s.sensor_counters().iter().filter(|c| c.sample_kind() == Some(SampleKind::Imu));
    imus.map(|c| c.counts.received).sum()
}

/// Starts `fusiond run` from `bin` in `namespace` with `config` written to `dir`.
pub fn start_daemon(
    bin: &std::path::Path,
    dir: &std::path::Path,
    config: &str,
    namespace: &str,
    mode: Mode,
) -> anyhow::Result<ChildGuard> {
    let path = dir.join(format!("{namespace}.toml"));
    std::fs::write(&path, config)?;
    let child = Command::new(bin)
        .args(["run", "--namespace", namespace, "--wait", mode.name(), "--config"])
        .arg(&path)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()?;
    Ok(ChildGuard(child))
}

/// What the separate publisher process sends (the fan-out rows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PublisherPlan {
    /// IMU rate, Hz.
    pub rate_hz: f64,
    /// IMU samples to send.
    pub count: u64,
    /// IMU and position sensor id.
    pub sensor: u32,
    /// Notify the daemon's wake event (event mode).
    pub wake: bool,
}

impl PublisherPlan {
    /// The plan as environment variables for the re-executed bench binary.
    pub fn to_env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("FUSION_BENCH_RATE", self.rate_hz.to_string()),
            ("FUSION_BENCH_COUNT", self.count.to_string()),
            ("FUSION_BENCH_SENSOR", self.sensor.to_string()),
            ("FUSION_BENCH_WAKE", u8::from(self.wake).to_string()),
        ]
    }

    /// The plan from the environment (see [`to_env`](Self::to_env)).
    pub fn from_env() -> anyhow::Result<Self> {
        let var = |k: &str| std::env::var(k).map_err(|_| anyhow::anyhow!("{k} not set"));
        Ok(Self {
            rate_hz: var("FUSION_BENCH_RATE")?.parse()?,
            count: var("FUSION_BENCH_COUNT")?.parse()?,
            sensor: var("FUSION_BENCH_SENSOR")?.parse()?,
            wake: var("FUSION_BENCH_WAKE")? == "1",
        })
    }
}

/// The publisher process: IMU samples at the plan's rate, plus a position fix
/// every 100th, into `namespace`. Samples carry `t_ns = sent_ns = now`.
pub fn publisher(namespace: &str, plan: PublisherPlan, imu_value: ([f64; 3], [f64; 3])) -> anyhow::Result<()> {
    let client = Client::connect(namespace)?;
    let mut imu = client.imu_publisher(plan.sensor)?;
    let mut pos = client.position_publisher(plan.sensor)?;
    imu.set_wake(plan.wake);
    pos.set_wake(plan.wake);
    // Let the daemon's subscribers connect to the new publishers.
    std::thread::sleep(Duration::from_millis(200));
    let mut pacer = Pacer::new(plan.rate_hz);
    for seq in 0..plan.count {
        pacer.wait();
        let t = now_ns();
        if seq % 100 == 50 {
            pos.publish(t, [0.0; 3], [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64])?;
        }
        imu.publish(t, imu_value.0, imu_value.1)?;
    }
    Ok(())
}

/// The fan-out reader: every snapshot of an IMU sample from `sensor` with
/// `seq ≥ skip`, until `count` are recorded or the stream has been quiet for a
/// second: received − sent, ns.
pub fn fan_out_reader(
    client: &Client,
    mode: Mode,
    sensor: u32,
    skip: u64,
    count: u64,
) -> anyhow::Result<Histogram<u64>> {
    let mut state = client.state_subscriber_with_buffer(service::STATE_BUFFER)?;
    let mut latency = histogram();
    let mut idle_since = Instant::now();
    while latency.len() < count {
        let snap = match mode {
            Mode::Spin => state.spin_next(Duration::from_millis(100))?,
            Mode::Event => state.wait_next(Duration::from_millis(100))?,
        };
        let Some(s) = snap else {
            // The publisher sent `skip + count` samples; a few may have left no
            // snapshot of their own (e.g. refused); once it is quiet, stop.
            if !latency.is_empty() && idle_since.elapsed() > Duration::from_secs(1) {
                break;
            }
            anyhow::ensure!(idle_since.elapsed() < Duration::from_secs(5), "no snapshot for 5 s");
            continue;
        };
        let received = now_ns();
        idle_since = Instant::now();
        if s.input_kind == SampleKind::Imu as u32 && s.input_sensor == sensor && s.input_seq >= skip {
            latency.record(received.saturating_sub(s.input_sent_ns))?;
        }
    }
    Ok(latency)
}
