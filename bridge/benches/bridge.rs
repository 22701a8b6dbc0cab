//! What `fusion-bridge` adds to the snapshot stream: latency and throughput of
//! snapshots that cross Zenoh (two iceoryx2 domains, two bridges on loopback TCP)
//! beside the same snapshots read over shared memory in the publisher's domain.
//!
//! A stand-in for fusiond publishes `StateSnapshot`s (4208 B) on `<ns>/state` of
//! domain A, stamped with `publish_ns`, at 1 kHz and 10 kHz (10 kHz as bursts of
//! 10 every millisecond), and as fast as it can; a reader in domain A and a reader
//! in domain B (behind `--state out` and `--state in` bridges) each wait on the
//! state event and take `now − publish_ns` of every snapshot.
//!
//! `cargo bench -p fusion-bridge --bench bridge`;
//! `FUSION_BENCH_SECONDS` sets the seconds per rate (default 5);
//! `FUSION_BENCH_BRIDGE=PATH` runs that fusion-bridge binary (for A/B runs).

use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use fusion_client::Client;
use fusion_shared::service::{self, DOMAIN_ENV, ServiceNames};
use fusion_shared::{StateSnapshot, now_ns};
use hdrhistogram::Histogram;

struct Bridge(Child);

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
        let _ = self.0.wait();
    }
}

fn bridge(domain: &str, ns: &str, args: &[&str]) -> Bridge {
    Bridge(
        Command::new(
            std::env::var("FUSION_BENCH_BRIDGE").unwrap_or_else(|_| env!("CARGO_BIN_EXE_fusion-bridge").into()),
        )
        .args(["--namespace", ns])
        .args(args)
        .env(DOMAIN_ENV, domain)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .spawn()
        .expect("fusion-bridge runs"),
    )
}

/// What a reader saw: latencies (ns) and the count.
struct Seen {
    latency: Histogram<u64>,
    received: u64,
    first_ns: u64,
    last_ns: u64,
}

/// Reads snapshots in `domain` until `stop`, recording `now − publish_ns`.
fn read(domain: String, ns: String, stop: Arc<AtomicBool>, ready: Arc<AtomicBool>) -> Seen {
    let client = Client::connect_in_domain(&ns, Some(&domain)).unwrap();
    let mut reader = loop {
        match client.state_subscriber_with_buffer(service::STATE_BUFFER) {
            Ok(r) => break r,
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
        }
    };
    ready.store(true, Ordering::Relaxed);
    let mut seen = Seen { latency: Histogram::new(3).unwrap(), received: 0, first_ns: 0, last_ns: 0 };
    // The service's history (the last snapshot of the previous rate) comes
    // first: counted are the snapshots after the first warm-up one.
    let mut warmed = false;
    while !stop.load(Ordering::Relaxed) {
        if let Some(s) = reader.wait_next(Duration::from_millis(50)).unwrap() {
            let now = now_ns();
            if s.seq == u64::MAX {
                warmed = true;
                continue;
            }
            if !warmed {
                continue;
            }
            let _ = seen.latency.record(now.saturating_sub(s.publish_ns));
            seen.received += 1;
            if seen.first_ns == 0 {
                seen.first_ns = now;
            }
            seen.last_ns = now;
        }
    }
    seen
}

fn micros(ns: u64) -> String {
    format!("{:.1}", ns as f64 / 1e3)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let seconds: f64 = std::env::var("FUSION_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let id = std::process::id();
    let (domain_a, domain_b) = (format!("fbench{id}a"), format!("fbench{id}b"));
    let ns = format!("bridge-bench-{id}");
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("tcp/127.0.0.1:{port}");

    // The stand-in for fusiond: the state service of domain A, as fusiond opens it.
    let config = service::iceoryx_config(Some(&domain_a)).unwrap();
    let node = service::create_node("bridge-bench", &config).unwrap();
    let names = ServiceNames::new(&ns).unwrap();
    let state = service::state_service(&node, &names, Some(service::MAX_STATE_SUBSCRIBERS)).unwrap();
    let publisher = state.publisher_builder().create().unwrap();
    let notifier = service::event_service(&node, &names.state).unwrap().notifier_builder().create().unwrap();

    let _a = bridge(&domain_a, &ns, &["--listen", &endpoint, "--state", "out"]);
    let _b = bridge(&domain_b, &ns, &["--connect", &endpoint, "--state", "in"]);

    println!(
        "fusion-bridge: snapshots ({} B) over shared memory (domain A) and across Zenoh (A → bridge → TCP loopback → bridge → B)",
        std::mem::size_of::<StateSnapshot>()
    );
    println!("| rate | path | received / sent | p50 µs | p99 µs | max µs | rate received /s |");
    println!("|---|---|---|---|---|---|---|");
    let mut seq = 0u64;
    for rate in [1_000.0, 10_000.0, f64::INFINITY] {
        let stop = Arc::new(AtomicBool::new(false));
        let ready = [Arc::new(AtomicBool::new(false)), Arc::new(AtomicBool::new(false))];
        let readers: Vec<_> = [&domain_a, &domain_b]
            .iter()
            .zip(&ready)
            .map(|(d, r)| {
                let (d, n, s, r) = ((*d).clone(), ns.clone(), Arc::clone(&stop), Arc::clone(r));
                std::thread::spawn(move || read(d, n, s, r))
            })
            .collect();
        // Warm up until the far reader gets snapshots (the bridges are connected).
        let warm = Instant::now();
        while !ready.iter().all(|r| r.load(Ordering::Relaxed)) || warm.elapsed() < Duration::from_secs(2) {
            let snap = StateSnapshot { seq: u64::MAX, publish_ns: now_ns(), ..Default::default() };
            publisher.send_copy(snap).unwrap();
            let _ = notifier.notify();
            std::thread::sleep(Duration::from_millis(10));
        }
        let n = if rate.is_finite() { (rate * seconds) as u64 } else { (20_000.0 * seconds) as u64 };
        let start = Instant::now();
        for k in 0..n {
            if rate.is_finite() {
                // 1 kHz: one per ms; 10 kHz: 10 per ms.
                let per_ms = (rate / 1000.0) as u64;
                let due = start + Duration::from_millis(k / per_ms);
                while Instant::now() < due {
                    std::thread::sleep(due.saturating_duration_since(Instant::now()));
                }
            }
            let snap = StateSnapshot { seq, publish_ns: now_ns(), ..Default::default() };
            seq += 1;
            publisher.send_copy(snap).unwrap();
            let _ = notifier.notify();
        }
        let sent_s = start.elapsed().as_secs_f64();
        std::thread::sleep(Duration::from_secs(2));
        stop.store(true, Ordering::Relaxed);
        let label = if rate.is_finite() {
            format!("{} kHz", rate / 1000.0)
        } else {
            format!("flat out ({:.0}/s sent)", n as f64 / sent_s)
        };
        for (path, seen) in ["shared memory", "Zenoh bridge"].iter().zip(readers.into_iter().map(|r| r.join().unwrap()))
        {
            let span = (seen.last_ns.saturating_sub(seen.first_ns)) as f64 / 1e9;
            println!(
                "| {label} | {path} | {} / {n} | {} | {} | {} | {:.0} |",
                seen.received,
                micros(seen.latency.value_at_quantile(0.5)),
                micros(seen.latency.value_at_quantile(0.99)),
                micros(seen.latency.max()),
                if span > 0.0 { seen.received as f64 / span } else { 0.0 }
            );
        }
    }
    drop((publisher, notifier, state, node));
    service::remove_domain_counter_if_last(&config);
}
