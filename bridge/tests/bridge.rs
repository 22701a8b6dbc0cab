//! `fusion-bridge` between two "hosts" on one machine: two iceoryx2 domains
//! joined only by two bridges over Zenoh on loopback, with explicit endpoints
//! and no multicast scouting. fusiond and the sensors are the workspace's own
//! binaries, run with the daemon's test helpers.

#[path = "../../daemon/tests/common/mod.rs"]
mod common;

use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain};
use fusion_client::Client;
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{Sample, StateSnapshot, snapshot};

/// A free TCP port on loopback.
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// A bridge in `domain`'s iceoryx2 domain, its stderr to `log`.
fn bridge(domain: &TestDomain, namespace: &str, args: &[&str], log: &Path) -> Running {
    Running(
        Command::new(env!("CARGO_BIN_EXE_fusion-bridge"))
            .args(["--namespace", namespace, "--status-interval", "0.2"])
            .args(args)
            .env(DOMAIN_ENV, &domain.domain)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log).unwrap())
            .spawn()
            .unwrap(),
    )
}

fn wait_for_log(log: &Path, text: &str) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while !std::fs::read_to_string(log).unwrap_or_default().contains(text) {
        assert!(Instant::now() < deadline, "no {text:?} in {}", std::fs::read_to_string(log).unwrap_or_default());
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Reads snapshots until `n` arrived (or 30 s passed).
fn read_all(reader: &mut fusion_client::StateSubscriber, n: usize) -> Vec<StateSnapshot> {
    let mut out = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    while out.len() < n && Instant::now() < deadline {
        if let Some(s) = reader.wait_next(Duration::from_millis(100)).unwrap() {
            out.push(*s);
        }
    }
    out
}

/// Reads A's snapshots until one for each of `n` samples has come and the last
/// is settled: a late sample's correction lands in a snapshot of its own.
fn read_run(reader: &mut fusion_client::StateSubscriber, n: usize) -> Vec<StateSnapshot> {
    let mut out: Vec<StateSnapshot> = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    let inputs = |out: &[StateSnapshot]| out.iter().filter(|s| s.input_kind != snapshot::INPUT_NONE).count();
    while (inputs(&out) < n || out.last().is_some_and(|s| !s.settled())) && Instant::now() < deadline {
        if let Some(s) = reader.wait_next(Duration::from_millis(100)).unwrap() {
            out.push(*s);
        }
    }
    out
}

/// Host A runs fusiond; host B runs the sensors and a reader. The samples go
/// B → A and the snapshots A → B, each over its own bridge stream; the reader on
/// B receives every snapshot that a reader on A receives, in order, bit for bit.
#[test]
fn two_hosts_joined_by_zenoh_see_every_snapshot_bit_for_bit() {
    let (host_a, host_b) = (TestDomain::new("bridge-a"), TestDomain::new("bridge-b"));
    let ns = host_a.namespace.clone();
    let logs = tempfile::tempdir().unwrap();
    let mut daemon = Daemon::start(&host_a, &common::linear_config(Some(0.999)), "event");

    let port = free_port();
    let listen = format!("tcp/127.0.0.1:{port}");
    let log_a = logs.path().join("a.log");
    let log_b = logs.path().join("b.log");
    let mut bridge_a = bridge(&host_a, &ns, &["--listen", &listen, "--state", "out", "--samples", "in"], &log_a);
    let mut bridge_b = bridge(&host_b, &ns, &["--connect", &listen, "--state", "in", "--samples", "out"], &log_b);
    wait_for_log(&log_a, "fusion-bridge running");
    wait_for_log(&log_b, "fusion-bridge running");

    let client_a = Client::connect_in_domain(&ns, Some(&host_a.domain)).unwrap();
    let mut reader_a = client_a.state_subscriber_with_buffer(512).unwrap();
    // On host B, `<ns>/state` exists once bridge B has opened it.
    let client_b = Client::connect_in_domain(&ns, Some(&host_b.domain)).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut reader_b = loop {
        match client_b.state_subscriber_with_buffer(512) {
            Ok(r) => break r,
            Err(e) => assert!(Instant::now() < deadline, "no state service on host B: {e}"),
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    // The Zenoh peers found each other (and, a moment later, each other's
    // subscriptions); the sensors of B publish only then.
    wait_for_log(&log_a, "zenoh peers: 1");
    wait_for_log(&log_b, "zenoh peers: 1");
    std::thread::sleep(Duration::from_secs(1));

    let mut c = ScenarioConfig { seed: 31, duration_s: 1.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    let samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let mut publishers = fusion_client::SensorPublishers::all(&client_b).unwrap();
    for s in &samples {
        publishers.publish(*s).unwrap();
        std::thread::sleep(Duration::from_micros(300));
    }

    let on_a = read_run(&mut reader_a, samples.len());
    let on_b = read_all(&mut reader_b, on_a.len());
    let inputs = on_a.iter().filter(|s| s.input_kind != snapshot::INPUT_NONE).count();
    assert_eq!(inputs, samples.len(), "fusiond on A processed every sample sent on B");
    assert!(on_a.last().unwrap().settled(), "the last correction landed");
    assert_eq!(on_b.len(), on_a.len(), "B received every snapshot of A");
    for (i, (a, b)) in on_a.iter().zip(&on_b).enumerate() {
        assert!(
            common::snapshot_bytes(a) == common::snapshot_bytes(b),
            "snapshot {i} differs (seq {} vs {})",
            a.seq,
            b.seq
        );
    }
    assert!(on_b.windows(2).all(|w| w[1].seq == w[0].seq + 1), "in order, none missing");
    let fused: u64 = on_b.last().unwrap().sensor_counters().iter().map(|c| c.counts.fused).sum();
    assert!(fused > 5, "fixes fused: {fused}");

    // fusiond may publish more after the run (a stream going stale changes the
    // health; the last snapshot comes at shutdown): stop it first, then the
    // bridges, and B re-published every snapshot A forwarded.
    assert!(daemon.terminate().success());
    drop(daemon);
    drop((reader_a, reader_b, publishers, client_a, client_b));
    std::thread::sleep(Duration::from_millis(500));
    for (bridge, log) in [(&mut bridge_a, &log_a), (&mut bridge_b, &log_b)] {
        let status = bridge.stop(Duration::from_secs(10));
        assert!(status.is_some_and(|s| s.success()), "{}", std::fs::read_to_string(log).unwrap());
    }
    let (log_a, log_b) = (std::fs::read_to_string(&log_a).unwrap(), std::fs::read_to_string(&log_b).unwrap());
    let forwarded = |log: &str, stream: &str| -> u64 {
        let line = log.lines().rev().find(|l| l.contains(&format!("{stream}: forwarded "))).unwrap_or_default();
        let after = line.split(&format!("{stream}: forwarded ")).nth(1).unwrap_or_default();
        after.split(',').next().and_then(|n| n.parse().ok()).unwrap_or_else(|| panic!("no {stream} count in {log}"))
    };
    // Zenoh's own start-up warning (the bridge reports unreachable peers itself).
    for log in [&log_a, &log_b] {
        assert!(!log.contains("Scouting delay elapsed"), "{log}");
    }
    let (out_a, in_b) = (forwarded(&log_a, "state out"), forwarded(&log_b, "state in"));
    assert!(out_a >= on_b.len() as u64, "A forwarded {out_a} snapshots, B read {}", on_b.len());
    assert_eq!(in_b, out_a, "B re-published every snapshot A forwarded: {log_b}");
    assert!(log_b.contains(&format!("state in: forwarded {in_b}, refused 0, gaps 0")), "{log_b}");
    let n = samples.len();
    assert!(log_b.contains(&format!("samples out: forwarded {n}, refused 0")), "{log_b}");
    assert_eq!(forwarded(&log_a, "samples in"), n as u64, "{log_a}");
    assert!(host_a.files().is_empty(), "{:?}", host_a.files());
    assert!(host_b.files().is_empty(), "{:?}", host_b.files());
}

/// A snapshot of another wire version (or size) reaching a bridge is refused,
/// counted and named; the good ones around it still reach the readers.
#[test]
fn a_bridge_refuses_a_snapshot_of_another_version() {
    use zenoh::Wait;
    let host_b = TestDomain::new("bridge-v");
    let ns = host_b.namespace.clone();
    let logs = tempfile::tempdir().unwrap();
    let port = free_port();
    let listen = format!("tcp/127.0.0.1:{port}");
    let log_b = logs.path().join("b.log");
    let mut bridge_b = bridge(&host_b, &ns, &["--listen", &listen, "--state", "in"], &log_b);
    wait_for_log(&log_b, "fusion-bridge running");

    // A Zenoh peer of this test's own, in place of a bridge of another version.
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", "\"peer\"").unwrap();
    config.insert_json5("connect/endpoints", &format!("[\"{listen}\"]")).unwrap();
    config.insert_json5("scouting/multicast/enabled", "false").unwrap();
    let session = zenoh::open(config).wait().unwrap();
    let key = format!("fusion/{ns}/state");
    let octets = zenoh::bytes::Encoding::APPLICATION_OCTET_STREAM;
    let client_b = Client::connect_in_domain(&ns, Some(&host_b.domain)).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut reader = loop {
        if let Ok(r) = client_b.state_subscriber() {
            break r;
        }
        assert!(Instant::now() < deadline, "no state service from the bridge");
        std::thread::sleep(Duration::from_millis(20));
    };
    wait_for_log(&log_b, "zenoh peers: 1");
    std::thread::sleep(Duration::from_secs(1));

    let good = |seq: u64| StateSnapshot { seq, t_ns: 1000 + seq, ..Default::default() };
    let put = |payload: Vec<u8>, schema: &str| {
        session.put(key.clone(), payload).encoding(octets.clone().with_schema(schema)).wait().unwrap();
    };
    // SAFETY: `type_name` reads a constant (unsafe only for its implementors).
    let current = unsafe { <StateSnapshot as iceoryx2::prelude::ZeroCopySend>::type_name() };
    put(common::snapshot_bytes(&good(0)).to_vec(), current);
    put(common::snapshot_bytes(&good(1)).to_vec(), "fusion.StateSnapshot.v6");
    put(common::snapshot_bytes(&good(2))[..4000].to_vec(), current);
    put(common::snapshot_bytes(&good(3)).to_vec(), current);
    let got = read_all(&mut reader, 2);
    assert_eq!(got.iter().map(|s| s.seq).collect::<Vec<_>>(), [0, 3]);
    assert!(reader.wait_next(Duration::from_millis(300)).unwrap().is_none(), "nothing else came through");

    drop((reader, client_b));
    let _ = session.close().wait();
    assert!(bridge_b.stop(Duration::from_secs(10)).is_some_and(|s| s.success()));
    let log = std::fs::read_to_string(&log_b).unwrap();
    assert!(log.contains("state in: forwarded 2, refused 2, gaps 2"), "{log}");
    assert!(log.contains(&format!("fusion.StateSnapshot.v6 (expected application/octet-stream;{current})")), "{log}");
    let expected = format!("4000 bytes (expected {})", std::mem::size_of::<StateSnapshot>());
    assert!(log.contains(&expected), "{log}");
    assert!(host_b.files().is_empty(), "{:?}", host_b.files());
}

#[test]
fn bad_arguments_are_refused_before_anything_starts() {
    let domain = TestDomain::new("bridge-args");
    for (args, reason) in [
        (&["--listen", "tcp/127.0.0.1:1"][..], "nothing to forward"),
        (&["--state", "out"][..], "no peers"),
        (&["--state", "out", "--listen", "carrier-pigeon/x"][..], "transport carrier-pigeon is not built in"),
        (
            &["--samples", "in", "--listen", "tcp/127.0.0.1:1", "--kinds", "imu,sonar"][..],
            "unknown sample kind \"sonar\"",
        ),
        (&["--state", "in", "--listen", "tcp/127.0.0.1:1", "--namespace", "a/b"][..], "invalid namespace"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_fusion-bridge"))
            .args(args)
            .env(DOMAIN_ENV, &domain.domain)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        // A usage error: status 2, clap's format, before anything started.
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: ") && err.lines().next().unwrap().contains(reason), "{args:?}: {err}");
    }
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

#[test]
fn an_endpoint_that_cannot_be_opened_is_a_failure_on_one_line() {
    let domain = TestDomain::new("bridge-busy");
    // The port is taken: the arguments are valid, the job cannot be done.
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let endpoint = format!("tcp/127.0.0.1:{}", taken.local_addr().unwrap().port());
    let out = Command::new(env!("CARGO_BIN_EXE_fusion-bridge"))
        .args(["--state", "out", "--listen", &endpoint])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("fusion-bridge: cannot open the Zenoh session: "), "{err}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// `--connect` to an endpoint where no bridge listens: the bridge says within
/// seconds that it reaches no peer (it only ever said "forwarded 0").
#[test]
fn an_unreachable_peer_is_reported() {
    let domain = TestDomain::new("bridge-unreached");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bridge.log");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let started = Instant::now();
    let b = bridge(&domain, &domain.namespace, &["--state", "in", "--connect", &endpoint], &log);
    wait_for_log(&log, "no Zenoh peer reached after 5 s");
    assert!(started.elapsed() < Duration::from_secs(20), "{:?}", started.elapsed());
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains(&endpoint));
    // The bridge's own warning, not Zenoh's vaguer one besides.
    assert!(!text.contains("Scouting delay elapsed"), "{text}");
    drop(b);
}
