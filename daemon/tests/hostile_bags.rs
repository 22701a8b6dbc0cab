//! Hostile and damaged ROS bags, each written here, against `fusiond replay`
//! and `fusion-sim run --input`, each run in 1 GiB of address space: a clear
//! error or the damage named, what came before it kept, never an abort or a
//! hang. The sizes a file declares are checked before anything is allocated
//! (ROS 1 chunks, CDR strings), leftover bytes are refused, duplicates found,
//! an SQLite read bounded, rosbag2's per-message compression read, and a stamp
//! far ahead refused by both tools alike.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::live::workspace_bin;
use fusion_shared::service::DOMAIN_ENV;

/// The ground-robot page's configuration for robot_localization's test2 bag
/// (its topics are the ones the bags here use).
fn jackal() -> String {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/ground-robots.md")).unwrap();
    let start = page.find("```toml\n# jackal.toml").unwrap() + "```toml\n".len();
    let end = start + page[start..].find("```").unwrap();
    page[start..end].to_string()
}

#[path = "hostile_bags/clocks.rs"]
mod clocks;
#[path = "hostile_bags/drivers.rs"]
mod drivers;

const IMU_TOPIC: &str = "/imu/data";
const ODOM_TOPIC: &str = "/jackal_velocity_controller/odom";

/// 1 GiB of address space: a reader that believes a declared size aborts.
const ADDRESS_SPACE: &str = "--as=1073741824";

/// Runs `fusiond replay` on `bag` within [`ADDRESS_SPACE`] (and a hang guard).
fn replay(dir: &Path, bag: &Path) -> Output {
    replay_with(dir, bag, &jackal())
}

/// [`replay`] with the configuration `config`.
fn replay_with(dir: &Path, bag: &Path, config: &str) -> Output {
    let config_text = config;
    let config = dir.join("config.toml");
    std::fs::write(&config, config_text).unwrap();
    let out = Command::new("prlimit")
        .args([ADDRESS_SPACE, "--", "timeout", "120"])
        .arg(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--config"])
        .arg(&config)
        .arg("--input")
        .arg(bag)
        .arg("--output")
        .arg(dir.join("out.jsonl"))
        .output()
        .unwrap();
    assert_ended_itself(&out, "fusiond replay");
    out
}

/// Runs `fusion-sim run --input bag` (with no fusiond: `--allow-no-daemon`)
/// within [`ADDRESS_SPACE`].
fn sim(dir: &Path, bag: &Path) -> Output {
    let config = dir.join("config.toml");
    std::fs::write(&config, jackal()).unwrap();
    let out = Command::new("prlimit")
        .args([ADDRESS_SPACE, "--", "timeout", "120"])
        .arg(workspace_bin("fusion-sim"))
        .args(["run", "--allow-no-daemon", "--namespace", &format!("hostile-bags-{}", std::process::id())])
        .arg("--config")
        .arg(&config)
        .arg("--input")
        .arg(bag)
        .env(DOMAIN_ENV, format!("hb{}", std::process::id()))
        .output()
        .unwrap();
    assert_ended_itself(&out, "fusion-sim run");
    out
}

/// Neither a signal (an abort) nor the hang guard's 124 ended it.
fn assert_ended_itself(out: &Output, what: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code().is_some_and(|c| c != 124), "{what}: {:?}\n{stderr}", out.status);
    assert!(!stderr.contains("panicked") && !stderr.contains("memory allocation"), "{what}: {stderr}");
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The estimates `fusiond replay` wrote.
fn lines(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("out.jsonl")).unwrap_or_default().lines().map(String::from).collect()
}

// --- Messages -------------------------------------------------------------

/// A robot at rest: an IMU message every 10 ms, an odometry message every 50 ms.
fn messages(n: u32) -> Vec<(&'static str, u64)> {
    let mut m = Vec::new();
    for i in 0..n {
        let t = 1_000_000_000 + u64::from(i) * 10_000_000;
        m.push((IMU_TOPIC, t));
        if i % 5 == 0 {
            m.push((ODOM_TOPIC, t));
        }
    }
    m
}

