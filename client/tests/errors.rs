//! The client's typed errors, against real iceoryx2 services in a private domain.

use fusion_client::{Client, ClientError, SampleKind};
use fusion_shared::service::{self, ServiceNames};
use iceoryx2::prelude::*;

mod common;
use common::remove_domain_files;

fn domain(tag: &str) -> String {
    format!("fc{}{tag}", std::process::id())
}

#[test]
fn a_reader_without_a_daemon_is_told_so() {
    let d = domain("nodaemon");
    let client = Client::connect_in_domain("quiet", Some(&d)).unwrap();
    match client.state_subscriber() {
        Err(ClientError::DaemonNotRunning { namespace }) => assert_eq!(namespace, "quiet"),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a reader without a daemon"),
    }
    // Publishers may start before the daemon: they reach nobody yet.
    let mut imu = client.imu_publisher(0).unwrap();
    assert_eq!(imu.publish(1, [0.0; 3], [0.0; 3]).unwrap(), 0);
    drop((imu, client));
    remove_domain_files(&d);
}

#[test]
fn another_wire_version_is_an_incompatible_version() {
    let d = domain("oldwire");
    let names = ServiceNames::new("mixed").unwrap();
    let node = service::create_node("old-peer", &service::iceoryx_config(Some(&d)).unwrap()).unwrap();
    // A peer built against the v1 wire types: the same size, the v1 type name.
    #[derive(Debug, Clone, Copy, ZeroCopySend)]
    #[type_name("fusion.ImuSample.v1")]
    #[repr(C)]
    struct ImuSampleV1 {
        t_ns: u64,
        sent_ns: u64,
        seq: u64,
        sensor: u32,
        _reserved: u32,
        accel_mps2: [f64; 3],
        gyro_radps: [f64; 3],
    }
    let name: ServiceName = names.samples(SampleKind::Imu).as_str().try_into().unwrap();
    let _old = node.service_builder(&name).publish_subscribe::<ImuSampleV1>().open_or_create().unwrap();
    let client = Client::connect_in_domain("mixed", Some(&d)).unwrap();
    match client.imu_publisher(0) {
        Err(ClientError::IncompatibleVersion { service }) => assert_eq!(service, "mixed/imu"),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("opened a service of another type"),
    }
    drop((client, _old, node));
    remove_domain_files(&d);
}

#[test]
fn an_unusable_namespace_is_an_error() {
    assert!(matches!(Client::connect("no spaces"), Err(ClientError::InvalidNamespace(_))));
}
