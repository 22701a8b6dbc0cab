//! Running the real fusiond over real iceoryx2 in a test: every test gets its own
//! iceoryx2 domain (file prefix) and namespace, so tests run in parallel without
//! seeing each other, and can check that nothing is left behind.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use fusion_client::{Client, StateSubscriber};
use fusion_shared::service::{DOMAIN_ENV, domain_prefix};
use fusion_shared::{Sample, StateSnapshot};

/// A unique iceoryx2 domain and namespace; removes the domain's files on drop.
pub struct TestDomain {
    pub domain: String,
    pub namespace: String,
    pub prefix: String,
}

impl TestDomain {
    pub fn new(tag: &str) -> Self {
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let domain = format!("ft{}x{n}", std::process::id());
        let prefix = domain_prefix(&domain).unwrap();
        Self { namespace: format!("{tag}-{n}"), domain, prefix }
    }

    pub fn client(&self) -> Client {
        Client::connect_in_domain(&self.namespace, Some(&self.domain)).unwrap()
    }

    /// Files of this domain in /dev/shm and /tmp/iceoryx2.
    pub fn files(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Ok(entries) = std::fs::read_dir("/dev/shm") {
            for e in entries.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with(&self.prefix) {
                    out.push(format!("/dev/shm/{name}"));
                }
            }
        }
        let mut stack = vec![PathBuf::from("/tmp/iceoryx2")];
        while let Some(dir) = stack.pop() {
            for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                let path = e.path();
                if path.is_dir() {
                    stack.push(path.clone());
                }
                if e.file_name().to_string_lossy().starts_with(&self.prefix) {
                    out.push(path.display().to_string());
                }
            }
        }
        out
    }
}

