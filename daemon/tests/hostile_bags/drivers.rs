//! Drivers' messages as they send them: what a sensor's selection leaves out is never looked at.

use super::*;

/// A drone's odometry as its driver sends it: the orientation (0, 0, 0, 0),
/// NaN for the position it does not measure, a pose covariance of zeros, and
/// a twist covariance with variances only for what it measures, one of them
/// 0. With `[sensor.twist] fuse = ["vx", "vy"]` and `[sensor.pose] fuse =
/// ["z"]` (its sonar's height) nothing is refused for what was not selected;
/// the estimate is bit for bit the one of the same bag with every unselected
/// field valid (a unit quaternion, positions, variances, other values), and
/// the selected zero variances are fused as the documented floor (bit for bit
/// the bag that sends the floor).
#[test]
fn a_drones_odometry_is_fused_as_selected_whatever_it_sends_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let config = jackal().replace(
        "kinds = [\"odometry\"]\ntopic = \"/jackal_velocity_controller/odom\"",
        "kinds = [\"twist\", \"pose\"]\ntopic = \"/jackal_velocity_controller/odom\"\n[sensor.twist]\n\
         fuse = [\"vx\", \"vy\"]\n[sensor.pose]\nfuse = [\"z\"]",
    );
    assert!(config.contains("fuse = [\"vx\", \"vy\"]"), "{config}");
    // (orientation, pose covariance, twist values, twist and height covariance)
    let odometry = |t: u64, quaternion: [f64; 4], pose_var: f64, rest: f64, vy_var: f64| {
        let header = Header(Stamp((t / 1_000_000_000) as i32, (t % 1_000_000_000) as u32), "odom".into());
        let [w, x, y, z] = quaternion;
        let (east, north) = if rest == 0.0 { (f64::NAN, f64::NAN) } else { (1.0, 2.0) };
        let pose = [east, north, 0.5 + 1e-3 * (t % 7) as f64, x, y, z, w];
        let mut pose_cov = [0.0; 36];
        let mut twist_cov = [0.0; 36];
        for i in 0..6 {
            pose_cov[i * 7] = pose_var;
            twist_cov[i * 7] = rest;
        }
        (twist_cov[0], twist_cov[7], pose_cov[14]) = (0.01, vy_var, vy_var);
        let twist = [0.02, -0.01, 3.0 * rest, rest, -rest, 2.0 * rest];
        let m = Odometry(header, "base_link".into(), pose, vec36(pose_cov), twist, vec36(twist_cov));
        cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap()
    };
    let bag = |name: &str, quaternion, pose_var, rest, vy_var| {
        let m: Vec<_> = messages(300)
            .into_iter()
            .map(|(topic, t)| match topic {
                IMU_TOPIC => (topic, t, cdr_message(topic, t)),
                _ => (topic, t, odometry(t, quaternion, pose_var, rest, vy_var)),
            })
            .collect();
        let path = dir.path().join(name);
        mcap_bag(&path, &m);
        path
    };
    let run = |bag: &Path| {
        let out = replay_with(dir.path(), bag, &config);
        let said = stderr(&out);
        assert!(out.status.success(), "{said}");
        (said, lines(dir.path()))
    };
    let (said, as_sent) = run(&bag("drone.mcap", [0.0; 4], 0.0, 0.0, 0.0));
    assert!(said.contains("messages -> 60 pose, 60 twist"), "{said}");
    assert!(!said.contains("refused:"), "no message refused: {said}");
    assert!(said.contains("invalid 0,"), "{said}");
    for kind in ["twist", "pose"] {
        let fused = as_sent
            .iter()
            .filter(|l| l.contains(&format!("\"kind\":\"{kind}\"")) && l.contains("\"accepted\":true"))
            .count();
        assert!(fused > 40, "{fused} {kind} samples fused:\n{said}");
    }
    let (_, valid_elsewhere) = run(&bag("valid.mcap", [1.0, 0.0, 0.0, 0.0], 1e-3, 0.7, 0.0));
    assert_eq!(as_sent, valid_elsewhere, "what was not selected changed the estimate");
    let (_, floor) = run(&bag("floor.mcap", [0.0; 4], 0.0, 0.0, 1e-9));
    assert_eq!(as_sent, floor, "a selected zero variance is fused as 1e-9");
    let (_, larger) = run(&bag("larger.mcap", [0.0; 4], 0.0, 0.0, 1e-4));
    assert_ne!(as_sent, larger, "the selected variance counts");
}