const VAR3: [f64; 9] = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4];

fn var6() -> [f64; 36] {
    let mut c = [0.0; 36];
    for i in 0..6 {
        c[i * 7] = 1e-3;
    }
    c
}

/// Little-endian writer of ROS 1 serialisation.
#[derive(Default)]
struct Ros1Writer(Vec<u8>);

impl Ros1Writer {
    fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn f64s(&mut self, v: &[f64]) -> &mut Self {
        v.iter().for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
        self
    }
    fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
        self
    }
    fn header(&mut self, t: u64) -> &mut Self {
        self.u32(0).u32((t / 1_000_000_000) as u32).u32((t % 1_000_000_000) as u32).string("base_link")
    }
}

/// A ROS 1 message of `topic` at `t`.
fn ros1_message(topic: &str, t: u64) -> Vec<u8> {
    let mut w = Ros1Writer::default();
    w.header(t);
    if topic == IMU_TOPIC {
        w.f64s(&[0.0, 0.0, 0.0, 1.0]).f64s(&VAR3).f64s(&[0.0; 3]).f64s(&VAR3).f64s(&[0.0, 0.0, 9.80665]).f64s(&VAR3);
    } else {
        w.string("base_link").f64s(&[0.0; 3]).f64s(&[0.0, 0.0, 0.0, 1.0]).f64s(&var6()).f64s(&[0.0; 6]).f64s(&var6());
    }
    w.0
}

#[derive(serde::Serialize)]
struct Stamp(i32, u32);
#[derive(serde::Serialize)]
struct Header(Stamp, String);
#[derive(serde::Serialize)]
struct Imu(Header, [f64; 4], [f64; 9], [f64; 3], [f64; 9], [f64; 3], [f64; 9]);
#[derive(serde::Serialize)]
struct Odometry(Header, String, [f64; 7], Vec36, [f64; 6], Vec36);
/// 36 numbers (serde's arrays stop at 32): a tuple of a 32 and a 4.
#[derive(serde::Serialize)]
struct Vec36([f64; 32], [f64; 4]);

fn vec36(v: [f64; 36]) -> Vec36 {
    Vec36(v[..32].try_into().unwrap(), v[32..].try_into().unwrap())
}

/// A ROS 2 message (CDR, little-endian, written by the `cdr` crate: another
/// encoder than fusiond's reader) of `topic` at `t`.
fn cdr_message(topic: &str, t: u64) -> Vec<u8> {
    let header = Header(Stamp((t / 1_000_000_000) as i32, (t % 1_000_000_000) as u32), "base_link".into());
    if topic == IMU_TOPIC {
        let m = Imu(header, [0.0, 0.0, 0.0, 1.0], VAR3, [0.0; 3], VAR3, [0.0, 0.0, 9.80665], VAR3);
        cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap()
    } else {
        let pose = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let m = Odometry(header, "base_link".into(), pose, vec36(var6()), [0.0; 6], vec36(var6()));
        cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap()
    }
}

fn ros_type(topic: &str, ros2: bool) -> &'static str {
    match (topic == IMU_TOPIC, ros2) {
        (true, false) => "sensor_msgs/Imu",
        (true, true) => "sensor_msgs/msg/Imu",
        (false, false) => "nav_msgs/Odometry",
        (false, true) => "nav_msgs/msg/Odometry",
    }
}

// --- ROS 1 bags -----------------------------------------------------------

fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = ((name.len() + 1 + value.len()) as u32).to_le_bytes().to_vec();
    f.extend_from_slice(name.as_bytes());
    f.push(b'=');
    f.extend_from_slice(value);
    f
}

fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
    let header: Vec<u8> = fields.iter().flat_map(|(n, v)| field(n, v)).collect();
    let mut r = (header.len() as u32).to_le_bytes().to_vec();
    r.extend_from_slice(&header);
    r.extend_from_slice(&(data.len() as u32).to_le_bytes());
    r.extend_from_slice(data);
    r
}

fn connection(id: u32, topic: &str) -> Vec<u8> {
    // The types' MD5 sums, as `rosbag` writes them (32 hexadecimal digits).
    let md5: &[u8] =
        if topic == IMU_TOPIC { b"6a62c6daae103f4ff57a132d6f95cec2" } else { b"cd5e73d190d741a2f92e81eda573aca7" };
    let data: Vec<u8> = [
        ("topic", topic.as_bytes()),
        ("type", ros_type(topic, false).as_bytes()),
        ("md5sum", md5),
        ("message_definition", b""),
    ]
    .iter()
    .flat_map(|(n, v)| field(n, v))
    .collect();
    record(&[("op", &[0x07]), ("conn", &id.to_le_bytes()), ("topic", topic.as_bytes())], &data)
}

/// A chunk of a ROS 1 bag: its compression name, the size it declares
/// (`None`: its true size), and its messages (topic, stamp, bytes).
struct Chunk1 {
    compression: &'static str,
    declared: Option<u32>,
    messages: Vec<(&'static str, u64, Vec<u8>)>,
}

/// A ROS 1 bag (format 2.0) of `chunks`, with its index: connection records
/// and chunk infos after the chunk section, as `rosbag record` writes them.
fn ros1_bag(chunks: &[Chunk1]) -> Vec<u8> {
    let topics = [IMU_TOPIC, ODOM_TOPIC];
    let conn = |topic: &str| topics.iter().position(|t| *t == topic).unwrap() as u32;
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    let header_at = out.len();
    let bag_header = |index_pos: u64| {
        let fields: [(&str, &[u8]); 4] = [
            ("op", &[0x03]),
            ("index_pos", &index_pos.to_le_bytes()),
            ("conn_count", &2u32.to_le_bytes()),
            ("chunk_count", &(chunks.len() as u32).to_le_bytes()),
        ];
        record(&fields, &[b' '; 64])
    };
    out.extend(bag_header(0));
    let mut infos = Vec::new();
    for chunk in chunks {
        let mut data = Vec::new();
        for topic in topics {
            data.extend(connection(conn(topic), topic));
        }
        for (topic, t, bytes) in &chunk.messages {
            let time =
                [((t / 1_000_000_000) as u32).to_le_bytes(), ((t % 1_000_000_000) as u32).to_le_bytes()].concat();
            data.extend(record(&[("op", &[0x02]), ("conn", &conn(topic).to_le_bytes()), ("time", &time)], bytes));
        }
        let size = chunk.declared.unwrap_or(data.len() as u32);
        let at = out.len() as u64;
        out.extend(record(
            &[("op", &[0x05]), ("compression", chunk.compression.as_bytes()), ("size", &size.to_le_bytes())],
            &data,
        ));
        infos.push((at, chunk.messages.first().map_or(0, |m| m.1), chunk.messages.last().map_or(0, |m| m.1)));
    }
    let index_pos = out.len() as u64;
    for topic in topics {
        out.extend(connection(conn(topic), topic));
    }
    for (at, start, end) in infos {
        let time =
            |t: u64| [((t / 1_000_000_000) as u32).to_le_bytes(), ((t % 1_000_000_000) as u32).to_le_bytes()].concat();
        let fields: [(&str, &[u8]); 5] = [
            ("op", &[0x06]),
            ("ver", &1u32.to_le_bytes()),
            ("chunk_pos", &at.to_le_bytes()),
            ("start_time", &time(start)),
            ("end_time", &time(end)),
        ];
        let mut fields = fields.to_vec();
        fields.push(("count", &[0, 0, 0, 0]));
        out.extend(record(&fields, &[]));
    }
    let header = bag_header(index_pos);
    out[header_at..header_at + header.len()].copy_from_slice(&header);
    out
}

fn ros1_chunk(messages: &[(&'static str, u64)]) -> Chunk1 {
    Chunk1 {
        compression: "none",
        declared: None,
        messages: messages.iter().map(|&(topic, t)| (topic, t, ros1_message(topic, t))).collect(),
    }
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn a_clean_ros1_bag_written_here_replays() {
    let dir = tempfile::tempdir().unwrap();
    let m = messages(200);
    let bag = write(dir.path(), "clean.bag", &ros1_bag(&[ros1_chunk(&m[..100]), ros1_chunk(&m[100..])]));
    let out = replay(dir.path(), &bag);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(lines(dir.path()).len(), m.len() + 200, "one estimate per sample (IMU and attitude each)");
}

/// A compressed chunk whose header claims 4 GiB decompressed (the `rosbag`
/// crate reserved it and aborted): the chunk before it is read, the damage
/// named, exit status 4.
#[test]
fn a_ros1_chunk_that_claims_4_gib_is_refused_before_anything_is_allocated() {
    let dir = tempfile::tempdir().unwrap();
    let m = messages(200);
    for compression in ["lz4", "bz2"] {
        let hostile = Chunk1 {
            compression,
            declared: Some(u32::MAX),
            messages: vec![(IMU_TOPIC, 3_000_000_000, vec![0x5a; 4096])],
        };
        let bag = write(dir.path(), &format!("{compression}.bag"), &ros1_bag(&[ros1_chunk(&m), hostile]));
        let out = replay(dir.path(), &bag);
        let said = stderr(&out);
        assert_eq!(out.status.code(), Some(4), "{compression}: {said}");
        assert!(said.contains("4294967295 bytes decompressed") && said.contains("the bag is damaged"), "{said}");
        assert_eq!(lines(dir.path()).len(), m.len() + 200, "{compression}: the chunk before it, whole");
        let out = sim(dir.path(), &bag);
        let said = stderr(&out);
        assert_eq!(out.status.code(), Some(4), "fusion-sim, {compression}: {said}");
        assert!(said.contains("4294967295 bytes decompressed") && said.contains("published what comes before it"));
    }
}

/// A message with the same bytes as one before it (its stamp among them) is a
/// duplicate: counted so, fused once.
#[test]
fn a_byte_identical_duplicate_is_counted_as_one_not_fused_twice() {
    let dir = tempfile::tempdir().unwrap();
    let m = messages(100);
    let mut chunk = ros1_chunk(&m);
    let imu = chunk.messages.iter().position(|x| x.0 == IMU_TOPIC && x.1 == 1_300_000_000).unwrap();
    let odom = chunk.messages.iter().position(|x| x.0 == ODOM_TOPIC && x.1 == 1_500_000_000).unwrap();
    let (imu_copy, odom_copy) = (chunk.messages[imu].clone(), chunk.messages[odom].clone());
    chunk.messages.insert(odom + 1, odom_copy);
    chunk.messages.insert(imu + 1, imu_copy);
    let bag = write(dir.path(), "twice.bag", &ros1_bag(&[chunk]));
    let out = replay(dir.path(), &bag);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains(&format!("{IMU_TOPIC} (sensor_msgs/Imu): 101 messages")), "{said}");
    assert_eq!(said.matches("1 duplicates (the same bytes as an earlier message)").count(), 2, "{said}");
    assert!(said.contains("duplicates 3,"), "the imu's, its attitude's and the odometry's copies: {said}");
    assert_eq!(lines(dir.path()).len(), m.len() + 100, "each copy processed once");
}

// --- ROS 2 bags -----------------------------------------------------------

/// A ROS 2 bag in MCAP of `(topic, stamp, bytes)`.
fn mcap_bag(path: &Path, messages: &[(&str, u64, Vec<u8>)]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").create(file).unwrap();
    let mut channels = std::collections::HashMap::new();
    for topic in [IMU_TOPIC, ODOM_TOPIC] {
        let schema = w.add_schema(ros_type(topic, true), "ros2msg", b"").unwrap();
        channels.insert(topic, w.add_channel(schema, topic, "cdr", &Default::default()).unwrap());
    }
    for (i, (topic, t, bytes)) in messages.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: channels[topic],
            sequence: i as u32,
            log_time: *t,
            publish_time: *t,
        };
        w.write_to_known_channel(&header, bytes).unwrap();
    }
    w.finish().unwrap();
}

/// A ROS 2 bag in SQLite (rosbag2's `sqlite3` storage) of `(topic, stamp, bytes)`.
fn db3_bag(path: &Path, messages: &[(&str, u64, Vec<u8>)]) -> rusqlite::Connection {
    let db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
         serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, \
         data BLOB NOT NULL);",
    )
    .unwrap();
    for (id, topic) in [IMU_TOPIC, ODOM_TOPIC].iter().enumerate() {
        db.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
            rusqlite::params![id as i64 + 1, topic, ros_type(topic, true)],
        )
        .unwrap();
    }
    for (topic, t, bytes) in messages {
        let id = if *topic == IMU_TOPIC { 1 } else { 2 };
        db.execute(
            "INSERT INTO messages(topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![id, *t as i64, bytes],
        )
        .unwrap();
    }
    db
}

