//! A ROS 2 node's message all the way to its odometry, on each middleware,
//! beside that middleware's raw round trip and fusiond's own leg, measured
//! in the same run.
//!
//! - **ROS node → odometry**: a ROS node's stand-in in this process publishes
//!   `sensor_msgs/msg/Imu` stamped with the wall clock at 200 Hz; fusion-ros
//!   hands each to fusiond (iceoryx2), and sends the odometry of its
//!   snapshot back; the stand-in takes `received − sent` of the odometry with
//!   the Imu's stamp.
//! - **raw round trip**: the same stand-in sends a message of the Imu's size
//!   to an echo node (a second session or participant in this process, where
//!   fusion-ros sits) which answers with one of the odometry's size, through
//!   the same middleware (on rmw_zenoh, through the same router).
//! - **fusiond's leg**: `received − sent` of the snapshot of each sample
//!   fusion-ros published, read over iceoryx2 (the latency bench's e2e row).
//!
//! The ROS row should stay within 1.5× of the raw round trip plus fusiond's
//! leg. Everything is on this host: rmw_zenoh through a router on 127.0.0.1,
//! DDS on the 127.0.0.1 interface alone (`[ros] dds_interfaces`).
//!
//! `cargo bench -p fusion-ros --bench ros` (fusiond from `target/release`, or
//! `FUSION_BENCH_FUSIOND=PATH`); `FUSION_BENCH_SECONDS` per row (default 5).

use std::collections::HashMap;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use fusion_client::Client;
use fusion_ros::Sink;
use fusion_ros::dds::DdsNode;
use fusion_ros::rmw_zenoh::{Attachment, Qos, TopicType, topic_key};
use fusion_shared::ros::decode_cdr;
use fusion_shared::ros::messages::{Imu, Odometry, Quaternion, Ros2Header, Vector3};
use fusion_shared::ros::ros2::{Time, to_cdr};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::time::{now_ns, wall_minus_monotonic_ns};
use hdrhistogram::Histogram;
use zenoh::Wait;

struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
        let _ = self.0.wait();
    }
}

fn config(transport: &str) -> String {
    format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.1\ngyroscope_noise_density = 0.004\naccelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-4\n\n[filter]\ninitial_state = [0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]\ninitial_covariance_diagonal = [1e-6, 1e-6, 1e-6, 0.01, 0.01, 0.01, 0.01, 0.01, 1.0, 0.01, 0.01, 0.01, 1e-4, 1e-4, 1e-4]\n\n[[sensor]]\nname = \"imu\"\nid = 0\nkinds = [\"imu\"]\ntopic = \"/imu/data\"\n\n\
         [ros]\ntransport = \"{transport}\"\nrate_hz = 0.0\ndiagnostics_topic = \"\"\ndds_interfaces = [\"127.0.0.1\"]\n"
    )
}

fn imu(stamp_ns: u64) -> Imu<Ros2Header> {
    let t = Time::of_ns(stamp_ns);
    let header = Ros2Header { sec: t.sec, nanosec: t.nanosec, frame_id: "imu_link".into() };
    let v = |x, y, z| Vector3 { x, y, z };
    Imu {
        header,
        orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
        orientation_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        angular_velocity: v(0.0, 0.0, 0.001),
        angular_velocity_covariance: [0.0; 9],
        linear_acceleration: v(0.0, 0.0, 9.81),
        linear_acceleration_covariance: [0.0; 9],
    }
}

fn wall_ns() -> u64 {
    now_ns() + wall_minus_monotonic_ns()
}

/// Latencies, µs percentiles.
fn row(name: &str, h: &Histogram<u64>) -> f64 {
    let us = |q: f64| h.value_at_quantile(q) as f64 / 1000.0;
    println!(
        "| {name:<34} | {:>6} | {:>8.1} | {:>8.1} | {:>8.1} | {:>8.1} |",
        h.len(),
        us(0.5),
        us(0.9),
        us(0.99),
        h.max() as f64 / 1000.0
    );
    us(0.5)
}

