//! The front of `fusionctl foxglove`'s WebSocket server: the port clients
//! connect to, before the Foxglove SDK's server.
//!
//! The SDK speaks the Foxglove WebSocket protocol v1 under the subprotocol names
//! `foxglove.sdk.v1.1` and `foxglove.sdk.v1`, and answers HTTP 400 without a word
//! to a client that offers only the protocol's older name, `foxglove.websocket.v1`
//! (Lichtblick, Foxglove Studio before 2025), though it is the same protocol as
//! `foxglove.sdk.v1` (inline schemas). The front reads each connection's upgrade
//! request (RFC 6455 §4.1: an HTTP/1.1 request head), offers the SDK
//! `foxglove.sdk.v1` in place of the older name and gives the client back the
//! name it offered; a client that offers none of the three is logged with what
//! it offered, and gets the SDK's 400. Then it copies the bytes both ways.

use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// The protocol's older subprotocol name, served as [`SDK_V1`].
pub const OLD_V1: &str = "foxglove.websocket.v1";
/// The SDK's name of the same protocol.
pub const SDK_V1: &str = "foxglove.sdk.v1";
/// The subprotocols the SDK's server takes itself.
const SDK_NAMES: [&str; 2] = ["foxglove.sdk.v1.1", SDK_V1];
/// The longest request or response head read, bytes.
const MAX_HEAD: usize = 16 * 1024;

/// Accepts connections on `listener` until `stop`, passing each to the SDK's
/// server at `backend` (in threads of their own).
pub fn serve(listener: TcpListener, backend: SocketAddr, stop: Arc<AtomicBool>) -> std::io::Result<()> {
    listener.set_nonblocking(true)?;
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((client, peer)) => {
                std::thread::spawn(move || {
                    if let Err(e) = pass(client, peer, backend) {
                        eprintln!("fusionctl foxglove: connection from {peer}: {e}");
                    }
                });
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Reads a head (up to the blank line) from `stream`: the head, and the bytes
/// read after it.
fn read_head(stream: &mut TcpStream) -> std::io::Result<(String, Vec<u8>)> {
    let mut buf = Vec::with_capacity(2048);
    let mut chunk = [0u8; 2048];
    loop {
        if let Some(end) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            let rest = buf.split_off(end + 4);
            let head = String::from_utf8(buf).map_err(|_| std::io::Error::other("a head that is not text"))?;
            return Ok((head, rest));
        }
        if buf.len() > MAX_HEAD {
            return Err(std::io::Error::other("a head longer than 16 KiB"));
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "closed before its head ended"));
        }
        buf.extend_from_slice(&chunk[..n]);
    }
}

/// The subprotocols a request head offers (`Sec-WebSocket-Protocol`, any case,
/// every such header, comma-separated).
pub fn offered(head: &str) -> Vec<String> {
    head.lines()
        .filter_map(|l| l.split_once(':'))
        .filter(|(name, _)| name.trim().eq_ignore_ascii_case("sec-websocket-protocol"))
        .flat_map(|(_, value)| value.split(',').map(|p| p.trim().to_string()))
        .filter(|p| !p.is_empty())
        .collect()
}

/// `head` with the values of its `Sec-WebSocket-Protocol` headers replaced by `value`.
pub fn with_subprotocol(head: &str, value: &str) -> String {
    head.split_inclusive("\r\n")
        .map(|line| match line.split_once(':') {
            Some((name, _)) if name.trim().eq_ignore_ascii_case("sec-websocket-protocol") => {
                format!("{name}: {value}\r\n")
            }
            _ => line.to_string(),
        })
        .collect()
}

