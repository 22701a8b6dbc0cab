//! Bags whose stamps jump: one far ahead, a clock set back an hour.

use super::*;

/// One message stamped an hour ahead in a bag of 2 s: `fusiond replay`
/// refuses it as a time jump, and `fusion-sim` sends it at once, out of
/// pace, for fusiond to refuse by its clock, instead of sleeping until that
/// stamp (or withholding it, a gap fusiond would count as lost).
#[test]
fn a_stamp_an_hour_ahead_is_refused_by_replay_and_by_fusion_sim() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = messages(200);
    m.insert(150, (ODOM_TOPIC, m[150].1 + 3_600_000_000_000));
    let chunk = ros1_chunk(&m);
    let bag = write(dir.path(), "ahead.bag", &ros1_bag(&[chunk]));
    let out = replay(dir.path(), &bag);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("timestamp jumps too far ahead"), "{said}");
    // An hour's sleep would be cut by the hang guard (exit 124, a failure).
    let out = sim(dir.path(), &bag);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(
        said.contains(
            "1 samples stamped more than [validation] max_jump_ns ahead of the others: published at once, not paced"
        ),
        "{said}"
    );
}

/// A robot's clock set back an hour halfway through its bag (NTP stepping a
/// wall clock): `fusiond replay` refuses the first samples after the step as
/// stepping back, then names the new timeline and fuses the rest of the bag
/// to its end (with `--smooth` too, each timeline smoothed alone); nothing
/// is dropped too late or rate-limited. `fusion-sim` publishes the new
/// timeline on from where the old one stopped, neither flooding the past nor
/// sleeping.
#[test]
fn a_clock_set_back_an_hour_mid_bag_starts_a_new_timeline_in_replay_and_in_fusion_sim() {
    let dir = tempfile::tempdir().unwrap();
    let hour = 3_600_000_000_000;
    let mut m = messages(600);
    let half = m.len() / 2;
    m[..half].iter_mut().for_each(|(_, t)| *t += hour);
    let last_stamp = m.last().unwrap().1;
    let bag = write(dir.path(), "stepped.bag", &ros1_bag(&[ros1_chunk(&m)]));
    let out = replay(dir.path(), &bag);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("timestamp steps too far back behind the others"), "{said}");
    assert!(said.contains("the input's clock was set back by 3599.990 s at message"), "{said}");
    assert!(said.contains("invalid 100,") && said.contains("dropped too late 0,"), "{said}");
    assert!(said.contains("rate-limited 0,"), "{said}");
    let out_lines = lines(dir.path());
    let end: serde_json::Value = serde_json::from_str(out_lines.last().unwrap()).unwrap();
    assert_eq!(end["t_ns"].as_u64(), Some(last_stamp), "the new timeline is fused to the bag's end");
    let smoothed = Command::new(env!("CARGO_BIN_EXE_fusiond"))
        .args(["replay", "--smooth", "--config"])
        .arg(dir.path().join("config.toml"))
        .arg("--input")
        .arg(&bag)
        .arg("--output")
        .arg(dir.path().join("smoothed.jsonl"))
        .output()
        .unwrap();
    assert!(smoothed.status.success(), "{}", stderr(&smoothed));
    let text = std::fs::read_to_string(dir.path().join("smoothed.jsonl")).unwrap();
    assert_eq!(text.lines().count(), out_lines.len());
    let out = sim(dir.path(), &bag);
    let said = stderr(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("100 samples stamped more than [validation] max_jump_ns back behind the others"), "{said}");
    assert!(said.contains("the clock was set back by 3599.990 s at message"), "{said}");
}
