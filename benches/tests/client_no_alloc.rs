//! A `fusion-client` publisher allocates nothing per sample: loan, write, send
//! and the wake-up notification, with a live subscriber on the other end
//! (fusiond's service settings, `fusion_shared::transport::Ipc`).

use fusion_benches::alloc::{Counting, count_this_thread, sizes};
use fusion_client::{Client, ImuSample, PositionSample};
use fusion_shared::service::{self, ServiceNames};

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn publishing_a_sample_allocates_nothing() {
    let domain = format!("fc{}", std::process::id());
    let namespace = "client-alloc";
    // The daemon's side of the two sample services, on this thread.
    let config = service::iceoryx_config(Some(&domain)).unwrap();
    let node = service::create_node("alloc-test", &config).unwrap();
    let names = ServiceNames::new(namespace).unwrap();
    let imu_sub = service::sample_service::<ImuSample>(&node, &names).unwrap().subscriber_builder().create().unwrap();
    let pos_sub =
        service::sample_service::<PositionSample>(&node, &names).unwrap().subscriber_builder().create().unwrap();

    let client = Client::connect_in_domain(namespace, Some(&domain)).unwrap();
    let mut imu = client.imu_publisher(0).unwrap();
    let mut pos = client.position_publisher(1).unwrap();
    imu.set_wake(true);
    pos.set_wake(true);
    let mut received = 0u64;
    let mut publish = |k: u64| {
        let reached = imu.publish_sample(ImuSample::new(k, 0, k, [0.0; 3], [0.0; 3])).unwrap();
        assert_eq!(reached, 1, "the subscriber is connected");
        if k.is_multiple_of(10) {
            pos.publish_sample(PositionSample::new(k, 1, k, [0.0; 3], [0.0; 9])).unwrap();
        }
        while let Some(s) = imu_sub.receive().unwrap() {
            received += u64::from(s.header.seq == k);
        }
        while pos_sub.receive().unwrap().is_some() {}
    };
    for k in 0..100 {
        publish(k);
    }
    count_this_thread();
    let before = sizes();
    for k in 100..2100 {
        publish(k);
    }
    let after = sizes();
    assert_eq!(after, before, "allocations (size, count) while publishing 2000 IMU samples and 200 fixes");
    assert_eq!(received, 2100, "every sample arrived");
    // Every port and node goes before the domain's last file.
    drop((imu, pos, client, imu_sub, pos_sub, node));
    service::remove_domain_counter_if_last(&config);
}
