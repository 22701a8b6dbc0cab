//! `fusionctl foxglove` against a running fusiond: a WebSocket client speaking
//! the Foxglove protocol subscribes to the estimate and receives it.

mod common;

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain, publish_in_lockstep, workspace_bin};
use fusion_shared::recording;
use fusion_shared::service::DOMAIN_ENV;
use fusion_shared::{ImuSample, PositionSample, Sample};
use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

type Socket = WebSocket<MaybeTlsStream<TcpStream>>;

fn connect(port: u16) -> Socket {
    let mut request = format!("ws://127.0.0.1:{port}").into_client_request().unwrap();
    request.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut socket, response) = tungstenite::connect(request).unwrap();
    assert_eq!(response.headers()["Sec-WebSocket-Protocol"], "foxglove.sdk.v1");
    if let MaybeTlsStream::Plain(s) = socket.get_mut() {
        s.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    }
    socket
}

/// The next message, or `None` after the read timeout.
fn next(socket: &mut Socket) -> Option<Message> {
    match socket.read() {
        Ok(m) => Some(m),
        Err(tungstenite::Error::Io(e))
            if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) =>
        {
            None
        }
        Err(e) => panic!("websocket: {e}"),
    }
}

#[test]
fn a_foxglove_client_receives_the_live_estimate() {
    let domain = TestDomain::new("foxglove");
    let mut daemon = Daemon::start(&domain, &common::linear_config(Some(0.999)), "event");
    let mut server = Running(
        Command::new(workspace_bin("fusionctl"))
            .args(["foxglove", "--namespace", &domain.namespace, "--port", "0"])
            .env(DOMAIN_ENV, &domain.domain)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut line = String::new();
    BufReader::new(server.0.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let port: u16 = line.trim().rsplit(':').next().unwrap().parse().unwrap_or_else(|_| panic!("{line}"));

    // A plain HTTP request (a browser, curl) is told what the port is.
    let mut plain = TcpStream::connect(("127.0.0.1", port)).unwrap();
    std::io::Write::write_all(&mut plain, b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n").unwrap();
    let mut answer = String::new();
    std::io::Read::read_to_string(&mut plain, &mut answer).unwrap();
    assert!(answer.starts_with("HTTP/1.1 426") && answer.contains("Foxglove WebSocket"), "{answer}");

    // The channels are advertised; subscribe to the pose.
    let mut socket = connect(port);
    let deadline = Instant::now() + Duration::from_secs(10);
    let pose_channel = loop {
        assert!(Instant::now() < deadline, "no advertisement of {}", recording::POSE_TOPIC);
        let Some(Message::Text(text)) = next(&mut socket) else { continue };
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        if v["op"] != "advertise" {
            continue;
        }
        let channels = v["channels"].as_array().unwrap();
        if let Some(c) = channels.iter().find(|c| c["topic"] == recording::POSE_TOPIC) {
            assert_eq!(c["schemaName"], "foxglove.PoseInFrame");
            assert_eq!(c["encoding"], "json");
            break c["id"].as_u64().unwrap();
        }
    };
    let subscribe = serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": pose_channel}]});
    socket.send(Message::Text(subscribe.to_string().into())).unwrap();
    std::thread::sleep(Duration::from_millis(200)); // the subscription reaches the server

    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let mut samples: Vec<Sample> = (0..10u64)
        .map(|k| Sample::Imu(ImuSample::new(1_000_000_000 + k * 10_000_000, 0, k, [0.5, 0.0, 0.0], [0.0; 3])))
        .collect();
    let cov = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    samples.push(Sample::Position(PositionSample::new(1_095_000_000, 1, 0, [2.0, 1.0, 0.0], cov)));
    let last = *publish_in_lockstep(&client, &mut reader, &samples).last().unwrap();

    // Message data: opcode 1, subscription id, log time, the JSON pose.
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut poses = 0;
    loop {
        assert!(Instant::now() < deadline, "the last estimate never arrived ({poses} poses)");
        let Some(Message::Binary(data)) = next(&mut socket) else { continue };
        assert_eq!(data[0], 1, "message data");
        assert_eq!(u32::from_le_bytes(data[1..5].try_into().unwrap()), 7, "our subscription");
        let pose: serde_json::Value = serde_json::from_slice(&data[13..]).unwrap();
        poses += 1;
        let p = &pose["pose"]["position"];
        if p["x"].as_f64() == Some(last.x[0]) && p["y"].as_f64() == Some(last.x[1]) {
            // The timestamp is the estimate's time on the wall clock (a date
            // in Foxglove, not 1970): within a few ms of ours.
            let stamp = pose["timestamp"]["sec"].as_u64().unwrap() * 1_000_000_000
                + pose["timestamp"]["nsec"].as_u64().unwrap();
            let ours = last.t_ns + fusion_shared::time::wall_minus_monotonic_ns();
            assert!(stamp.abs_diff(ours) < 50_000_000, "pose at {stamp}, estimate at {ours} on the wall clock");
            break;
        }
    }
    assert!(poses > 1, "one pose per snapshot");

    // The subprotocols the server takes, as docs/recording.md says: the SDK's
    // two and the protocol's older name (Lichtblick, older Foxglove Studio),
    // answered with the name offered; another is refused (400) and logged.
    for (offered, accepted) in [
        ("foxglove.sdk.v1.1", true),
        ("foxglove.sdk.v1", true),
        ("foxglove.websocket.v1", true),
        ("bogus.protocol.v9", false),
    ] {
        let mut request = format!("ws://127.0.0.1:{port}").into_client_request().unwrap();
        request.headers_mut().insert("Sec-WebSocket-Protocol", offered.parse().unwrap());
        match tungstenite::connect(request) {
            Ok((mut s, response)) => {
                assert!(accepted, "{offered} was accepted");
                assert_eq!(response.headers()["Sec-WebSocket-Protocol"], offered);
                // The older name speaks the same protocol: the server's hello and advertisements.
                if let MaybeTlsStream::Plain(t) = s.get_mut() {
                    t.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
                }
                let Message::Text(hello) = s.read().unwrap() else { panic!("{offered}: no text message") };
                assert!(hello.contains("serverInfo"), "{offered}: {hello}");
                s.close(None).unwrap();
            }
            Err(tungstenite::Error::Http(response)) => {
                assert!(!accepted, "{offered} was refused");
                assert_eq!(response.status(), 400, "{offered}");
            }
            Err(e) => panic!("{offered}: {e}"),
        }
    }
    socket.close(None).unwrap();
    let _ = Command::new("kill").args(["-INT", &server.0.id().to_string()]).status();
    assert!(server.wait_for(Duration::from_secs(10)).expect("fusionctl foxglove did not stop").success());
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut server.0.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(stderr.contains("refusing a client") && stderr.contains("[bogus.protocol.v9]"), "{stderr}");
    assert_eq!(stderr.matches("refusing a client").count(), 1, "{stderr}");
    drop(reader);
    drop(client);
    assert!(daemon.terminate().success());
    assert!(domain.files().is_empty(), "left in /dev/shm: {:?}", domain.files());
}

/// In a namespace where no fusiond runs, the server says so within seconds
/// (it served an empty stream without a word), and says so again when one starts.
#[test]
fn a_server_without_fusiond_says_so() {
    let domain = TestDomain::new("foxglove-none");
    let mut server = Running(
        Command::new(workspace_bin("fusionctl"))
            .args(["foxglove", "--namespace", &domain.namespace, "--port", "0"])
            .env(DOMAIN_ENV, &domain.domain)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut stderr = BufReader::new(server.0.stderr.take().unwrap());
    let started = Instant::now();
    let mut line = String::new();
    stderr.read_line(&mut line).unwrap();
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    assert!(line.contains(&format!("no fusiond runs in namespace \"{}\"", domain.namespace)), "{line}");
    let mut daemon = Daemon::start(&domain, &common::linear_config(Some(0.999)), "event");
    line.clear();
    stderr.read_line(&mut line).unwrap();
    assert!(line.contains("fusiond is running in namespace") && line.contains("serving it"), "{line}");
    drop(server);
    assert!(daemon.terminate().success());
}
