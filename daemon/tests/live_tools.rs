//! The command-line tools against a real daemon: `fusion-sim run --input FILE`
//! feeding fusiond while `fusionctl echo` records, compared with `fusiond replay`.

mod common;

use std::process::{Command, Stdio};

use common::live::{Daemon, TestDomain, workspace_bin};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_shared::Sample;
use fusion_shared::service::DOMAIN_ENV;

fn config() -> String {
    common::linear_config(Some(0.999)).replace("[100, 100, 100, 10, 10, 10]", "[100, 100, 100, 225, 225, 225]")
}

/// Feeds `samples` from a file with fusion-sim while fusionctl echo records;
/// returns the echo lines and the replay lines of the same file.
fn sim_into_daemon_with_echo(
    tag: &str,
    samples: &[Sample],
) -> (Vec<serde_json::Value>, Vec<fusion_daemon::replay::OutputLine>) {
    let domain = TestDomain::new(tag);
    let mut daemon = Daemon::start(&domain, &config(), "event");
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("drive.jsonl");

    let echo_out = dir.path().join("echo.jsonl");
    let mut echo = Command::new(workspace_bin("fusionctl"))
        .args(["echo", "--namespace", &domain.namespace, "--idle-timeout", "30"])
        .env(DOMAIN_ENV, &domain.domain)
        .stdout(std::fs::File::create(&echo_out).unwrap())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    // Start publishing only once echo has subscribed.
    common::live::wait_for_state_reader(&domain, "fusionctl echo");
    common::live::publish_file(&domain, &input, samples);
    // Every sample has its snapshot and the last correction has landed (a late
    // sample's lands in a snapshot of its own): then echo is stopped.
    let read = || -> Vec<serde_json::Value> {
        let text = std::fs::read_to_string(&echo_out).unwrap();
        text.lines().map_while(|l| serde_json::from_str(l).ok()).collect()
    };
    let done = |lines: &[serde_json::Value]| {
        lines.iter().filter(|e| e["input"]["kind"] != "none").count() == samples.len()
            && lines.last().is_some_and(|e| e["pending"].is_null())
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    while !done(&read()) && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(Command::new("kill").args(["-INT", &echo.id().to_string()]).status().unwrap().success());
    assert!(echo.wait().unwrap().success());
    assert!(daemon.terminate().success());
    let echoed = read();
    assert!(
        done(&echoed),
        "echo saw a snapshot of every sample and a settled last one: {} lines, last {:?}",
        echoed.len(),
        echoed.last()
    );
    (echoed, common::run_replay(dir.path(), &config(), &input, false).0)
}

fn same(echo: &serde_json::Value, line: &fusion_daemon::replay::OutputLine) -> bool {
    let nums =
        |v: &serde_json::Value| -> Vec<f64> { v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    echo["t_ns"].as_u64() == Some(line.t_ns)
        && echo["kind"] == line.kind.as_str()
        && echo["seq"].as_u64() == Some(line.seq)
        && nums(&echo["x"]) == line.x
        && nums(&echo["P"]) == line.p
        && echo["accepted"].as_bool() == line.accepted
}

fn drive(delays_ms: (u64, u64)) -> Vec<Sample> {
    let mut c = ScenarioConfig { seed: 12, duration_s: 2.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.position.delay_min_ns = delays_ms.0 * 1_000_000;
    c.position.delay_max_ns = delays_ms.1 * 1_000_000;
    c.position.outlier_probability = 0.1;
    Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect()
}

#[test]
fn sim_input_with_echo_reproduces_every_replay_estimate_of_a_sorted_file() {
    let mut samples = drive((0, 0));
    samples.sort_by_key(|s| (s.t_ns(), s.kind(), s.sensor(), s.seq()));
    let (echoed, replayed) = sim_into_daemon_with_echo("echo-sorted", &samples);
    assert!(echoed.iter().all(|e| e["pending"].is_null()), "in order: no snapshot waits for a correction");
    let echoed: Vec<_> = echoed.into_iter().filter(|e| e["input"]["kind"] != "none").collect();
    assert_eq!(echoed.len(), replayed.len());
    for (i, (e, r)) in echoed.iter().zip(&replayed).enumerate() {
        assert!(same(e, r), "snapshot {i} differs from replay:\n{e}\n{r:?}");
    }
    // The gate rejected the injected outliers live as in replay.
    assert!(replayed.iter().any(|l| l.accepted == Some(false)));
}

#[test]
fn sim_input_with_echo_reproduces_the_replay_final_state_of_a_late_file() {
    let samples = drive((20, 120));
    let (echoed, replayed) = sim_into_daemon_with_echo("echo-late", &samples);
    let landed = echoed
        .windows(2)
        .filter(|w| !w[0]["pending"].is_null() && w[1]["pending"].is_null() && w[1]["input"]["kind"] == "none")
        .count();
    assert!(landed > 0, "corrections landed in snapshots of their own");
    assert!(same(echoed.last().unwrap(), replayed.last().unwrap()), "final state differs");
    assert!(echoed.iter().any(|e| e["input"]["replayed"].as_u64() > Some(0)), "positions were late");
    assert!(echoed.iter().any(|e| !e["pending"].is_null()), "and were corrected in the background");
}
