//! A recording cut by power loss (the recorder SIGKILLed mid-run) is not lost:
//! the recorder writes and syncs complete chunks every `--flush-interval`, and
//! `fusiond replay` and `fusionctl plot` use every complete chunk of the cut
//! file, saying it was cut. And a recorder given a namespace where no fusiond
//! runs gives up when its `--duration` has passed.

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::live::{Daemon, Running, TestDomain, workspace_bin};
use fusion_shared::service::DOMAIN_ENV;

#[test]
fn a_recorder_killed_mid_run_leaves_a_file_that_replays_and_plots() {
    let domain = TestDomain::new("cut");
    let config = format!("{}\n[validation]\nmax_past_ns = 5_000_000_000\n", common::linear_config(Some(0.999)));
    let mut daemon = Daemon::start(&domain, &config, "event");
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("killed.mcap");
    let mut recorder = Running(
        Command::new(workspace_bin("fusionctl"))
            .args(["record", "--namespace", &domain.namespace, "--flush-interval", "0.5", "--output"])
            .arg(&mcap)
            .env(DOMAIN_ENV, &domain.domain)
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    common::live::wait_for_state_reader(&domain, "fusionctl record");
    let mut sim = Running(
        Command::new(workspace_bin("fusion-sim"))
            .args(["run", "--namespace", &domain.namespace, "--duration", "6", "--imu-rate", "200"])
            .env(DOMAIN_ENV, &domain.domain)
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    std::thread::sleep(Duration::from_secs(3));
    // Power lost: no chance to write the summary.
    recorder.0.kill().unwrap();
    recorder.0.wait().unwrap();
    assert!(sim.wait_for(Duration::from_secs(30)).is_some_and(|s| s.success()));
    drop(sim);
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());

    let bytes = std::fs::read(&mcap).unwrap();
    assert!(bytes.len() > 10_000, "{} bytes", bytes.len());
    assert!(!matches!(mcap::Summary::read(&bytes), Ok(Some(_))), "a killed recorder writes no summary");
    let config_path = dir.path().join("config.toml");
    std::fs::write(&config_path, &config).unwrap();
    let out = Command::new(common::live::fusiond())
        .args(["replay", "--config"])
        .arg(&config_path)
        .arg("--input")
        .arg(&mcap)
        .arg("--output")
        .arg(dir.path().join("replayed.jsonl"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("was cut off"), "{stderr}");
    // About 2 s at 200 Hz reached the file before the kill (flushed every 0.5 s).
    let replayed = std::fs::read_to_string(dir.path().join("replayed.jsonl")).unwrap().lines().count();
    assert!(replayed >= 300, "{replayed} snapshots replayed\n{stderr}");
    // Compared with the live run: what both have is equal, and the cut is
    // said, not taken for a difference.
    let out = Command::new(common::live::fusiond())
        .args(["replay", "--compare", "--config"])
        .arg(&config_path)
        .arg("--input")
        .arg(&mcap)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("all equal bit for bit") && stderr.contains("the recording was cut"), "{stderr}");

    a_damaged_chunk_ends_the_replay_there(dir.path(), &config_path, &bytes, replayed);

    let plot = Command::new(workspace_bin("fusionctl"))
        .args(["plot", "--input"])
        .arg(&mcap)
        .arg("--output-dir")
        .arg(dir.path().join("report"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&plot.stderr);
    assert!(plot.status.success(), "{stderr}");
    assert!(stderr.contains("was cut off"), "{stderr}");
    assert!(dir.path().join("report").read_dir().unwrap().count() > 0);
}

#[test]
fn a_recorder_without_fusiond_gives_up_after_its_duration() {
    let domain = TestDomain::new("cut-none");
    let dir = tempfile::tempdir().unwrap();
    let started = Instant::now();
    let out = Command::new("timeout")
        .arg("60")
        .arg(workspace_bin("fusionctl"))
        .args(["record", "--namespace", &domain.namespace, "--duration", "2", "--output"])
        .arg(dir.path().join("none.mcap"))
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    assert!(stderr.contains("no fusiond ran in namespace") && stderr.contains("2.0 s of --duration"), "{stderr}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// 16 bytes of 0xff over the sizes in the header of a chunk in the middle of
/// `bytes`: the replay reads the samples before it, says where the damage is,
/// and does not abort.
fn a_damaged_chunk_ends_the_replay_there(dir: &std::path::Path, config: &std::path::Path, bytes: &[u8], whole: usize) {
    // The chunk records' offsets, from the records' framing (opcode, u64 length).
    let mut chunks = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if bytes[at] == 0x06 {
            chunks.push(at);
        }
        at += 9 + len;
    }
    assert!(chunks.len() >= 4, "{} chunks", chunks.len());
    let damaged_at = chunks[chunks.len() / 2];
    let mut damaged = bytes.to_vec();
    damaged[damaged_at + 9 + 16..damaged_at + 9 + 32].fill(0xff);
    let path = dir.join("damaged.mcap");
    std::fs::write(&path, &damaged).unwrap();
    let out = Command::new(common::live::fusiond())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--input")
        .arg(&path)
        .arg("--output")
        .arg(dir.join("damaged.jsonl"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The damage is the exit status (4), and the loss is said.
    assert_eq!(out.status.code(), Some(fusion_shared::exit::DAMAGED.into()), "{stderr}");
    assert!(stderr.contains(&format!("is damaged at byte {damaged_at}")), "{stderr}");
    assert!(stderr.contains(&format!("the {} bytes from the damage", bytes.len() - damaged_at)), "{stderr}");
    let replayed = std::fs::read_to_string(dir.join("damaged.jsonl")).unwrap().lines().count();
    assert!(replayed > 0 && replayed < whole, "{replayed} of {whole}\n{stderr}");
}
