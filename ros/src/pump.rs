//! fusion-ros's two threads besides Zenoh's: ROS messages to fusiond's
//! samples (`input`), fusiond's snapshots to odometry, TF and diagnostics
//! (`output`). Each owns its own iceoryx2 node (iceoryx2's ports stay on
//! their thread).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam::channel::{Receiver, RecvTimeoutError};
use fusion_client::{Client, SensorPublishers, StateSubscriber};
use fusion_ros::Sink;
use fusion_ros::clock::RosClock;
use fusion_ros::diagnostics::{Report, diagnostics};
use fusion_ros::input::{InputStats, InputTopic};
use fusion_ros::odometry::{BaseLink, Rate, odometry};
use fusion_ros::settings::RosSettings;
use fusion_shared::ros::messages::{Imu, Odometry, Ros2Header};
use fusion_shared::ros::ros2::{DiagnosticArray, TfMessage};
use fusion_shared::ros::{LiveReader, Route, decode_cdr};
use fusion_shared::{Sample, StateSnapshot};

/// A message that passed its checks, for the input thread.
pub struct Inbound {
    /// Its topic's index in the input topics.
    pub topic: usize,
    /// Its CDR.
    pub data: Vec<u8>,
}

/// What the threads share.
pub struct Shared {
    /// The ROS clock.
    pub clock: RosClock,
    /// The input's counts.
    pub stats: InputStats,
    /// The newest IMU rate (for the twist).
    pub rate: Mutex<Rate>,
    /// Set to stop.
    pub stop: AtomicBool,
    /// Odometry messages sent.
    pub odometry_sent: AtomicU64,
}

/// The IMU rate of an Imu message: its angular velocity and covariance
/// (zeros where not given).
fn imu_rate(data: &[u8]) -> Option<Rate> {
    let m: Imu<Ros2Header> = decode_cdr(data).ok()?;
    let v = m.angular_velocity;
    let cov = if m.angular_velocity_covariance[0] < 0.0 { [0.0; 9] } else { m.angular_velocity_covariance };
    Some(Rate { radps: [v.x, v.y, v.z], cov })
}

/// A sample's ROS stamp moved onto fusiond's clock, or why it cannot be.
fn restamped(mut sample: Sample, clock: &RosClock) -> Result<Sample, String> {
    let t = clock.to_monotonic(sample.t_ns())?;
    sample.header_mut().t_ns = t;
    Ok(sample)
}

/// Until stopped: each message from `rx` decoded with the topic map and its
/// samples published to fusiond in `namespace`.
pub fn input(namespace: &str, routes: Vec<Route>, topics: Vec<InputTopic>, rx: Receiver<Inbound>, shared: &Shared) {
    let run = || -> anyhow::Result<()> {
        let client = Client::connect(namespace)?;
        let mut publishers = SensorPublishers::all(&client)?;
        let mut reader = LiveReader::new(routes);
        let mut items = Vec::new();
        while !shared.stop.load(Ordering::Relaxed) {
            let m = match rx.recv_timeout(Duration::from_millis(100)) {
                Ok(m) => m,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => break,
            };
            let t = &topics[m.topic];
            shared.stats.message(&t.topic);
            if let Err(why) = reader.message(&t.topic, t.ty.ros, &m.data, |item| items.push(item)) {
                shared.stats.refuse(&t.topic, &why);
            }
            for item in items.drain(..) {
                match item.sample.and_then(|s| restamped(s, &shared.clock)) {
                    Ok(s) => {
                        if matches!(s, Sample::Imu(_))
                            && let Some(rate) = imu_rate(&m.data)
                        {
                            *shared.rate.lock().unwrap_or_else(|e| e.into_inner()) = rate;
                        }
                        match publishers.publish(s) {
                            Ok(_) => shared.stats.sample(&t.topic),
                            Err(e) => shared.stats.refuse(&t.topic, &format!("not sent to fusiond: {e}")),
                        }
                    }
                    Err(why) => shared.stats.refuse(&t.topic, &why),
                }
            }
        }
        Ok(())
    };
    if let Err(e) = run() {
        tracing::error!("input: {e:#}");
        shared.stop.store(true, Ordering::Relaxed);
    }
}

