//! The permission model against a second Unix user: only the daemon's user may
//! create, read, write or break fusiond's shared memory and iceoryx2 files.
//!
//! Adding a user needs root. As another user the tests that need one say so and
//! return, unless `FUSION_REQUIRE_ROOT_TESTS` is set (CI sets it), when they fail.

mod common;

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_shared::ImuSample;
use fusion_shared::service::DOMAIN_ENV;

const PEER: &str = "fusion-peer";

/// The second user's uid, created if needed; `None` (test skipped) when this
/// process cannot add users.
fn peer_uid() -> Option<u32> {
    if fusion_shared::permissions::euid() != 0 {
        assert!(std::env::var_os("FUSION_REQUIRE_ROOT_TESTS").is_none(), "this test needs root to add a Unix user");
        eprintln!("skipped: adding a second Unix user needs root");
        return None;
    }
    let id = |out: Output| String::from_utf8_lossy(&out.stdout).trim().parse::<u32>().ok();
    if let Some(uid) = id(Command::new("id").args(["-u", PEER]).output().unwrap()) {
        return Some(uid);
    }
    let added = Command::new("useradd")
        .args(["--system", "--no-create-home", "--shell", "/usr/sbin/nologin", PEER])
        .output()
        .unwrap();
    // A parallel test may have added it first.
    let uid = id(Command::new("id").args(["-u", PEER]).output().unwrap());
    assert!(uid.is_some(), "useradd failed: {}", String::from_utf8_lossy(&added.stderr));
    uid
}

/// Runs `args` as the second user, killed after 20 s (the hang this guards against).
fn as_peer(args: &[&str]) -> Output {
    Command::new("timeout").args(["20", "runuser", "-u", PEER, "--"]).args(args).output().unwrap()
}

/// A copy of a tool the second user may run (the build tree may be closed to it).
fn peer_copy(dir: &Path, name: &str) -> PathBuf {
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    let to = dir.join(name);
    std::fs::copy(workspace_bin(name), &to).unwrap();
    std::fs::set_permissions(&to, std::fs::Permissions::from_mode(0o755)).unwrap();
    to
}

fn node_counter(domain: &TestDomain) -> PathBuf {
    let files = domain.files();
    let counter =
        files.iter().find(|f| f.starts_with("/dev/shm/") && f.contains("_node.") && f.ends_with("global_mgmt"));
    PathBuf::from(counter.unwrap_or_else(|| panic!("no node counter among {files:?}")))
}

fn config() -> String {
    common::linear_config(Some(0.999))
}