fn cdr_messages(n: u32) -> Vec<(&'static str, u64, Vec<u8>)> {
    messages(n).into_iter().map(|(topic, t)| (topic, t, cdr_message(topic, t))).collect()
}

/// `header.frame_id` declares 2³¹ or 2³² − 1 bytes, or a little-endian
/// message says it is big-endian: the message is refused ("does not
/// decode"), nothing near that size is allocated, and the others are fused.
#[test]
fn a_cdr_length_past_the_message_is_refused_without_allocating_it() {
    let dir = tempfile::tempdir().unwrap();
    let clean = cdr_messages(100);
    for (name, damage) in [
        ("2^31", (12usize, 0x8000_0000u32.to_le_bytes().to_vec())),
        ("2^32-1", (12, u32::MAX.to_le_bytes().to_vec())),
        ("big-endian header", (1, vec![0])),
    ] {
        let mut m = clean.clone();
        for i in [10, 40] {
            let (at, bytes) = &damage;
            m[i].2[*at..*at + bytes.len()].copy_from_slice(bytes);
        }
        for (format, path) in [("mcap", dir.path().join("bag.mcap")), ("db3", dir.path().join("bag.db3"))] {
            let _ = std::fs::remove_file(&path);
            if format == "mcap" {
                mcap_bag(&path, &m);
            } else {
                drop(db3_bag(&path, &m));
            }
            let out = replay(dir.path(), &path);
            let said = stderr(&out);
            assert!(out.status.success(), "{name} {format}: {said}");
            assert!(said.contains("does not decode"), "{name} {format}: {said}");
            assert_eq!(lines(dir.path()).len(), clean.len() + 100 - 4, "{name} {format}: the others fused");
            let out = sim(dir.path(), &path);
            assert!(out.status.success(), "fusion-sim, {name} {format}: {}", stderr(&out));
        }
    }
}