/// What the output thread publishes on.
pub struct Outputs {
    /// `[ros] odometry_topic`.
    pub odometry: Box<dyn Sink<Odometry<Ros2Header>>>,
    /// `[ros] tf_topic`, if any.
    pub tf: Option<Box<dyn Sink<TfMessage>>>,
    /// `[ros] diagnostics_topic`, if any.
    pub diagnostics: Option<Box<dyn Sink<DiagnosticArray>>>,
}

/// One odometry (and TF) per `period_ns` of estimate time at most; every one
/// with a period of 0, and again at once when the estimate's time goes back
/// (a new timeline).
struct Decimate {
    period_ns: u64,
    last: Option<u64>,
}

impl Decimate {
    fn due(&mut self, t_ns: u64) -> bool {
        if let Some(last) = self.last
            && t_ns >= last
            && t_ns - last < self.period_ns
        {
            return false;
        }
        self.last = Some(t_ns);
        true
    }
}

/// The state subscriber, once fusiond serves one.
fn subscriber(client: &Client, shared: &Shared) -> Option<StateSubscriber> {
    let mut said = false;
    while !shared.stop.load(Ordering::Relaxed) {
        if let Ok(s) = client.state_subscriber() {
            return Some(s);
        }
        if !said {
            tracing::info!("waiting for fusiond's snapshots");
            said = true;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    None
}

/// Until stopped: fusiond's snapshots in `namespace` to odometry and TF (at
/// most `[ros] rate_hz`), and diagnostics every `[ros] diagnostics_period_s`.
pub fn output(namespace: &str, ros: &RosSettings, routes: &[Route], out: &Outputs, shared: &Shared) {
    let run = || -> anyhow::Result<()> {
        let client = Client::connect(namespace)?;
        let Some(mut sub) = subscriber(&client, shared) else { return Ok(()) };
        let base = BaseLink::new(ros.base_link_position_m, ros.base_link_rotation_rpy_deg);
        let period_ns = if ros.rate_hz > 0.0 { (1e9 / ros.rate_hz) as u64 } else { 0 };
        let mut decimate = Decimate { period_ns, last: None };
        let diagnostics_period = Duration::from_secs_f64(ros.diagnostics_period_s);
        let mut next_diagnostics = Instant::now() + diagnostics_period;
        let mut newest: Option<(StateSnapshot, Instant)> = None;
        while !shared.stop.load(Ordering::Relaxed) {
            if let Some(s) = sub.wait_next(Duration::from_millis(50))? {
                let s = *s;
                if decimate.due(s.t_ns) {
                    send_odometry(&s, &base, ros, out, shared)?;
                }
                newest = Some((s, Instant::now()));
            }
            if Instant::now() >= next_diagnostics {
                next_diagnostics += diagnostics_period;
                if let Some(p) = &out.diagnostics {
                    let stale = newest.as_ref().is_some_and(|(_, at)| at.elapsed() > 2 * diagnostics_period);
                    let input = shared.stats.counts();
                    let report = Report {
                        node: &ros.node,
                        snapshot: newest.as_ref().map(|(s, _)| (s, stale)),
                        routes,
                        input: &input,
                        clock_steps: shared.clock.steps.load(Ordering::Relaxed),
                    };
                    p.put(&diagnostics(&report, shared.clock.now_ros()))?;
                }
            }
        }
        Ok(())
    };
    if let Err(e) = run() {
        tracing::error!("output: {e:#}");
        shared.stop.store(true, Ordering::Relaxed);
    }
}

fn send_odometry(
    s: &StateSnapshot,
    base: &BaseLink,
    ros: &RosSettings,
    out: &Outputs,
    shared: &Shared,
) -> anyhow::Result<()> {
    let Some(stamp) = shared.clock.to_ros(s.t_ns) else { return Ok(()) };
    let rate = *shared.rate.lock().unwrap_or_else(|e| e.into_inner());
    let Some((odom, tf)) = odometry(s, base, &rate, stamp, &ros.world_frame, &ros.base_frame) else { return Ok(()) };
    out.odometry.put(&odom)?;
    shared.odometry_sent.fetch_add(1, Ordering::Relaxed);
    if let Some(p) = &out.tf {
        p.put(&TfMessage { transforms: vec![tf] })?;
    }
    Ok(())
}

/// Shared state at the start.
pub fn shared(clock: RosClock) -> Arc<Shared> {
    Arc::new(Shared {
        clock,
        stats: InputStats::default(),
        rate: Mutex::new(Rate::default()),
        stop: AtomicBool::new(false),
        odometry_sent: AtomicU64::new(0),
    })
}
