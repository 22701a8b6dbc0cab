//! fusion-ros on DDS against an independent implementation, with no ROS
//! installation: a ROS 2 node's stand-in on Cyclone DDS (one of ROS 2's own
//! middlewares, through its Python package; `tests/python/dds_node.py`) with
//! ROS 2's DDS names and types. It finds fusiond on `ros_discovery_info`,
//! plays the first seconds of robot_localization's husky bag at their pace
//! with `/clock`, and takes fusiond's odometry, TF and diagnostics; the last
//! odometry is compared with `fusiond replay` of the same messages.
//!
//! DDS discovery is multicast (SPDP, 239.255.0.1): fusion-ros and the
//! stand-in run in a network namespace of their own (`unshare -n`, `lo` up
//! with multicast), so that nothing leaves it. fusiond runs outside it (its
//! iceoryx2 services are shared memory and Unix sockets in files).

#[path = "../../daemon/tests/common/mod.rs"]
mod common;
mod ros_common;

use std::process::{Command, Stdio};
use std::time::Duration;

use common::live::{Daemon, Running, TestDomain};
use fusion_shared::service::DOMAIN_ENV;
use ros_common::{config, husky_bag, off_replay, replay};

/// Whether this process may make a network namespace (root); else `false`,
/// said on stderr (a failure where `FUSION_REQUIRE_ROOT_TESTS` is set).
fn may_unshare() -> bool {
    let ok = Command::new("unshare").args(["-n", "true"]).status().is_ok_and(|s| s.success());
    if !ok {
        let said = "`unshare -n` is refused here (it needs root): the DDS test runs its nodes in a network \
                    namespace of their own, so that DDS's multicast discovery stays in it";
        assert!(std::env::var_os("FUSION_REQUIRE_ROOT_TESTS").is_none(), "{said}");
        eprintln!("skipped: {said}");
    }
    ok
}

/// The namespace's script: `lo` up with multicast, fusion-ros in the
/// background, the stand-in, then fusion-ros stopped (its status last).
const SCRIPT: &str = r#"set -u
ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || exit 90
"$FUSION_ROS" --namespace "$NS" --config "$CONFIG" --status-interval 0.5 2> "$ROS_LOG" &
ros=$!
"$PYTHON" "$STAND_IN" "$@"
rc=$?
kill -TERM $ros
wait $ros || exit 91
exit $rc
"#;

/// Cyclone on the namespace's `lo`, multicast on (Cyclone leaves it off on a
/// loopback interface by default).
const CYCLONE: &str = r#"<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General></Domain></CycloneDDS>"#;

#[test]
fn a_ros_node_on_dds_gets_fusionds_odometry_of_its_bag() {
    let Some(bag) = husky_bag() else { return };
    if !may_unshare() {
        return;
    }
    let domain = TestDomain::new("ros-dds");
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("husky.toml");
    std::fs::write(&config_path, config("dds")).unwrap();
    let mut daemon = Daemon::start_with(&domain, &config("dds"), &[]);
    let (segment, result, log) =
        (dir.path().join("segment"), dir.path().join("result.json"), dir.path().join("ros.log"));
    let stand_in = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/dds_node.py");
    let mut run = Running(
        Command::new("unshare")
            .args(["-n", "sh", "-c", SCRIPT, "sh", "--seconds", "12", "--hostile", "--bag"])
            .arg(&bag)
            .arg("--segment")
            .arg(&segment)
            .arg("--result")
            .arg(&result)
            .env("FUSION_ROS", env!("CARGO_BIN_EXE_fusion-ros"))
            .env("NS", &domain.namespace)
            .env("CONFIG", &config_path)
            .env("ROS_LOG", &log)
            .env("PYTHON", common::python_venv())
            .env("STAND_IN", &stand_in)
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .env("CYCLONEDDS_URI", CYCLONE)
            .env(DOMAIN_ENV, &domain.domain)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let status = run.wait_for(Duration::from_secs(120)).expect("the namespace's script ends");
    let log = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(status.success(), "{status}: {log}");
    assert!(daemon.terminate().success(), "{}", daemon.stderr());
    eprintln!("{log}");
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&result).unwrap()).unwrap();

    // fusiond as `ros2 node list` sees it, with its writers (odometry, TF, diagnostics, and more).
    assert!(r["nodes"].as_array().unwrap().iter().any(|n| n == "//fusiond"), "{}", r["nodes"]);
    assert!(r["fusiond_writers"].as_u64().unwrap() >= 3, "{}", r["fusiond_writers"]);
    let odometry = &r["odometry"];
    let stamp = odometry["stamp_ns"].as_u64().unwrap();
    assert_eq!(stamp, r["last_stamp_ns"].as_u64().unwrap(), "the last odometry is of the last sample");
    assert_eq!((odometry["frame"].as_str(), odometry["child"].as_str()), (Some("odom"), Some("base_link")));
    let stamps: Vec<u64> = r["stamps"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    let all = r["all_odometry_stamps"].as_array().unwrap();
    assert!(all.iter().all(|s| stamps.binary_search(&s.as_u64().unwrap()).is_ok()), "stamps kept");
    assert_eq!(r["tf_last"], odometry["position"]);
    let names = r["diagnostics_names"].as_array().unwrap();
    for n in ["fusiond: estimate", "fusiond: ROS input", "fusiond: wheels (odometry)"] {
        assert!(names.iter().any(|x| x == n), "{n}: {names:?}");
    }

    let lines = replay(&config_path, &segment.join("segment.mcap"), dir.path());
    let (off_m, off_rad) = off_replay(odometry, &lines);
    eprintln!("DDS: live vs replay at {stamp}: {off_m:e} m, {off_rad:e} rad ({} odometry messages)", all.len());
    assert!(off_m < 1e-9 && off_rad < 1e-9, "live {odometry} vs replay: {off_m} m, {off_rad} rad");
    // The flood: counted and said once; none of it reached fusiond.
    for why in ["a flood", "pressure variance unknown"] {
        assert_eq!(log.matches(why).count(), 1, "{why:?} said once: {log}");
    }
    assert!(domain.files().is_empty(), "{:?}", domain.files());
}