impl Drop for TestDomain {
    fn drop(&mut self) {
        let files = self.files();
        for f in &files {
            let _ = std::fs::remove_file(f).or_else(|_| std::fs::remove_dir_all(f));
        }
        // A SIGKILLed process's node directory (named by node id, no prefix) held
        // only this domain's files: remove it once empty (remove_dir refuses otherwise).
        for f in &files {
            if let Some(dir) = std::path::Path::new(f).parent()
                && dir.parent() == Some(std::path::Path::new("/tmp/iceoryx2/nodes"))
            {
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

/// The fusiond binary: this package's own, or, in another package's tests
/// (the bridge's), the workspace's (see [`workspace_bin`]).
pub fn fusiond() -> PathBuf {
    match option_env!("CARGO_BIN_EXE_fusiond") {
        Some(path) => PathBuf::from(path),
        None => workspace_bin("fusiond"),
    }
}

/// Path of a workspace binary of another package than the test's (the client's
/// `fusion-sim`, `fusionctl`, `fusion-demo`, the bridge's `fusion-bridge`, or
/// fusiond from the bridge's tests), in the directory of the test's own build.
///
/// `cargo test --workspace` builds them with the tests (the dev-dependency on
/// `fusion-client` turns on its `cli` feature). Run otherwise (`cargo test -p
/// fusion-daemon`), a binary may be missing or older than the sources: then its
/// package is built here once per test binary, with cargo's progress on the
/// terminal rather than captured, so the wait is visible.
pub fn workspace_bin(name: &str) -> PathBuf {
    let (package, features, sources): (&str, &[&str], &[&str]) = match name {
        "fusiond" => ("fusion-daemon", &[], &["daemon/src", "daemon/Cargo.toml"]),
        "fusion-bridge" => {
            ("fusion-bridge", &[], &["bridge/src", "bridge/Cargo.toml", "client/src", "client/Cargo.toml"])
        }
        _ => ("fusion-client", &["--features", "cli"], &["client/src", "client/Cargo.toml"]),
    };
    // target/<profile>/deps/<test> → target/<profile>/<name>
    let exe = std::env::current_exe().unwrap();
    let path = exe.parent().and_then(Path::parent).unwrap().join(name);
    static BUILT: std::sync::Mutex<Vec<&str>> = std::sync::Mutex::new(Vec::new());
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    if !built.contains(&package) {
        built.push(package);
        if !built_after_sources(&path, sources) {
            let mut args = vec!["build", "-p", package, "--bins"];
            args.extend_from_slice(features);
            // Straight to the terminal: the test harness captures only `eprintln!`.
            let _ =
                writeln!(std::io::stderr(), "{name} is missing or older than its sources: cargo {}", args.join(" "));
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let mut cmd = Command::new(cargo);
            cmd.args(args);
            if !cfg!(debug_assertions) {
                cmd.arg("--release");
            }
            let status = cmd.current_dir(env!("CARGO_MANIFEST_DIR")).status().expect("run cargo build");
            assert!(status.success(), "building {package} failed");
        }
    }
    assert!(path.exists(), "{} is not built", path.display());
    path
}

/// Whether `binary` exists and is newer than every file of `sources` (paths
/// from the workspace root) and of the shared crate.
fn built_after_sources(binary: &Path, sources: &[&str]) -> bool {
    fn newest(dir: &Path) -> std::time::SystemTime {
        let mut latest = std::time::SystemTime::UNIX_EPOCH;
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            let t = if path.is_dir() {
                newest(&path)
            } else {
                entry.metadata().and_then(|m| m.modified()).unwrap_or(latest)
            };
            latest = latest.max(t);
        }
        latest
    }
    let Ok(built) = std::fs::metadata(binary).and_then(|m| m.modified()) else { return false };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    sources.iter().chain(&["shared/src", "shared/Cargo.toml"]).all(|p| {
        let p = root.join(p);
        let t = if p.is_dir() { newest(&p) } else { std::fs::metadata(&p).and_then(|m| m.modified()).unwrap_or(built) };
        t <= built
    })
}

/// The `[validation]` table for a daemon fed recorded or simulated time: any
/// timestamp behind the clock is accepted.
pub const RECORDED_TIME: &str = "[validation]\nmax_past_ns = 9_000_000_000_000_000_000\n";

/// A running `fusiond run`.
pub struct Daemon {
    child: Child,
    _dir: tempfile::TempDir,
    stderr: PathBuf,
}

impl Daemon {
    pub fn start(domain: &TestDomain, config: &str, wait: &str) -> Self {
        Self::start_with(domain, config, &["--wait", wait])
    }

    /// `fusiond run` with `args` after the namespace and config.
    ///
    /// The tests publish simulated time, which starts near 0 and so lies far
    /// behind the daemon's clock: unless `config` has a `[validation]` table of
    /// its own, the past-timestamp check is opened up ([`RECORDED_TIME`]).
    pub fn start_with(domain: &TestDomain, config: &str, args: &[&str]) -> Self {
        Self::start_with_env(domain, config, args, &[])
    }

    /// [`start_with`](Self::start_with), with `env` added to fusiond's environment.
    pub fn start_with_env(domain: &TestDomain, config: &str, args: &[&str], env: &[(&str, &str)]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let config_path = dir.path().join("config.toml");
        let config =
            if config.contains("[validation]") { config.to_string() } else { format!("{config}\n{RECORDED_TIME}") };
        std::fs::write(&config_path, config).unwrap();
        let mut with_config = vec![std::ffi::OsString::from("--config"), config_path.into_os_string()];
        with_config.extend(args.iter().map(std::ffi::OsString::from));
        Self::launch(domain, dir, &with_config, env)
    }

    /// `fusiond run` without a configuration file: on the built-in defaults.
    pub fn start_on_defaults(domain: &TestDomain) -> Self {
        Self::launch(domain, tempfile::tempdir().unwrap(), &[], &[])
    }

    fn launch(domain: &TestDomain, dir: tempfile::TempDir, args: &[std::ffi::OsString], env: &[(&str, &str)]) -> Self {
        let stderr = dir.path().join("stderr.log");
        let child = Command::new(fusiond())
            .args(["run", "--namespace", &domain.namespace])
            .args(args)
            .env(DOMAIN_ENV, &domain.domain)
            .env("RUST_LOG", "info")
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .unwrap();
        let mut d = Self { child, _dir: dir, stderr };
        d.wait_ready(domain);
        d
    }

    fn wait_ready(&mut self, domain: &TestDomain) {
        let client = domain.client();
        let deadline = Instant::now() + Duration::from_secs(20);
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                panic!("fusiond exited at start-up ({status}): {}", self.stderr());
            }
            if self.stderr().contains("fusiond running") && client.state_subscriber().is_ok() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!("fusiond did not come up: {}", self.stderr());
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    pub fn signal(&mut self, signal: &str) {
        let ok = Command::new("kill").args([signal, &self.child.id().to_string()]).status().unwrap().success();
        assert!(ok, "kill {signal} failed");
    }

    /// SIGTERM, then the exit status (SIGKILL after 10 s).
    pub fn terminate(&mut self) -> ExitStatus {
        self.stop_with("-TERM")
    }

    /// `signal` (`-TERM`, `-INT`), then the exit status (SIGKILL after 10 s).
    pub fn stop_with(&mut self, signal: &str) -> ExitStatus {
        self.signal(signal);
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                return status;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        panic!("fusiond ignored {signal}: {}", self.stderr());
    }

    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.is_running() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A tool's process, stopped with SIGTERM (to its whole process group when it
/// leads one) and reaped when dropped: a failing test leaves nothing running.
pub struct Running(pub Child);

impl Running {
    /// Waits for the process to end by itself, at most `timeout`.
    pub fn wait_for(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(status) = self.0.try_wait().unwrap() {
                return Some(status);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// SIGTERM, then the exit status within `timeout` (`None`: still running).
    pub fn stop(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
        self.wait_for(timeout)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let pid = self.0.id().to_string();
            let _ = Command::new("kill").args(["-TERM", "--", &format!("-{pid}")]).status();
            let _ = Command::new("kill").args(["-TERM", &pid]).status();
            if self.wait_for(Duration::from_secs(5)).is_none() {
                let _ = self.0.kill();
            }
        }
        let _ = self.0.wait();
    }
}

/// Writes `samples` to `path` as JSON lines and publishes the file with
/// `fusion-sim run --input` (as fast as fusiond takes them).
pub fn publish_file(domain: &TestDomain, path: &Path, samples: &[Sample]) {
    let text: String = samples.iter().map(|s| fusion_shared::jsonl::format_sample(s) + "\n").collect();
    std::fs::write(path, text).unwrap();
    // The tests' files are stamped on the scenario's clock, and their fusiond
    // takes them as they are (`RECORDED_TIME`).
    let sim = Command::new(workspace_bin("fusion-sim"))
        .args(["run", "--keep-stamps", "--namespace", &domain.namespace, "--input"])
        .arg(path)
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
}

/// Waits (at most 20 s) until `who` reads `<ns>/state`: a tool started as a
/// process of its own has subscribed, and may be sent to.
pub fn wait_for_state_reader(domain: &TestDomain, who: &str) {
    wait_for_state_readers(domain, 1, who);
}

/// Waits (at most 20 s) until `n` readers have subscribed to the domain's
/// `<ns>/state` (fusiond itself is not one).
pub fn wait_for_state_readers(domain: &TestDomain, n: usize, who: &str) {
    use iceoryx2::service::port_factory::PortFactory as _;
    let config = fusion_shared::service::iceoryx_config(Some(&domain.domain)).unwrap();
    let node = fusion_shared::service::create_node("test-probe", &config).unwrap();
    let names = fusion_shared::service::ServiceNames::new(&domain.namespace).unwrap();
    let state = fusion_shared::service::state_service(&node, &names, None).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    while state.dynamic_config().number_of_subscribers() < n {
        assert!(Instant::now() < deadline, "{who} did not subscribe");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Whether a snapshot was triggered by `sample`.
pub fn triggered_by(s: &StateSnapshot, sample: &Sample) -> bool {
    s.input_t_ns == sample.t_ns()
        && s.input_kind == sample.kind() as u32
        && s.input_sensor == sample.sensor()
        && s.input_seq == sample.seq()
}

/// Publishes samples one by one, each after the snapshot of the previous one:
/// the daemon sees exactly this arrival order. Returns the snapshots.
pub fn publish_in_lockstep(client: &Client, reader: &mut StateSubscriber, samples: &[Sample]) -> Vec<StateSnapshot> {
    let mut publishers = fusion_client::SensorPublishers::all(client).unwrap();
    let mut out = Vec::with_capacity(samples.len());
    for s in samples {
        publishers.publish(*s).unwrap().expect("a publisher of every kind");
        out.push(snapshot_of(reader, s));
    }
    out
}

/// Waits (at most 10 s) for the snapshot that `sample` triggered, skipping others.
pub fn snapshot_of(reader: &mut StateSubscriber, sample: &Sample) -> StateSnapshot {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no snapshot for {sample:?}");
        if let Some(snap) = reader.wait_next(left).unwrap()
            && triggered_by(snap, sample)
        {
            return *snap;
        }
    }
}

/// How many samples of sensor `sensor` fusiond has received, as its latest
/// snapshot says, waiting (at most 10 s) until it is `n`.
pub fn received_by(domain: &TestDomain, sensor: u32, n: u64) -> u64 {
    let client = domain.client();
    let mut reader = client.state_subscriber().unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let row =
            reader.latest().unwrap().and_then(|s| s.sensor_counters().iter().find(|c| c.sensor == sensor).copied());
        let received = row.map_or(0, |r| r.counts.received);
        if received >= n || Instant::now() > deadline {
            return received;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `fusionctl record --output mcap` in `domain`, once it reads the state
/// service (it opens the sample services before it), its stderr to `stderr`.
pub fn start_recorder(domain: &TestDomain, mcap: &Path, stderr: Stdio) -> Running {
    let recorder = Running(
        Command::new(workspace_bin("fusionctl"))
            .args(["record", "--namespace", &domain.namespace, "--output"])
            .arg(mcap)
            .env(DOMAIN_ENV, &domain.domain)
            .stderr(stderr)
            .spawn()
            .unwrap(),
    );
    wait_for_state_reader(domain, "fusionctl record");
    recorder
}

/// A recording of a live run of 3 s of a drive (200 Hz IMU, fixes 20–120 ms
/// late), made with the tools as a user makes one: `fusiond run` with
/// `config`, `fusionctl record`, `fusion-sim run --input`; the recorder stopped
/// with SIGINT once fusiond processed every sample. Returns its path in `dir`.
pub fn record_drive(dir: &Path, config: &str) -> PathBuf {
    let domain = TestDomain::new("recorded-drive");
    let mut c = fusion_client::sim::ScenarioConfig { seed: 8, duration_s: 3.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.position.delay_min_ns = 20_000_000;
    c.position.delay_max_ns = 120_000_000;
    let samples: Vec<Sample> =
        fusion_client::sim::Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let mut daemon = Daemon::start(&domain, config, "event");
    let mcap = dir.join("run.mcap");
    let mut recorder = start_recorder(&domain, &mcap, Stdio::null());
    publish_file(&domain, &dir.join("drive.jsonl"), &samples);
    let mut reader = domain.client().state_subscriber().unwrap();
    let processed = |s: &StateSnapshot| s.sensor_counters().iter().map(|c| c.counts.processed).sum::<u64>();
    // A hang guard: fusiond processes the drive in well under a second.
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    while reader.latest().unwrap().map_or(0, &processed) < samples.len() as u64 {
        assert!(std::time::Instant::now() < deadline, "fusiond did not process the drive");
        std::thread::sleep(Duration::from_millis(10));
    }
    drop(reader);
    assert!(Command::new("kill").args(["-INT", &recorder.0.id().to_string()]).status().unwrap().success());
    assert!(recorder.wait_for(Duration::from_secs(20)).is_some_and(|s| s.success()), "fusionctl record failed");
    assert!(daemon.terminate().success());
    mcap
}
