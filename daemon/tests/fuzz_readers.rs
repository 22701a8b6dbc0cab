//! Every reader of files fusiond takes, fuzzed from real files: ROS 1 bags,
//! ROS 2 bags in MCAP and in SQLite (robot_localization's test bags, from
//! `../shared/data/robot_localization`), a recording of a live fusiond run
//! (`fusionctl record`), and JSON lines (`examples/drive.jsonl`). Each input is
//! the real file with damage at a random offset (a flipped bit, 16 bytes of
//! 0xFF, 4 KiB of random bytes, bytes inserted, or the file cut there), read
//! in process as the tools read it. None may panic, hang or allocate past
//! [`LARGEST_ALLOCATION`]: a reader that believes a size the file declares
//! shows here. Bounded by the number of inputs (a fixed seed: the same inputs
//! on every machine); `FUSION_FUZZ_CASES` raises it for a longer run, and the
//! counts are printed (`--nocapture`).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use fusion_daemon::config::Config;
use fusion_daemon::replay::recording::{Recording, replay_recording};
use fusion_shared::ros::{Route, read_bag};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The largest single allocation a reader may make: a chunk may declare at
/// most `fusion_shared::mcap_scan::MAX_CHUNK_BYTES` (256 MiB) decompressed.
const LARGEST_ALLOCATION: u64 = (1 << 28) + (1 << 20);

/// The system allocator, noting the largest request. A request past 4 GiB
/// is refused (the process aborts, naming its size) rather than granted on
/// overcommit and touched.
struct Largest;

