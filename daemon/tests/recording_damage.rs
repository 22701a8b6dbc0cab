//! A recording of a live run (`fusionctl record`) damaged at 22 places spread
//! over the file, three ways each (4 KiB of random bytes, one flipped bit, 16
//! bytes of 0xFF), through every tool that reads recordings: `fusiond replay`,
//! with `--compare` and with `--smooth`, and `fusionctl plot`. Each reads what
//! comes before the damage, names the damage and what was lost after it, and
//! exits with status 4 (`fusion_shared::exit::DAMAGED`); none aborts, none
//! exits 0 as if the file were whole.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::live::workspace_bin;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The damage done at one place.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Random4k,
    BitFlip,
    Ff16,
}

fn damage(clean: &[u8], at: usize, kind: Kind, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut bytes = clean.to_vec();
    match kind {
        Kind::Random4k => {
            let end = (at + 4096).min(bytes.len());
            rng.fill_bytes(&mut bytes[at..end]);
        }
        Kind::BitFlip => bytes[at] ^= 0x08,
        Kind::Ff16 => {
            let end = (at + 16).min(bytes.len());
            bytes[at..end].fill(0xff);
        }
    }
    bytes
}

fn run(tool: &Path, args: &[&str], input: &Path, extra: &[&std::ffi::OsStr]) -> Output {
    let out = Command::new("prlimit")
        .args(["--as=1073741824", "--", "timeout", "120"])
        .arg(tool)
        .args(args)
        .arg(input)
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code().is_some_and(|c| c != 124), "{args:?}: {:?}\n{stderr}", out.status);
    out
}

#[test]
fn a_recording_damaged_anywhere_is_read_up_to_the_damage_and_says_what_was_lost() {
    let dir = tempfile::tempdir().unwrap();
    let config_text = format!("{}\n{}", common::linear_config(Some(0.999)), common::live::RECORDED_TIME);
    let clean = std::fs::read(common::live::record_drive(dir.path(), &config_text)).unwrap();
    let config = dir.path().join("config.toml");
    std::fs::write(&config, &config_text).unwrap();
    let fusiond = Path::new(env!("CARGO_BIN_EXE_fusiond"));
    let fusionctl = workspace_bin("fusionctl");
    // The clean file: every tool reads it whole, exit 0.
    let whole = dir.path().join("whole.jsonl");
    let clean_path = dir.path().join("clean.mcap");
    std::fs::write(&clean_path, &clean).unwrap();
    let out = run(
        fusiond,
        &["replay", "--config", config.to_str().unwrap(), "--input"],
        &clean_path,
        &["--output".as_ref(), whole.as_os_str()],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let whole_text = std::fs::read_to_string(&whole).unwrap();
    let whole = whole_text.lines().count();

    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let (mut cases, mut lost) = (0, 0);
    for place in 0..22 {
        // Past the magic, up to the last byte.
        let at = 8 + place * (clean.len() - 9) / 21;
        for kind in [Kind::Random4k, Kind::BitFlip, Kind::Ff16] {
            let what = format!("{kind:?} at byte {at} of {}", clean.len());
            let path = dir.path().join("damaged.mcap");
            std::fs::write(&path, damage(&clean, at, kind, &mut rng)).unwrap();
            let output = dir.path().join("damaged.jsonl");
            let _ = std::fs::remove_file(&output);
            let replay = ["replay", "--config", config.to_str().unwrap(), "--input"];
            for extra in
                [&["--output".as_ref(), output.as_os_str()][..], &["--compare".as_ref()], &["--smooth".as_ref()]]
            {
                let out = run(fusiond, &replay, &path, extra);
                let stderr = String::from_utf8_lossy(&out.stderr);
                assert_eq!(out.status.code(), Some(4), "replay {extra:?}, {what}: {stderr}");
                assert!(stderr.contains("is damaged at byte"), "replay {extra:?}, {what}: {stderr}");
                assert!(stderr.contains("bytes from the damage to the end of the file are not read"), "{stderr}");
            }
            // What comes before the damage was replayed, exactly as from the
            // whole file (all of it for damage past the last sample; where
            // that is in the file depends on the run's timing).
            let replayed = std::fs::read_to_string(&output).unwrap_or_default();
            assert!(
                whole_text.starts_with(&replayed),
                "{what}: the estimates replayed are not the whole file's first ones"
            );
            lost += u64::from(replayed.lines().count() < whole);
            let report = dir.path().join("report");
            let out = run(&fusionctl, &["plot", "--input"], &path, &["--output-dir".as_ref(), report.as_os_str()]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(4), "plot, {what}: {stderr}");
            assert!(stderr.contains("is damaged at byte") && stderr.contains("not read"), "plot, {what}: {stderr}");
            cases += 1;
        }
    }
    assert_eq!(cases, 66);
    // Damage in the header and the first records loses every estimate.
    assert!(lost >= 3, "{lost} of 66 places lost estimates");
}