/// fusiond's leg: `now − input_sent_ns` of every snapshot, read over iceoryx2.
fn fusiond_leg(domain: String, ns: String, until: Instant) -> Histogram<u64> {
    let client = Client::connect_in_domain(&ns, Some(&domain)).unwrap();
    let mut h = Histogram::new(3).unwrap();
    let mut sub = loop {
        if let Ok(s) = client.state_subscriber() {
            break s;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    while Instant::now() < until {
        if let Some(s) = sub.wait_next(Duration::from_millis(50)).unwrap()
            && s.input_sent_ns > 0
        {
            let _ = h.record(now_ns().saturating_sub(s.input_sent_ns));
        }
    }
    h
}

/// What the stand-in sent (stamp → when) and took back.
struct Book {
    sent: HashMap<u64, u64>,
    odometry: Histogram<u64>,
    raw: Histogram<u64>,
}

fn book() -> Arc<Mutex<Book>> {
    Arc::new(Mutex::new(Book {
        odometry: Histogram::new(3).unwrap(),
        raw: Histogram::new(3).unwrap(),
        sent: HashMap::new(),
    }))
}

fn on_odometry(book: &Mutex<Book>, o: &Odometry<Ros2Header>) {
    let now = now_ns();
    let stamp = o.header.sec as u64 * 1_000_000_000 + u64::from(o.header.nanosec);
    let mut b = book.lock().unwrap();
    if let Some(sent) = b.sent.remove(&stamp) {
        let _ = b.odometry.record(now - sent);
    }
}

/// The pace: `each(i)` every 5 ms for `seconds`.
fn paced(seconds: f64, mut each: impl FnMut(u64)) {
    let start = Instant::now();
    let mut i = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        let next = start + Duration::from_micros(5000 * i);
        if let Some(d) = next.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
        each(i);
        i += 1;
    }
}

fn zenoh_session(mode: &str, port: u16, listen: bool) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", &format!("\"{mode}\"")).unwrap();
    let endpoints = format!("[\"tcp/127.0.0.1:{port}\"]");
    c.insert_json5(if listen { "listen/endpoints" } else { "connect/endpoints" }, &endpoints).unwrap();
    c.insert_json5("scouting/multicast/enabled", "false").unwrap();
    zenoh::open(c).wait().unwrap()
}

fn zenoh_rows(seconds: f64, start: &dyn Fn(&str, &[&str]) -> Proc, domain: &str, ns: &str) {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let _router = zenoh_session("router", port, true);
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let _ros = start("zenoh", &["--connect", &endpoint, "--listen", "tcp/127.0.0.1:0"]);
    let (node, echo) = (zenoh_session("peer", port, false), zenoh_session("peer", port, false));
    let b = book();
    let imu_ty = TopicType::of("sensor_msgs/msg/Imu").unwrap();
    let odom_ty = TopicType::of("nav_msgs/msg/Odometry").unwrap();
    let b2 = Arc::clone(&b);
    let _odom = node
        .declare_subscriber(topic_key(0, "/odometry/filtered", &odom_ty))
        .callback(move |s| {
            if let Ok(o) = decode_cdr::<Odometry<Ros2Header>>(&s.payload().to_bytes()) {
                on_odometry(&b2, &o);
            }
        })
        .wait()
        .unwrap();
    let pong_size = to_cdr(&odometry_like()).len();
    let e = echo.clone();
    let _echo = echo
        .declare_subscriber("bench/ping")
        .callback(move |s| {
            let mut pong = s.payload().to_bytes().to_vec();
            pong.resize(pong_size.max(16), 0);
            let _ = e.put("bench/pong", pong).wait();
        })
        .wait()
        .unwrap();
    let b3 = Arc::clone(&b);
    let _pong = node
        .declare_subscriber("bench/pong")
        .callback(move |s| {
            let sent = u64::from_le_bytes(s.payload().to_bytes()[..8].try_into().unwrap());
            let _ = b3.lock().unwrap().raw.record(now_ns() - sent);
        })
        .wait()
        .unwrap();
    let imu_key = topic_key(0, "/imu/data", &imu_ty);
    std::thread::sleep(Duration::from_secs(2));
    let leg = {
        let (d, n) = (domain.to_string(), ns.to_string());
        let until = Instant::now() + Duration::from_secs_f64(seconds + 1.0);
        std::thread::spawn(move || fusiond_leg(d, n, until))
    };
    paced(seconds, |i| {
        let stamp = wall_ns();
        let data = to_cdr(&imu(stamp));
        b.lock().unwrap().sent.insert(stamp, now_ns());
        let a = Attachment { sequence_number: i as i64 + 1, source_timestamp_ns: stamp as i64, gid: [7; 16] };
        node.put(&imu_key, data.clone()).attachment(a.to_bytes()).wait().unwrap();
        std::thread::sleep(Duration::from_micros(2500));
        let mut ping = now_ns().to_le_bytes().to_vec();
        ping.resize(data.len(), 0);
        node.put("bench/ping", ping).wait().unwrap();
    });
    std::thread::sleep(Duration::from_millis(500));
    report("rmw_zenoh", &b.lock().unwrap(), &leg.join().unwrap());
}

