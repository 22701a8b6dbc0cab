//! The state subscriber against real iceoryx2 services in a private domain, with
//! this test in fusiond's place.

use std::time::Duration;

use fusion_client::Client;
use fusion_shared::service::{self, ServiceNames};
use iceoryx2::service::port_factory::PortFactory;

mod common;
use common::remove_domain_files;

#[test]
fn a_polling_reader_adds_no_listener_and_a_waiting_one_does() {
    let domain = format!("fc{}listen", std::process::id());
    let names = ServiceNames::new("readers").unwrap();
    let node = service::create_node("stand-in-daemon", &service::iceoryx_config(Some(&domain)).unwrap()).unwrap();
    let _state = service::state_service(&node, &names, Some(service::MAX_STATE_SUBSCRIBERS)).unwrap();
    let event = service::event_service(&node, &names.state).unwrap();
    let listeners = || event.dynamic_config().number_of_listeners();

    let client = Client::connect_in_domain("readers", Some(&domain)).unwrap();
    let mut reader = client.state_subscriber().unwrap();
    assert!(reader.try_next().unwrap().is_none());
    assert!(reader.latest().unwrap().is_none());
    assert!(reader.spin_next(Duration::from_millis(1)).unwrap().is_none());
    // fusiond notifies every listener after every snapshot: a reader that only
    // polls must not cost it that.
    assert_eq!(listeners(), 0, "a polling reader has no listener");
    assert!(reader.wait_next(Duration::from_millis(1)).unwrap().is_none());
    assert_eq!(listeners(), 1, "a waiting reader sleeps on the event");
    drop(reader);
    assert_eq!(listeners(), 0);

    drop((client, event, _state, node));
    remove_domain_files(&domain);
}
