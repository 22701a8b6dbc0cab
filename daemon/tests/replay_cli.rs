//! `fusiond replay` and `fusiond print-config` as a user runs them: bad input,
//! exit statuses, streaming.

mod common;

use std::io::{BufRead, Read, Write};
use std::process::Command;

use fusion_daemon::config::Config;
use fusion_daemon::replay::replay;

fn fusiond() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fusiond"))
}

const GOOD_IMU: &str =
    r#"{"imu": {"t_ns": 1000000, "sensor": 0, "seq": 0, "accel": [0.1, 0.2, 0.0], "gyro": [0, 0, 0]}}"#;
const GOOD_POS: &str =
    r#"{"position": {"t_ns": 1100000, "sensor": 1, "seq": 0, "pos": [1, 2, 3], "cov": [1, 0, 0, 0, 1, 0, 0, 0, 1]}}"#;

#[test]
fn every_kind_of_bad_line_is_rejected_with_its_line_number_and_reason() {
    let bad = [
        ("not json at all", "expected"),
        (
            r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [1, 2], "gyro": [0, 0, 0]}}"#,
            "invalid length 2",
        ),
        (
            r#"{"position": {"t_ns": 2000000, "sensor": 1, "seq": 1, "pos": [1, 2, 3], "cov": [1, 0, 0, 0, 1, 0, 0, 0]}}"#,
            "invalid length 8",
        ),
        (
            r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [1e999, 0, 0], "gyro": [0, 0, 0]}}"#,
            "number out of range",
        ),
        (
            r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [NaN, 0, 0], "gyro": [0, 0, 0]}}"#,
            "expected value",
        ),
        (r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [0, 0, 0]}}"#, "missing field `gyro`"),
        (r#"{"imu": {"t_ns": -5, "sensor": 0, "seq": 1, "accel": [0, 0, 0], "gyro": [0, 0, 0]}}"#, "invalid value"),
        (r#"{"lidar": {"t_ns": 2000000}}"#, "unknown variant `lidar`"),
        (
            r#"{"position": {"t_ns": 2000000, "sensor": 1, "seq": 1, "pos": [1, 2, 3], "cov": [1, 0.5, 0, 0, 1, 0, 0, 0, 1]}}"#,
            "covariance not symmetric",
        ),
        (
            r#"{"position": {"t_ns": 2000000, "sensor": 1, "seq": 1, "pos": [1, 2, 3], "cov": [1, 2, 0, 2, 1, 0, 0, 0, 1]}}"#,
            "covariance not positive definite",
        ),
        (
            r#"{"position": {"t_ns": 2000000, "sensor": 1, "seq": 1, "pos": [1, 2, 3], "cov": [0, 0, 0, 0, 0, 0, 0, 0, 0]}}"#,
            "covariance not positive definite",
        ),
        (
            r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [0, 0, 300], "gyro": [0, 0, 0]}}"#,
            "beyond the sensor range",
        ),
        (
            r#"{"imu": {"t_ns": 2000000, "sensor": 0, "seq": 1, "accel": [0, 0, 9.8], "gyro": [50, 0, 0]}}"#,
            "beyond the sensor range",
        ),
    ];
    let mut input = format!("{GOOD_IMU}\n{GOOD_POS}\n");
    for (line, _) in &bad {
        input.push_str(line);
        input.push('\n');
    }
    input.push('\n'); // a blank line is not a sample
    input.push_str(r#"{"imu": {"t_ns": 3000000, "sensor": 0, "seq": 2, "accel": [0, 0, 0], "gyro": [0, 0, 0]}}"#);
    input.push('\n');

    let config = Config::parse(&common::linear_config(None)).unwrap();
    let mut out = Vec::new();
    let summary = replay(&config, input.as_bytes(), Some(&mut out), false).unwrap();
    assert_eq!((summary.read, summary.counts.processed, summary.counts.invalid), (16, 3, 13), "{summary}");
    // At most 10 are described one by one, with line numbers (1-based) and reasons.
    assert_eq!(summary.invalid_lines.len(), 10);
    for (i, ((line_no, reason), (_, needle))) in summary.invalid_lines.iter().zip(&bad).enumerate() {
        assert_eq!(*line_no, i as u64 + 3);
        assert!(reason.contains(needle), "line {line_no}: {reason:?} lacks {needle:?}");
    }
    assert!(summary.to_string().contains("and 3 more invalid lines"), "{summary}");

    // The bad lines changed nothing: same estimates as the good lines alone.
    let good_only: String = input
        .lines()
        .filter(|l| l.contains("\"seq\": 0") || l.contains("\"seq\": 2"))
        .map(|l| format!("{l}\n"))
        .collect();
    let mut clean = Vec::new();
    replay(&config, good_only.as_bytes(), Some(&mut clean), false).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), String::from_utf8(clean).unwrap());
}

