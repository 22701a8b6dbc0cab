//! The C API against a live fusiond: the C example (`client/examples/c/`), the
//! error checks (`client/tests/c/errors.c`) and the typed accessors
//! (`client/tests/c/typed.c`, against the Rust ones), the robot kinds
//! (`client/tests/c/robot.c`: a magnetometer, a twist, a barometer, poses) compiled with the system C
//! compiler and linked with `libfusion_client.a`; the header compiled as C++.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use common::live::{Daemon, TestDomain};
use fusion_shared::service::DOMAIN_ENV;

fn client_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../client")
}

/// `libfusion_client.a` of this build: the client library, a dependency of
/// these tests, is built with all its crate types into `deps/` beside fusiond.
fn static_lib() -> PathBuf {
    let lib = PathBuf::from(env!("CARGO_BIN_EXE_fusiond")).with_file_name("deps").join("libfusion_client.a");
    assert!(lib.exists(), "{} is not built", lib.display());
    lib
}

/// Compiles `sources` with `compiler` (`cc`, `c++`) and links the client
/// library; returns the executable.
fn compile(compiler: &str, flags: &[&str], source: &Path, out_dir: &Path) -> PathBuf {
    let exe = out_dir.join(source.file_stem().unwrap());
    let output = Command::new(compiler)
        .args(flags)
        .args(["-Wall", "-Wextra", "-Werror", "-I"])
        .arg(client_dir().join("include"))
        .arg(source)
        .arg(static_lib())
        // What rustc says a static Rust library needs (--print native-static-libs).
        .args(["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl", "-lc", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {compiler}: {e}"));
    assert!(output.status.success(), "{compiler} {}: {}", source.display(), String::from_utf8_lossy(&output.stderr));
    exe
}

fn run(exe: &Path, domain: &TestDomain, namespace: &str) -> (bool, String, String) {
    let out = Command::new(exe).arg(namespace).env(DOMAIN_ENV, &domain.domain).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_c_example_publishes_and_reads_from_a_live_fusiond() {
    let build = tempfile::tempdir().unwrap();
    let example = compile("cc", &["-std=c11"], &client_dir().join("examples/c/example.c"), build.path());

    let domain = TestDomain::new("c-api");
    let mut daemon = Daemon::start(&domain, &common::linear_config(None), "event");
    let client = domain.client();
    let mut reader = client.state_subscriber_with_buffer(16).unwrap();
    let (ok, stdout, stderr) = run(&example, &domain, &domain.namespace);
    assert!(ok, "{stdout}{stderr}");

    // fusiond processed the C program's IMU sample, and the program printed that snapshot.
    let snapshot = *reader.wait_next(Duration::from_secs(10)).unwrap().expect("a snapshot");
    assert_eq!(snapshot.input_kind, fusion_shared::SampleKind::Imu as u32);
    let imu = &snapshot.sensor_counters()[0];
    assert_eq!((imu.counts.received, imu.counts.processed, imu.counts.invalid), (1, 1, 0));
    // As an IMU of its own, not a vehicle's IMU 0.
    assert_eq!((imu.kind, imu.sensor), (fusion_shared::SampleKind::Imu as u32, 99));
    // `t_ns <t> x <x0> <x1> <x2> health <name>`, the doubles printed with 17 digits.
    let words: Vec<&str> = stdout.split_whitespace().collect();
    assert_eq!((words.len(), words[0], words[2], words[6]), (8, "t_ns", "x", "health"), "{stdout}");
    assert_eq!(words[1].parse::<u64>().unwrap(), snapshot.t_ns);
    let x: Vec<f64> = words[3..6].iter().map(|w| w.parse().unwrap()).collect();
    assert_eq!(x, snapshot.state()[..3], "{stdout}");
    assert_eq!(words[7], fusion_shared::snapshot::health::name(snapshot.health));
    drop(reader);
    drop(client);
    assert!(daemon.terminate().success());
    drop(daemon);
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

/// The guide's build command, as written, from the repository root (with this
/// build's library and a temporary output): the paths it names exist.
#[test]
fn the_guides_build_command_works_from_the_repository_root() {
    let guide = std::fs::read_to_string(client_dir().join("../docs/clients.md")).unwrap();
    let line = guide.lines().find(|l| l.starts_with("cc ")).expect("a cc command in docs/clients.md");
    assert!(line.contains("target/release/libfusion_client.a") && line.ends_with("-o example"), "{line}");
    let build = tempfile::tempdir().unwrap();
    let out = build.path().join("example");
    let command = line
        .replace("target/release/libfusion_client.a", &static_lib().display().to_string())
        .replace("-o example", &format!("-o {}", out.display()));
    let done = Command::new("sh").args(["-c", &command]).current_dir(client_dir().join("..")).output().unwrap();
    assert!(done.status.success(), "{command}: {}", String::from_utf8_lossy(&done.stderr));
    assert!(out.exists());
}

#[test]
fn bad_c_calls_get_a_status_and_a_reason() {
    let build = tempfile::tempdir().unwrap();
    let errors = compile("cc", &["-std=c11"], &client_dir().join("tests/c/errors.c"), build.path());
    let domain = TestDomain::new("c-errors");
    let (ok, stdout, stderr) = run(&errors, &domain, &domain.namespace);
    assert!(ok && stdout.ends_with("all checks held\n"), "{stdout}{stderr}");
    assert!(stdout.contains("not running in namespace"), "{stdout}");
    assert!(stdout.contains("NaN"), "{stdout}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

#[test]
fn the_header_compiles_and_links_as_cpp() {
    let build = tempfile::tempdir().unwrap();
    let exe = compile("c++", &["-std=c++17"], &client_dir().join("tests/c/header.cpp"), build.path());
    let domain = TestDomain::new("cpp");
    let (ok, stdout, stderr) = run(&exe, &domain, &domain.namespace);
    assert!(ok && stdout == "connected; health ok\n", "{stdout}{stderr}");
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}

#[test]
fn the_guide_shows_the_tested_c_example() {
    let guide = std::fs::read_to_string(client_dir().join("../docs/clients.md")).unwrap();
    let example = std::fs::read_to_string(client_dir().join("examples/c/example.c")).unwrap();
    assert!(
        guide.contains(&format!("```c\n{example}```\n")),
        "docs/clients.md's C example differs from examples/c/example.c"
    );
}

#[test]
fn the_c_typed_accessors_agree_with_the_rust_ones() {
    let build = tempfile::tempdir().unwrap();
    let typed = compile("cc", &["-std=c11"], &client_dir().join("tests/c/typed.c"), build.path());
    let path = common::typed::write_cases(build.path());
    let out = Command::new(typed).arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    common::typed::assert_agree(&String::from_utf8_lossy(&out.stdout));
}

/// A C program that publishes one sample and exits at once, run again and
/// again: every sample reaches fusiond (`fusion_publisher_free` waits until
/// fusiond could connect; without it about one in seven was lost).
#[test]
fn one_shot_c_programs_lose_no_sample() {
    let build = tempfile::tempdir().unwrap();
    let oneshot = compile("cc", &["-std=c11"], &client_dir().join("tests/c/oneshot.c"), build.path());
    let domain = TestDomain::new("c-oneshot");
    let mut daemon = Daemon::start(&domain, &common::linear_config(None), "event");
    let runs = 40u64;
    for k in 0..runs {
        let out = Command::new(&oneshot)
            .args([domain.namespace.as_str(), "42", &k.to_string()])
            .env(DOMAIN_ENV, &domain.domain)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let received = common::live::received_by(&domain, 42, runs);
    assert_eq!(received, runs, "samples of one-shot programs that reached fusiond");
    assert!(daemon.terminate().success());
}

/// The robot kinds from C: a magnetometer, a twist, a barometer and poses
/// reach an `ins` fusiond and are fused (the barometer's bias and the pose's
/// map frame set by their first samples); a NaN in a 6×6 covariance is refused
/// by the C API, a skewed quaternion by fusiond.
#[test]
fn fusiond_fuses_the_robot_kinds_c_publishes() {
    let build = tempfile::tempdir().unwrap();
    let robot =
        compile("cc", &["-std=c11", "-D_POSIX_C_SOURCE=199309L"], &client_dir().join("tests/c/robot.c"), build.path());
    let domain = TestDomain::new("c-robot");
    let mut daemon = Daemon::start(&domain, common::ROBOT_INS_CONFIG, "event");
    let (ok, stdout, stderr) = run(&robot, &domain, &domain.namespace);
    assert!(ok, "{stdout}{stderr}");
    assert!(stdout.contains("refused: twist sample with a NaN or infinite value"), "{stdout}");
    assert!(stdout.contains("published 281 samples"), "{stdout}");
    common::assert_robot_samples_fused(&domain);
    assert!(daemon.terminate().success());
}

/// Two IMUs averaged, read from C: one snapshot per instant, named after the
/// sample that completed it; an instant one IMU misses still gets its snapshot,
/// after fusiond's bounded wait.
#[test]
fn c_reads_one_snapshot_per_imu_instant() {
    let build = tempfile::tempdir().unwrap();
    let instants = compile(
        "cc",
        &["-std=c11", "-D_POSIX_C_SOURCE=199309L"],
        &client_dir().join("tests/c/instants.c"),
        build.path(),
    );
    let config = common::two_averaged_imus_config();
    let domain = TestDomain::new("c-instants");
    // Spin: the daemon never sleeps between an instant's samples (in event
    // mode an instant's snapshot also goes out when it would).
    let mut daemon = Daemon::start(&domain, &config, "spin");
    let out = Command::new(&instants)
        .args([&domain.namespace, &common::INSTANT_WAIT_NS.to_string()])
        .env(DOMAIN_ENV, &domain.domain)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(daemon.terminate().success());
    common::assert_one_snapshot_per_instant(&said);
}