static LARGEST: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size() as u64, Ordering::Relaxed);
        if layout.size() as u64 > 1 << 32 {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `alloc`, passed on.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc`, passed on.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size as u64, Ordering::Relaxed);
        if new_size as u64 > 1 << 32 {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `realloc`, passed on.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Largest = Largest;

/// Inputs per reader (each a damaged copy of a real file).
fn cases(default: u64) -> u64 {
    std::env::var("FUSION_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// What one damage did to a file, for a failure's message.
#[derive(Debug)]
#[allow(dead_code)] // The fields are read through `Debug`.
enum Damage {
    Flip { at: usize, bit: u8 },
    Ff16 { at: usize },
    Random4k { at: usize },
    Insert { at: usize, n: usize },
    Cut { at: usize },
}

/// `clean` with one damage at a random offset.
fn damaged(clean: &[u8], rng: &mut ChaCha8Rng) -> (Vec<u8>, Damage) {
    let mut bytes = clean.to_vec();
    let at = rng.random_range(0..clean.len());
    let damage = match rng.random_range(0..5) {
        0 => {
            let bit = rng.random_range(0..8);
            bytes[at] ^= 1 << bit;
            Damage::Flip { at, bit }
        }
        1 => {
            let end = (at + 16).min(bytes.len());
            bytes[at..end].fill(0xff);
            Damage::Ff16 { at }
        }
        2 => {
            let end = (at + 4096).min(bytes.len());
            rng.fill_bytes(&mut bytes[at..end]);
            Damage::Random4k { at }
        }
        3 => {
            let n = rng.random_range(1..9);
            let mut inserted = vec![0u8; n];
            rng.fill_bytes(&mut inserted);
            bytes.splice(at..at, inserted);
            Damage::Insert { at, n }
        }
        _ => {
            bytes.truncate(at);
            Damage::Cut { at }
        }
    };
    (bytes, damage)
}

/// Aborts the process, naming the input, when one input runs past a minute
/// (a reader that hangs): a test that hangs is a failure that says nothing.
struct Watchdog {
    armed: std::sync::Arc<(AtomicBool, std::sync::Mutex<String>)>,
}

impl Watchdog {
    fn new(reader: &'static str) -> Self {
        let armed = std::sync::Arc::new((AtomicBool::new(false), std::sync::Mutex::new(String::new())));
        let watched = std::sync::Arc::clone(&armed);
        std::thread::spawn(move || {
            let mut since: Option<(Instant, String)> = None;
            loop {
                std::thread::sleep(Duration::from_millis(200));
                let what = watched.1.lock().map(|w| w.clone()).unwrap_or_default();
                if !watched.0.load(Ordering::Relaxed) {
                    since = None;
                    continue;
                }
                match &since {
                    Some((t, w)) if *w == what && t.elapsed() > Duration::from_secs(60) => {
                        eprintln!("{reader}: one input ran for a minute (a hang): {what}");
                        std::process::abort();
                    }
                    Some((_, w)) if *w == what => {}
                    _ => since = Some((Instant::now(), what)),
                }
            }
        });
        Self { armed }
    }

    /// Runs `read` on the input `what`, watched.
    fn watch<T>(&self, what: String, read: impl FnOnce() -> T) -> T {
        if let Ok(mut w) = self.armed.1.lock() {
            *w = what;
        }
        self.armed.0.store(true, Ordering::Relaxed);
        let out = read();
        self.armed.0.store(false, Ordering::Relaxed);
        out
    }
}

/// Fuzzes `read` (a reader of a file at a path) from `clean`, `n` inputs;
/// returns how many ended how (read whole, the damage named, refused).
fn fuzz(name: &'static str, clean: &[u8], n: u64, seed: u64, read: impl Fn(&Path) -> Outcome) -> [u64; 3] {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("input-{name}"));
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let watchdog = Watchdog::new(name);
    let mut outcomes = [0u64; 3];
    for case in 0..n {
        let (bytes, damage) = damaged(clean, &mut rng);
        std::fs::write(&path, &bytes).unwrap();
        LARGEST.store(0, Ordering::Relaxed);
        let what = format!("{name} case {case}: {damage:?}");
        let outcome = watchdog.watch(what.clone(), || {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(&path)))
                .unwrap_or_else(|_| panic!("{what}: the reader panicked"))
        });
        let largest = LARGEST.load(Ordering::Relaxed);
        assert!(largest <= LARGEST_ALLOCATION, "{what}: an allocation of {largest} bytes");
        outcomes[outcome as usize] += 1;
    }
    eprintln!(
        "{name}: {n} damaged inputs from a file of {} bytes: {} read whole, {} read up to the damage named, {} \
         refused with a reason",
        clean.len(),
        outcomes[0],
        outcomes[1],
        outcomes[2]
    );
    outcomes
}

/// How a reader ended on one input.
#[derive(Clone, Copy)]
enum Outcome {
    Whole = 0,
    DamageNamed = 1,
    Refused = 2,
}

/// robot_localization's test bags: `FUSION_RL_DATA`, or `../shared/data/robot_localization`.
fn rl_data(name: &str) -> Option<PathBuf> {
    let root = std::env::var_os("FUSION_RL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/robot_localization"));
    let path = root.join(name);
    if path.exists() {
        return Some(path);
    }
    let said = format!(
        "{} is absent (robot_localization's test bags, BSD, from its repository's test/ folder; the ROS 2 copies \
         made with rosbags-convert: see ../shared/data/robot_localization/README.md; FUSION_RL_DATA names another \
         folder)",
        path.display()
    );
    assert!(std::env::var_os("FUSION_REQUIRE_RL_DATA").is_none(), "{said}");
    eprintln!("skipped: {said}");
    None
}

fn jackal_routes() -> Vec<Route> {
    let route = |topic: &str, kinds: &[&str], name: &str| {
        let kinds: Vec<String> = kinds.iter().map(|k| k.to_string()).collect();
        Route::of_sensor(name, 0, &kinds, Some(topic)).unwrap().unwrap()
    };
    vec![
        route("/imu/data", &["imu", "attitude"], "imu"),
        route("/jackal_velocity_controller/odom", &["odometry"], "wheels"),
    ]
}

/// A bag read as `fusiond replay` reads it: every sample taken.
fn read_a_bag(path: &Path) -> Outcome {
    let mut samples = 0u64;
    match read_bag(path, &jackal_routes(), |item| samples += u64::from(item.sample.is_ok())) {
        Ok(summary) if summary.damage.is_some() => Outcome::DamageNamed,
        Ok(_) => Outcome::Whole,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            Outcome::Refused
        }
    }
}

#[test]
fn ros1_bags() {
    let Some(path) = rl_data("test/test2.bag") else { return };
    let outcomes = fuzz("ROS 1 bag", &std::fs::read(path).unwrap(), cases(300), 1, read_a_bag);
    assert!(outcomes[1] > 0, "some damage was found and named");
}

#[test]
fn ros2_mcap_bags() {
    let Some(path) = rl_data("ros2/test2.mcap") else { return };
    let outcomes = fuzz("ROS 2 MCAP bag", &std::fs::read(path).unwrap(), cases(300), 2, read_a_bag);
    assert!(outcomes[1] > 0, "some damage was found and named");
}

#[test]
fn ros2_db3_bags() {
    let Some(path) = rl_data("ros2/test2.db3") else { return };
    fuzz("ROS 2 .db3 bag", &std::fs::read(path).unwrap(), cases(100), 3, read_a_bag);
}

#[test]
fn json_lines() {
    let clean = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/drive.jsonl")).unwrap();
    let config = Config::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/linear.toml")).unwrap();
    fuzz("JSON lines", &clean, cases(300), 4, |path| {
        let input = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        match fusion_daemon::replay::replay(&config, input, None::<std::io::Sink>, false) {
            Ok(s) if s.counts.invalid == 0 => Outcome::Whole,
            Ok(_) => Outcome::DamageNamed,
            Err(_) => Outcome::Refused,
        }
    });
}

#[test]
fn recordings() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{}\n{}", common::linear_config(Some(0.999)), common::live::RECORDED_TIME);
    let clean = std::fs::read(common::live::record_drive(dir.path(), &text)).unwrap();
    let config = Config::parse(&text).unwrap();
    let outcomes = fuzz("fusiond recording", &clean, cases(300), 5, |path| {
        let Ok(recording) = Recording::open(path) else { return Outcome::Refused };
        let damaged = recording.damage().is_some();
        for (smooth, compare) in [(false, true), (true, false)] {
            let replayed = replay_recording(&config, &recording, None::<std::io::Sink>, smooth, compare, || {});
            if let Err(e) = replayed {
                assert!(!e.to_string().is_empty());
            }
        }
        if damaged { Outcome::DamageNamed } else { Outcome::Whole }
    });
    assert!(outcomes[1] > outcomes[0], "most damage is found and named: {outcomes:?}");
}