/// The answer to a request that is no WebSocket upgrade (a browser, `curl`):
/// HTTP 426 with a line saying what the port is and how to open it; `None`
/// for an upgrade request.
pub fn plain_http_answer(head: &str) -> Option<String> {
    let upgrade = head.lines().filter_map(|l| l.split_once(':')).any(|(name, value)| {
        name.trim().eq_ignore_ascii_case("upgrade") && value.trim().eq_ignore_ascii_case("websocket")
    });
    if upgrade {
        return None;
    }
    let host = head
        .lines()
        .filter_map(|l| l.split_once(':'))
        .find(|(name, _)| name.trim().eq_ignore_ascii_case("host"))
        .map_or("this host and port", |(_, value)| value.trim());
    let body = format!(
        "This is fusionctl foxglove: fusiond's state over the Foxglove WebSocket protocol, not a web page. In \
         Foxglove (or Lichtblick), open a connection, choose Foxglove WebSocket, and give ws://{host}\n"
    );
    Some(format!(
        "HTTP/1.1 426 Upgrade Required\r\nUpgrade: websocket\r\nContent-Type: text/plain; charset=utf-8\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    ))
}

/// One connection: the upgrade request (renamed if need be), the response
/// (named back), then the bytes both ways until either side closes.
fn pass(mut client: TcpStream, peer: SocketAddr, backend: SocketAddr) -> std::io::Result<()> {
    client.set_nonblocking(false)?;
    client.set_read_timeout(Some(Duration::from_secs(10)))?;
    let (head, rest) = read_head(&mut client)?;
    client.set_read_timeout(None)?;
    if let Some(answer) = plain_http_answer(&head) {
        client.write_all(answer.as_bytes())?;
        let _ = client.shutdown(Shutdown::Both);
        return Ok(());
    }
    let offered = offered(&head);
    let sdk = offered.iter().any(|p| SDK_NAMES.contains(&p.as_str()));
    let old = !sdk && offered.iter().any(|p| p == OLD_V1);
    if !sdk && !old {
        eprintln!(
            "fusionctl foxglove: refusing a client at {peer}: it offers the subprotocols [{}]; served are {}, {} \
             and {OLD_V1}",
            offered.join(", "),
            SDK_NAMES[0],
            SDK_NAMES[1]
        );
    }
    let mut server = TcpStream::connect(backend)?;
    let request = if old { with_subprotocol(&head, SDK_V1) } else { head };
    server.write_all(request.as_bytes())?;
    server.write_all(&rest)?;
    let (response, rest) = read_head(&mut server)?;
    let response = if old { with_subprotocol(&response, OLD_V1) } else { response };
    client.write_all(response.as_bytes())?;
    client.write_all(&rest)?;
    let (mut from_client, mut to_server) = (client.try_clone()?, server.try_clone()?);
    let upstream = std::thread::spawn(move || {
        let _ = std::io::copy(&mut from_client, &mut to_server);
        let _ = to_server.shutdown(Shutdown::Write);
    });
    let _ = std::io::copy(&mut server, &mut client);
    let _ = client.shutdown(Shutdown::Both);
    let _ = upstream.join();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const REQUEST: &str = "GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nsec-websocket-protocol: foxglove.websocket.v1, other\r\n\r\n";

    #[test]
    fn the_offered_subprotocols_are_read_and_renamed() {
        assert_eq!(offered(REQUEST), vec![OLD_V1.to_string(), "other".to_string()]);
        let renamed = with_subprotocol(REQUEST, SDK_V1);
        assert_eq!(offered(&renamed), vec![SDK_V1.to_string()]);
        assert!(renamed.starts_with("GET / HTTP/1.1\r\nHost: x\r\n") && renamed.ends_with("\r\n\r\n"));
        assert!(offered("GET / HTTP/1.1\r\n\r\n").is_empty());
    }

    #[test]
    fn a_plain_http_request_is_told_what_the_port_is() {
        assert_eq!(plain_http_answer(REQUEST), None);
        let answer = plain_http_answer("GET / HTTP/1.1\r\nHost: robot:8765\r\n\r\n").unwrap();
        assert!(answer.starts_with("HTTP/1.1 426 Upgrade Required\r\n"), "{answer}");
        let body = answer.split("\r\n\r\n").nth(1).unwrap();
        assert!(body.contains("Foxglove WebSocket") && body.contains("ws://robot:8765"), "{body}");
        assert!(answer.contains(&format!("Content-Length: {}\r\n", body.len())));
    }
}