/// Odometry bytes under an IMU channel: they decode as an IMU message with
/// bytes left over, and are refused so, not fused as a garbage attitude.
#[test]
fn bytes_left_over_after_a_message_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = cdr_messages(100);
    let t = m[20].1;
    m[20].2 = cdr_message(ODOM_TOPIC, t);
    let path = dir.path().join("mixed.mcap");
    mcap_bag(&path, &m);
    let out = replay(dir.path(), &path);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("bytes left over after the message"), "{said}");
    assert_eq!(lines(dir.path()).len(), m.len() + 100 - 2, "the IMU message and its attitude refused");
}

/// rosbag2's `--compression-mode message`: each message a zstd frame. Read
/// as the same bag uncompressed, bit for bit.
#[test]
fn a_db3_with_per_message_zstd_replays_as_the_bag_uncompressed() {
    let dir = tempfile::tempdir().unwrap();
    let m = cdr_messages(100);
    let plain = dir.path().join("plain.db3");
    drop(db3_bag(&plain, &m));
    let out = replay(dir.path(), &plain);
    assert!(out.status.success(), "{}", stderr(&out));
    let expected = lines(dir.path());
    let compressed: Vec<_> = m.iter().map(|(topic, t, b)| (*topic, *t, zstd::encode_all(&b[..], 3).unwrap())).collect();
    let zstd = dir.path().join("zstd.db3");
    drop(db3_bag(&zstd, &compressed));
    let out = replay(dir.path(), &zstd);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(lines(dir.path()), expected);
}

