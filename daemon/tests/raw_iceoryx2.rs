//! A process that uses plain iceoryx2 (`ipc::Service`, not fusion-client) talks
//! to fusiond: fusiond's ports use `fusion_shared::transport::Ipc`, iceoryx2's
//! `ipc` service with pooled loan state, and that must not change what is in
//! shared memory. The raw side publishes samples, wakes the daemon through its
//! event service, and reads the snapshots, which must be replay's estimates.

mod common;

use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, triggered_by};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::service::{ServiceNames, iceoryx_config};
use fusion_shared::{ImuSample, PositionSample, Sample, SampleKind, StateSnapshot, now_ns};
use iceoryx2::prelude::*;

#[test]
fn a_plain_iceoryx2_process_feeds_and_reads_the_daemon() {
    let domain = TestDomain::new("raw");
    let config = common::linear_config(Some(0.999));
    let mut daemon = Daemon::start(&domain, &config, "event");

    let names = ServiceNames::new(&domain.namespace).unwrap();
    let node = NodeBuilder::new()
        .config(&iceoryx_config(Some(&domain.domain)).unwrap())
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .unwrap();
    let open = |name: &str| ServiceName::new(name).unwrap();
    let imu =
        node.service_builder(&open(&names.samples(SampleKind::Imu))).publish_subscribe::<ImuSample>().open().unwrap();
    let imu = imu.publisher_builder().create().unwrap();
    let position = node
        .service_builder(&open(&names.samples(SampleKind::Position)))
        .publish_subscribe::<PositionSample>()
        .open()
        .unwrap();
    let position = position.publisher_builder().create().unwrap();
    let wake = node.service_builder(&open(&names.wake)).event().open().unwrap().notifier_builder().create().unwrap();
    let state = node.service_builder(&open(&names.state)).publish_subscribe::<StateSnapshot>().open().unwrap();
    let state = state.subscriber_builder().buffer_size(16).create().unwrap();

    let mut c = ScenarioConfig { seed: 11, duration_s: 1.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    let samples: Vec<Sample> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let mut last = None;
    for s in &samples {
        let mut s = *s;
        s.header_mut().sent_ns = now_ns();
        match s {
            Sample::Imu(x) => imu.send_copy(x).map(drop).unwrap(),
            Sample::Position(x) => position.send_copy(x).map(drop).unwrap(),
            other => unreachable!("the scenario has IMU and position sensors only: {other:?}"),
        }
        wake.notify().unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        last = loop {
            assert!(Instant::now() < deadline, "no snapshot for {s:?}");
            match state.receive().unwrap() {
                Some(snap) if triggered_by(&snap, &s) => break Some(*snap),
                Some(_) => {}
                None => std::thread::sleep(Duration::from_micros(200)),
            }
        };
    }
    let last = last.unwrap();

    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.jsonl");
    common::write_input(&input, &Scenario::generate(&c));
    let (lines, _) = common::run_replay(dir.path(), &config, &input, false);
    let expected = lines.last().unwrap();
    assert_eq!((last.t_ns, last.sample_seq), (expected.t_ns, expected.seq));
    assert_eq!(last.state(), &expected.x[..], "the raw-fed daemon's estimate is replay's");
    assert!(daemon.terminate().success());
}