fn odometry_like() -> Odometry<Ros2Header> {
    use fusion_shared::ros::messages::{Pose, PoseWithCovariance, Twist, TwistWithCovariance};
    let v = Vector3 { x: 0.0, y: 0.0, z: 0.0 };
    Odometry {
        header: Ros2Header::at(0, "odom"),
        child_frame_id: "base_link".into(),
        pose: PoseWithCovariance {
            pose: Pose { position: v, orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 } },
            covariance: [[0.0; 6]; 6],
        },
        twist: TwistWithCovariance { twist: Twist { linear: v, angular: v }, covariance: [[0.0; 6]; 6] },
    }
}

fn dds_rows(seconds: f64, start: &dyn Fn(&str, &[&str]) -> Proc, domain: &str, ns: &str) {
    let lo = ["127.0.0.1".parse().unwrap()];
    let _ros = start("dds", &[]);
    let mut node = DdsNode::open("/", "bench_player", 0, &lo).unwrap();
    let mut echo = DdsNode::open("/", "bench_echo", 0, &lo).unwrap();
    let imu_pub = node.publisher::<Imu<Ros2Header>>("/imu/data", "sensor_msgs/msg/Imu", Qos::DEFAULT).unwrap();
    let odom = node.subscription::<Odometry<Ros2Header>>("/odometry/filtered", "nav_msgs/msg/Odometry", Qos::DEFAULT);
    let ping = node.publisher::<Imu<Ros2Header>>("/bench/ping", "sensor_msgs/msg/Imu", Qos::DEFAULT).unwrap();
    let pong = node.subscription::<Odometry<Ros2Header>>("/bench/pong", "nav_msgs/msg/Odometry", Qos::DEFAULT);
    let echo_in = echo.subscription::<Imu<Ros2Header>>("/bench/ping", "sensor_msgs/msg/Imu", Qos::DEFAULT).unwrap();
    let echo_out =
        echo.publisher::<Odometry<Ros2Header>>("/bench/pong", "nav_msgs/msg/Odometry", Qos::DEFAULT).unwrap();
    let (odom, pong) = (odom.unwrap(), pong.unwrap());
    let b = book();
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let (b2, s2) = (Arc::clone(&b), Arc::clone(&stop));
    let taker = std::thread::spawn(move || {
        // Blocks on the readers (a mio poll), as fusion-ros's own receiver
        // does: a spinning taker would take a core from fusiond.
        use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
        let (mut echo_in, mut odom, mut pong) = (echo_in, odom, pong);
        let mut poll = Poll::new().unwrap();
        poll.registry().register(&mut echo_in, Token(0), Interest::READABLE).unwrap();
        poll.registry().register(&mut odom, Token(1), Interest::READABLE).unwrap();
        poll.registry().register(&mut pong, Token(2), Interest::READABLE).unwrap();
        let mut events = Events::with_capacity(16);
        while !s2.load(std::sync::atomic::Ordering::Relaxed) {
            poll.poll(&mut events, Some(Duration::from_millis(50))).unwrap();
            while let Ok(Some((m, _))) = echo_in.take() {
                let mut o = odometry_like();
                o.header = m.header;
                let _ = echo_out.put(&o);
            }
            while let Ok(Some((o, _))) = odom.take() {
                on_odometry(&b2, &o);
            }
            while let Ok(Some((o, _))) = pong.take() {
                let sent = o.header.sec as u64 * 1_000_000_000 + u64::from(o.header.nanosec);
                let _ = b2.lock().unwrap().raw.record(now_ns() - sent);
            }
        }
    });
    std::thread::sleep(Duration::from_secs(3));
    let leg = {
        let (d, n) = (domain.to_string(), ns.to_string());
        let until = Instant::now() + Duration::from_secs_f64(seconds + 1.0);
        std::thread::spawn(move || fusiond_leg(d, n, until))
    };
    paced(seconds, |_| {
        let stamp = wall_ns();
        b.lock().unwrap().sent.insert(stamp, now_ns());
        let _ = imu_pub.put(&imu(stamp));
        std::thread::sleep(Duration::from_micros(2500));
        let _ = ping.put(&imu(now_ns()));
    });
    std::thread::sleep(Duration::from_millis(500));
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    taker.join().unwrap();
    report("DDS", &b.lock().unwrap(), &leg.join().unwrap());
}

