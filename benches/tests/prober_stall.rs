//! A prober that was descheduled (CPU load) goes on without a burst: the late
//! rows of the latency bench failed now and then with "no snapshot for IMU
//! sample N" because a prober 300 ms behind sent the missed ticks back to back,
//! stamped a few µs apart, and fusiond's rate limit (10 kHz, bursts of 100)
//! rightly dropped them: their snapshots never came. Here the prober starts
//! 300 ms behind against a real fusiond loop over iceoryx2.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fusion_benches::latency::{EndToEnd, LINEAR_CONFIG, Mode, Pacer, Prober};
use fusion_client::Client;
use fusion_daemon::config::Config;
use fusion_daemon::ipc::{RunOptions, WaitMode, run};
use fusion_shared::service;

#[test]
fn a_prober_that_fell_behind_sends_no_burst() {
    let id = std::process::id();
    // SAFETY: set before any thread of this test binary reads the environment.
    unsafe { std::env::set_var(service::DOMAIN_ENV, format!("fs{id}")) };
    let namespace = format!("prober-stall-{id}");
    let config = Config::parse(LINEAR_CONFIG).unwrap();
    let options = RunOptions {
        namespace: namespace.clone(),
        wait: WaitMode::Event,
        summary_interval: Duration::from_secs(60),
        cpu: None,
        stall: None,
        config_text: None,
    };
    let shutdown = Arc::new(AtomicBool::new(false));
    let daemon = {
        let shutdown = Arc::clone(&shutdown);
        std::thread::spawn(move || run(&config, &options, &shutdown))
    };
    let client = loop {
        let c = Client::connect(&namespace).unwrap();
        if c.state_subscriber().is_ok() {
            break c;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut reader = client.state_subscriber().unwrap();
    let mut prober = Prober::new(&client, Mode::Event, ([0.0; 3], [0.0; 3])).unwrap();
    let mut out = EndToEnd::new();
    let result = prober.run_paced(400, 0, Pacer::behind(1000.0, Duration::from_millis(300)), &mut out);
    let limited =
        reader.latest().unwrap().map(|s| s.sensor_counters().iter().map(|c| c.counts.rate_limited).sum::<u64>());
    drop((prober, reader, client));
    shutdown.store(true, Ordering::Relaxed);
    daemon.join().unwrap().unwrap();
    result.unwrap();
    assert_eq!(limited, Some(0), "samples rate-limited");
    assert_eq!(out.latency.len(), 400);
}