/// A `messages` that is a recursive view, which never ends: refused at once,
/// named. A read that runs away is cut off by the step budget.
#[test]
fn a_db3_whose_messages_never_end_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("endless.db3");
    let db = db3_bag(&path, &cdr_messages(10));
    db.execute_batch(
        "DROP TABLE messages;
         CREATE VIEW messages AS WITH RECURSIVE r(id, topic_id, timestamp, data) AS \
         (SELECT 1, 1, 0, x'00010000' UNION ALL SELECT id + 1, topic_id, timestamp + 1, data FROM r) SELECT * FROM r;",
    )
    .unwrap();
    drop(db);
    for out in [replay(dir.path(), &path), sim(dir.path(), &path)] {
        let said = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{said}");
        assert!(said.contains("\"messages\" is a view, not a table"), "{said}");
    }
}

/// A whole file compressed (rosbag2's `--compression-mode file`: `bag.db3.zstd`)
/// is named as such, with what to do.
#[test]
fn a_bag_compressed_whole_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.db3");
    drop(db3_bag(&plain, &cdr_messages(10)));
    let zstd = write(dir.path(), "bag.db3.zstd", &zstd::encode_all(&std::fs::read(&plain).unwrap()[..], 3).unwrap());
    let out = replay(dir.path(), &zstd);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(said.contains("a zstd-compressed file") && said.contains("zstd -d"), "{said}");
}

/// Ctrl-C while `fusion-sim` publishes a bag: it says it was interrupted and
/// how far it got, and exits 130, not 0 as if the bag had been published.
#[test]
fn fusion_sim_interrupted_says_so() {
    let dir = tempfile::tempdir().unwrap();
    // 20 s of a robot at rest, published at its pace.
    let bag = write(dir.path(), "long.bag", &ros1_bag(&[ros1_chunk(&messages(2000))]));
    let config = dir.path().join("config.toml");
    std::fs::write(&config, jackal()).unwrap();
    let mut sim = common::live::Running(
        Command::new(workspace_bin("fusion-sim"))
            .args(["run", "--allow-no-daemon", "--namespace", &format!("hostile-int-{}", std::process::id())])
            .arg("--config")
            .arg(&config)
            .arg("--input")
            .arg(&bag)
            .env(DOMAIN_ENV, format!("hi{}", std::process::id()))
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(Command::new("kill").args(["-INT", &sim.0.id().to_string()]).status().unwrap().success());
    let status = sim.wait_for(std::time::Duration::from_secs(20)).expect("fusion-sim did not stop on SIGINT");
    let mut said = String::new();
    std::io::Read::read_to_string(&mut sim.0.stderr.take().unwrap(), &mut said).unwrap();
    assert_eq!(status.code(), Some(i32::from(fusion_shared::exit::INTERRUPTED)), "{said}");
    assert!(said.contains("interrupted: published") && said.contains("before the signal"), "{said}");
}
