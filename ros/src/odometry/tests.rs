use fusion_shared::snapshot::model;

use super::*;

/// An INS snapshot at `p`, `v`, yawed `yaw`, with variance `var` on one
/// error state `at` only.
fn snapshot(p: [f64; 3], v: [f64; 3], yaw: f64, at: usize, var: f64) -> StateSnapshot {
    let mut s = StateSnapshot { model: model::INS, state_len: 16, cov_dim: 15, ..Default::default() };
    s.x[..3].copy_from_slice(&p);
    s.x[3..6].copy_from_slice(&v);
    s.x[6..10].copy_from_slice(&[(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()]);
    s.cov[at * 15 + at] = var;
    s
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn base_link_at_the_body_is_the_estimate() {
    let s = snapshot([1.0, 2.0, 3.0], [0.5, 0.0, 0.0], 0.3, 0, 0.04);
    let (o, tf) = odometry(&s, &BaseLink::new([0.0; 3], [0.0; 3]), &Rate::default(), 7, "odom", "base_link").unwrap();
    let p = &o.pose.pose.position;
    assert_eq!((p.x, p.y, p.z), (1.0, 2.0, 3.0));
    assert!(close(o.pose.pose.orientation.z, 0.15f64.sin()));
    // The world velocity in the body's axes: yawed 0.3 rad.
    let v = &o.twist.twist.linear;
    assert!(close(v.x, 0.5 * 0.3f64.cos()) && close(v.y, -0.5 * 0.3f64.sin()), "{v:?}");
    assert_eq!(o.pose.covariance[0][0], 0.04);
    assert_eq!((o.header.sec, o.header.nanosec, o.header.frame_id.as_str()), (0, 7, "odom"));
    assert_eq!((tf.header.frame_id.as_str(), tf.child_frame_id.as_str()), ("odom", "base_link"));
    assert_eq!(tf.transform.translation, o.pose.pose.position);
}

/// base_link 1 m ahead of the IMU: a yaw error moves it sideways (variance
/// `1² σ²`), and a forward speed's yaw error is a sideways speed error.
#[test]
fn a_lever_arm_maps_yaw_error_to_position_and_velocity() {
    let s = snapshot([0.0; 3], [2.0, 0.0, 0.0], 0.0, 8, 0.01);
    let base = BaseLink::new([1.0, 0.0, 0.0], [0.0; 3]);
    let (o, _) = odometry(&s, &base, &Rate::default(), 0, "odom", "base_link").unwrap();
    assert_eq!(o.pose.pose.position.x, 1.0);
    assert!(close(o.pose.covariance[1][1], 0.01), "{:?}", o.pose.covariance);
    assert!(close(o.pose.covariance[5][5], 0.01));
    assert!(close(o.twist.covariance[1][1], 4.0 * 0.01), "{:?}", o.twist.covariance);
    assert!(close(o.pose.covariance[0][0], 0.0));
}

/// Turning at 0.5 rad/s (bias 0.1 removed), base_link 2 m ahead moves
/// sideways at 0.8 m/s; base_link turned 90° sees it on its −x axis.
#[test]
fn a_turning_body_moves_base_link_sideways() {
    let mut s = snapshot([0.0; 3], [0.0; 3], 0.0, 0, 0.0);
    s.x[15] = 0.1;
    let rate = Rate { radps: [0.0, 0.0, 0.5], cov: [0.0; 9] };
    let (o, _) = odometry(&s, &BaseLink::new([2.0, 0.0, 0.0], [0.0; 3]), &rate, 0, "odom", "base_link").unwrap();
    assert!(close(o.twist.twist.linear.y, 0.8) && close(o.twist.twist.angular.z, 0.4), "{:?}", o.twist.twist);
    let turned = BaseLink::new([2.0, 0.0, 0.0], [0.0, 0.0, 90.0]);
    let (o, _) = odometry(&s, &turned, &rate, 0, "odom", "base_link").unwrap();
    assert!(close(o.twist.twist.linear.x, 0.8) && close(o.twist.twist.linear.y, 0.0), "{:?}", o.twist.twist);
}

#[test]
fn a_snapshot_without_an_estimate_gives_nothing() {
    let s = StateSnapshot::default();
    assert!(odometry(&s, &BaseLink::new([0.0; 3], [0.0; 3]), &Rate::default(), 0, "odom", "base_link").is_none());
}