#[test]
fn duplicates_and_too_late_samples_are_counted_in_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    for i in 0..300u64 {
        lines.push(format!(
            r#"{{"imu": {{"t_ns": {}, "sensor": 0, "seq": {i}, "accel": [0, 0, 0], "gyro": [0, 0, 0]}}}}"#,
            1_000_000_000 + i * 10_000_000
        ));
    }
    lines.push(lines[299].clone()); // duplicate
    lines.push(GOOD_POS.replace("1100000", "1100000000")); // 2 s older than the newest: too late
    let input = dir.path().join("in.jsonl");
    std::fs::write(&input, lines.join("\n")).unwrap();
    let (out, stderr) = common::run_replay(dir.path(), &common::linear_config(None), &input, false);
    assert_eq!(out.len(), 300);
    assert!(stderr.contains("read 302 lines: processed 300"), "{stderr}");
    assert!(stderr.contains("dropped too late 1, duplicates 1"), "{stderr}");
}

#[test]
fn exit_status_is_an_error_only_when_nothing_can_work() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("c.toml");
    std::fs::write(&config, common::linear_config(None)).unwrap();
    let good = dir.path().join("good.jsonl");
    std::fs::write(&good, format!("{GOOD_IMU}\nnonsense\n")).unwrap();
    let junk = dir.path().join("junk.jsonl");
    std::fs::write(&junk, "nonsense\n{}\n").unwrap();
    let bad_config = dir.path().join("bad.toml");
    std::fs::write(&bad_config, common::linear_config(None).replace("accel_noise_std", "accel_noise")).unwrap();
    let out = dir.path().join("out.jsonl");

    let run = |config: &std::path::Path, input: &std::path::Path| {
        let o = fusiond()
            .args(["replay", "--config"])
            .arg(config)
            .arg("--input")
            .arg(input)
            .arg("--output")
            .arg(&out)
            .output()
            .unwrap();
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (ok, err) = run(&config, &good);
    assert!(ok, "{err}");
    assert!(err.contains("invalid 1") && err.contains("line 2:"), "{err}");
    let (ok, err) = run(&config, &junk);
    assert!(!ok && err.contains("no sample could be processed"), "{err}");
    let (ok, err) = run(&config, &dir.path().join("missing.jsonl"));
    assert!(!ok && err.contains("missing.jsonl"), "{err}");
    let (ok, err) = run(&bad_config, &good);
    assert!(!ok && err.contains("accel_noise"), "{err}");
    // The MCAP magic followed by garbage: what is wrong with the file, with
    // or without --config (it said "--config is needed", or "the reasons are
    // above" with nothing above).
    let garbage = dir.path().join("garbage.mcap");
    std::fs::write(&garbage, [&b"\x89MCAP0\r\n"[..], b"no recording here, only these words"].concat()).unwrap();
    let (ok, err) = run(&config, &garbage);
    assert!(!ok && err.contains("damaged at byte 8: no header record after the magic"), "{err}");
    let o = fusiond().args(["replay", "--input"]).arg(&garbage).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("no header record") && !err.contains("--config"), "{err}");
}

#[test]
fn print_config_prints_a_valid_commented_default() {
    let out = fusiond().arg("print-config").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("# ") && text.contains("[gating]"));
    let c = Config::parse(&text).unwrap();
    assert_eq!(c.model.kind(), "linear");
}

/// An endless input generated on the fly, and an output that watches how far it
/// lags behind: without `--smooth` the estimates come out while the input is still
/// being read, at most one history window behind.
#[test]
fn replay_streams_with_memory_bounded_by_the_history() {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    static READ: AtomicU64 = AtomicU64::new(0);

    struct Generator {
        next: u64,
        end: u64,
        buf: Vec<u8>,
        pos: usize,
    }
    impl Read for Generator {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            let n = self.fill_buf()?.len().min(out.len());
            out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
            self.consume(n);
            Ok(n)
        }
    }
    impl BufRead for Generator {
        fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
            if self.pos == self.buf.len() && self.next < self.end {
                let i = self.next;
                self.next += 1;
                READ.store(i + 1, Relaxed);
                self.buf = format!(
                    "{{\"imu\": {{\"t_ns\": {}, \"sensor\": 0, \"seq\": {i}, \"accel\": [0.1, 0, 0], \"gyro\": [0, 0, 0]}}}}\n",
                    1_000_000_000 + i * 1_000_000
                )
                .into_bytes();
                self.pos = 0;
            }
            Ok(&self.buf[self.pos..])
        }
        fn consume(&mut self, n: usize) {
            self.pos += n;
        }
    }
    struct Lag {
        written: u64,
        max_lag: u64,
    }
    impl Write for Lag {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.written += b.iter().filter(|c| **c == b'\n').count() as u64;
            self.max_lag = self.max_lag.max(READ.load(Relaxed).saturating_sub(self.written));
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let config = Config::parse(&common::linear_config(None).replace("1_000_000_000", "100_000_000")).unwrap();
    let n = 200_000; // 200 s at 1 kHz
    let mut lag = Lag { written: 0, max_lag: 0 };
    let summary =
        replay(&config, Generator { next: 0, end: n, buf: Vec::new(), pos: 0 }, Some(&mut lag), false).unwrap();
    assert_eq!((summary.counts.processed, lag.written), (n, n));
    // 100 ms window at 1 kHz: ~101 entries held back, never the whole input.
    assert!(lag.max_lag <= 105, "output lagged {} samples behind the input", lag.max_lag);
}