fn report(middleware: &str, b: &Book, leg: &Histogram<u64>) {
    let ros = row(&format!("{middleware}: ROS Imu → its odometry"), &b.odometry);
    let raw = row(&format!("{middleware}: raw round trip"), &b.raw);
    let own = row("fusiond's leg (sample → snapshot)", leg);
    println!(
        "{middleware}: p50 {ros:.1} µs = {:.2} × (raw round trip + fusiond's leg = {:.1} µs); bound 1.5×",
        ros / (raw + own),
        raw + own
    );
}

fn main() {
    let seconds: f64 = std::env::var("FUSION_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let fusiond = std::env::var("FUSION_BENCH_FUSIOND")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../target/release/fusiond").into());
    assert!(
        std::path::Path::new(&fusiond).exists(),
        "{fusiond}: build it with `cargo build --release -p fusion-daemon`"
    );
    let dir = tempfile::tempdir().unwrap();
    println!("| row | n | p50 µs | p90 µs | p99 µs | max µs |\n|---|---|---|---|---|---|");
    for transport in ["zenoh", "dds"] {
        let (domain, ns) = (format!("rosbench{}x{transport}", std::process::id()), format!("rosbench_{transport}"));
        let path = dir.path().join(format!("{transport}.toml"));
        std::fs::write(&path, config(transport)).unwrap();
        let spawn = |bin: &str, args: Vec<String>| {
            Proc(
                Command::new(bin)
                    .args(args)
                    .env(DOMAIN_ENV, &domain)
                    // RustDDS warns of its own shutdown (locators, multicast groups).
                    .env("RUST_LOG", "warn,rustdds=off")
                    .stdout(Stdio::null())
                    .spawn()
                    .unwrap(),
            )
        };
        let conf = path.display().to_string();
        let _daemon =
            spawn(&fusiond, vec!["run".into(), "--namespace".into(), ns.clone(), "--config".into(), conf.clone()]);
        std::thread::sleep(Duration::from_secs(1));
        let start = |_: &str, extra: &[&str]| {
            let mut args = vec!["--namespace".to_string(), ns.clone(), "--config".into(), conf.clone()];
            args.extend(extra.iter().map(|s| s.to_string()));
            spawn(env!("CARGO_BIN_EXE_fusion-ros"), args)
        };
        match transport {
            "zenoh" => zenoh_rows(seconds, &start, &domain, &ns),
            _ => dds_rows(seconds, &start, &domain, &ns),
        }
    }
}