#[test]
fn another_user_can_neither_read_nor_break_the_shared_memory_nor_hang_new_processes() {
    let Some(_) = peer_uid() else { return };
    let domain = TestDomain::new("perm");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let client = domain.client();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.set_wake(true);
    imu.publish_sample(ImuSample::new(1_000_000, 0, 0, [0.0; 3], [0.0; 3])).unwrap();

    // Every file of the domain is the daemon user's and closed to others.
    let files = domain.files();
    assert!(files.len() > 5, "{files:?}");
    for f in &files {
        let meta = std::fs::symlink_metadata(f).unwrap();
        assert_eq!(meta.uid(), 0, "{f}");
        if !meta.is_dir() {
            assert_eq!(meta.mode() & 0o077, 0, "{f} is open to others: {:o}", meta.mode());
        }
    }
    let counter = node_counter(&domain);
    let before = std::fs::read(&counter).unwrap();
    // The other user can neither write (truncate) nor read the node counter (the
    // hang of every new process came from truncating it), nor any segment, nor put
    // files into iceoryx2's directory.
    for f in files.iter().filter(|f| f.starts_with("/dev/shm/")) {
        // Opened for writing, never created: a file that went away since the
        // listing (a connection closed) must not come back as the other user's.
        let out = as_peer(&["dd", "if=/dev/null", &format!("of={f}"), "conv=nocreat,notrunc", "status=none"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{f} is writable by another user");
        assert!(stderr.contains("Permission denied") || !Path::new(f).exists(), "{f}: {stderr}");
        assert!(!as_peer(&["cat", f]).status.success(), "{f} read");
    }
    assert!(!as_peer(&["touch", "/tmp/iceoryx2/planted"]).status.success());
    assert_eq!(std::fs::read(&counter).unwrap(), before);

    // A fusion tool started by the other user fails at once, saying why.
    let dir = tempfile::tempdir().unwrap();
    let fusionctl = peer_copy(dir.path(), "fusionctl");
    let env = format!("{DOMAIN_ENV}={}", domain.domain);
    let started = Instant::now();
    let out = as_peer(&["env", &env, fusionctl.to_str().unwrap(), "state", "--namespace", &domain.namespace]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(started.elapsed() < Duration::from_secs(15), "it hung: {stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("belongs to uid 0") && stderr.contains("one user"), "{stderr}");

    // The daemon and this user's new processes are unaffected.
    let fresh = domain.client();
    let mut reader = fresh.state_subscriber().unwrap();
    assert!(reader.wait_next(Duration::from_secs(5)).unwrap().is_some() || reader.latest().unwrap().is_some());
    assert!(daemon.is_running());
    assert!(daemon.terminate().success());
}

#[test]
fn a_node_counter_planted_by_another_user_is_refused_with_its_owner_not_waited_on() {
    let Some(_) = peer_uid() else { return };
    // Learn the counter's name in one domain, then plant it in another.
    let probe = TestDomain::new("probe");
    let probe_client = probe.client();
    let name = node_counter(&probe).file_name().unwrap().to_string_lossy().into_owned();
    drop(probe_client);
    let target = TestDomain::new("planted");
    let planted = format!("/dev/shm/{}", name.replacen(&probe.prefix, &target.prefix, 1));
    drop(probe);
    let out = as_peer(&["truncate", "-s", "0", &planted]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // The owner as the file says, not as the user table said before: another
    // process on the machine may delete and re-create the user (a new uid) in
    // between, and what matters is that another user owns the file.
    let peer = std::fs::metadata(&planted).unwrap().uid();
    assert_ne!(peer, fusion_shared::permissions::euid(), "planted by another user");

    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("config.toml");
    std::fs::write(&config_path, config()).unwrap();
    let started = Instant::now();
    let out = Command::new("timeout")
        .args(["20", env!("CARGO_BIN_EXE_fusiond"), "run", "--namespace", &target.namespace, "--config"])
        .arg(&config_path)
        .env(DOMAIN_ENV, &target.domain)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(started.elapsed() < Duration::from_secs(15), "fusiond hung: {stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(&planted) && stderr.contains(&format!("belongs to uid {peer}")), "{stderr}");
    std::fs::remove_file(&planted).unwrap();
}

#[test]
fn a_node_counter_open_to_everyone_is_narrowed_to_its_owner() {
    // A plain iceoryx2 process (ipc::Service) makes the counter 0666.
    let domain = TestDomain::new("narrow");
    let config = fusion_shared::service::iceoryx_config(Some(&domain.domain)).unwrap();
    let node =
        iceoryx2::prelude::NodeBuilder::new().config(&config).create::<iceoryx2::prelude::ipc::Service>().unwrap();
    let counter = node_counter(&domain);
    assert_eq!(std::fs::metadata(&counter).unwrap().mode() & 0o777, 0o666);
    let client = domain.client();
    assert_eq!(std::fs::metadata(&counter).unwrap().mode() & 0o777, 0o600);
    drop((client, node));
}

/// Another user plants files under the names of everything fusiond made in a
/// run before (in `/dev/shm`, where anyone may create files), before fusiond
/// starts again. iceoryx2 0.10 names a service's segments (its dynamic config,
/// data segments, connections, event managers) by ids drawn when they are
/// made, so no name is reused: fusiond starts and fuses as usual. The files of
/// iceoryx2's directory (static configs, sockets, node records), whose names
/// are predictable, cannot be planted: the directory is closed to others. The
/// one predictable name in `/dev/shm`, the node counter, is refused with its
/// owner (`a_node_counter_planted_by_another_user_…`).
#[test]
fn files_planted_under_the_names_of_an_earlier_run_do_not_stop_fusiond() {
    let Some(_) = peer_uid() else { return };
    let probe = TestDomain::new("squat-probe");
    let mut daemon = Daemon::start(&probe, &config(), "event");
    let client = probe.client();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.set_wake(true);
    let mut reader = client.state_subscriber().unwrap();
    let sample = ImuSample::new(fusion_shared::now_ns(), 0, 0, [0.0; 3], [0.0; 3]);
    imu.publish_sample(sample).unwrap();
    common::live::snapshot_of(&mut reader, &sample.into());
    let names = probe.files();
    drop((imu, reader, client));
    assert!(daemon.terminate().success());
    drop(daemon);

    let target = TestDomain::new("squat");
    let mut planted = Vec::new();
    for name in &names {
        let name = name.replacen(&probe.prefix, &target.prefix, 1);
        if name.starts_with("/dev/shm/") {
            if name.contains("_node.") && name.ends_with("global_mgmt") {
                continue;
            }
            let out = as_peer(&["truncate", "-s", "4096", &name]);
            assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
            planted.push(name);
        } else {
            assert!(!as_peer(&["touch", &name]).status.success(), "{name} planted in iceoryx2's directory");
        }
    }
    assert!(planted.len() >= 8, "{planted:?} of {names:?}");

    let mut daemon = Daemon::start(&target, &config(), "event");
    let client = target.client();
    let mut imu = client.imu_publisher(0).unwrap();
    imu.set_wake(true);
    let mut reader = client.state_subscriber().unwrap();
    let sample = ImuSample::new(fusion_shared::now_ns(), 0, 0, [0.1, 0.0, 0.0], [0.0; 3]);
    imu.publish_sample(sample).unwrap();
    let snap = common::live::snapshot_of(&mut reader, &sample.into());
    assert_eq!(snap.sensor_counters()[0].counts.processed, 1);
    drop((imu, reader, client));
    assert!(daemon.terminate().success());
    for name in planted {
        std::fs::remove_file(&name).unwrap();
    }
}

/// Another user tries to open every file of the domain in `/dev/shm` for
/// writing, over and over, while this user's processes keep making new ones:
/// publishers and readers that come and go make data segments and connections.
/// iceoryx2 0.10 creates each segment with mode 0200 (`shm_open` with
/// `O_CREAT | O_EXCL`: the umask can only narrow it) and then sets 0600, so at no
/// moment may another user open one; not once in the run may it.
#[test]
fn new_segments_are_never_open_to_another_user_not_even_while_they_are_made() {
    let Some(_) = peer_uid() else { return };
    let domain = TestDomain::new("hammer");
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let pattern = format!("/dev/shm/{}*", domain.prefix);
    // As the other user: attempts to open each file for writing (never
    // creating one), printing the name of any that opens, until told to stop;
    // the count so far in a file of a folder both users write. Counts, not
    // seconds, end both sides: the same overlap on a fast or a loaded machine.
    let shared = tempfile::tempdir().unwrap();
    std::fs::set_permissions(shared.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    let (stop, count) = (shared.path().join("stop"), shared.path().join("count"));
    let script = format!(
        "n=0; while [ ! -e {stop} ]; do for f in {pattern}; do \
         n=$((n+1)); dd if=/dev/null of=\"$f\" conv=nocreat,notrunc status=none 2>/dev/null && echo \"OPENED $f\"; \
         done; echo $n > {count}.new && mv {count}.new {count}; done; echo \"attempts $n\"",
        stop = stop.display(),
        count = count.display(),
    );
    let peer = Command::new("timeout")
        .args(["120", "runuser", "-u", PEER, "--", "sh", "-c", &script])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let peer_attempts = || std::fs::read_to_string(&count).ok().and_then(|n| n.trim().parse::<u64>().ok()).unwrap_or(0);
    // A hang guard, not a timing: both counts are reached in seconds.
    let guard = Instant::now() + Duration::from_secs(100);
    let mut made = 0;
    while made < 50 || peer_attempts() < 200 {
        assert!(Instant::now() < guard, "{made} clients, {} attempts of the other user", peer_attempts());
        let client = domain.client();
        let mut imu = client.imu_publisher(7).unwrap();
        // Come and go at once (no wait for fusiond to take the sample).
        imu.set_linger(Duration::ZERO);
        imu.publish_sample(ImuSample::new(fusion_shared::now_ns(), 7, made, [0.0; 3], [0.0; 3])).unwrap();
        let reader = client.state_subscriber().unwrap();
        drop((reader, imu, client));
        made += 1;
    }
    std::fs::write(&stop, "").unwrap();
    let out = peer.wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(!said.contains("OPENED"), "another user opened a segment:\n{said}");
    let attempts: u64 = said.lines().last().and_then(|l| l.strip_prefix("attempts ")?.parse().ok()).unwrap_or(0);
    assert!(attempts >= 200 && made >= 50, "{attempts} attempts while {made} clients came and went");
    assert!(daemon.terminate().success());
}
