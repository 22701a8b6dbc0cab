//! The user guide (`docs/`, an mdBook) against the code it describes: pages that
//! are generated from the code, and pages that must name every kind.

use std::path::PathBuf;

use fusion_daemon::config::default_config_text;
use fusion_shared::SampleKind;

fn docs() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs")
}

/// `docs/config-reference.md` is `fusiond print-config`'s output in a TOML
/// block: the one source of every default. `FUSION_UPDATE_DOCS=1` rewrites it.
#[test]
fn the_configuration_reference_is_print_config() {
    let path = docs().join("config-reference.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let start = page.find("```toml\n").expect("a ```toml block") + "```toml\n".len();
    let end = start + page[start..].find("```").expect("the block's end");
    let text = default_config_text();
    if std::env::var_os("FUSION_UPDATE_DOCS").is_some() {
        std::fs::write(&path, format!("{}{text}{}", &page[..start], &page[end..])).unwrap();
        return;
    }
    assert!(
        page[start..end] == text,
        "docs/config-reference.md differs from `fusiond print-config`; run \
         FUSION_UPDATE_DOCS=1 cargo test -p fusion-daemon --test docs"
    );
}

/// `docs/sensor-kinds.md` has a row in its table and a section for every kind,
/// with the kind's code and the JSON names of its fields.
#[test]
fn every_sensor_kind_has_its_section() {
    let page = std::fs::read_to_string(docs().join("sensor-kinds.md")).unwrap();
    for &kind in SampleKind::ALL {
        let name = kind.name();
        assert!(page.contains(&format!("\n## {name}\n")), "docs/sensor-kinds.md has no section `## {name}`");
        assert!(
            page.contains(&format!("\n| {} | `{name}` |", kind as u8)),
            "docs/sensor-kinds.md's table has no row for {name} (code {})",
            kind as u8
        );
    }
}

/// The README's and the clients page's Rust snippets are the same, and they
/// publish in the example namespace with an IMU id of their own: a reader who
/// runs them beside a vehicle's fusiond (namespace `fusion`, IMU 0) must not
/// feed its filter.
#[test]
fn the_readme_snippet_does_not_publish_into_a_vehicle() {
    let readme = std::fs::read_to_string(docs().join("../README.md")).unwrap();
    let clients = std::fs::read_to_string(docs().join("clients.md")).unwrap();
    let snippet = |text: &str| -> String {
        let start = text.find("```rust\n").expect("a Rust snippet");
        let end = start + text[start..].find("\n```\n").unwrap();
        text[start..end].to_string()
    };
    let readme = snippet(&readme);
    assert_eq!(readme, snippet(&clients), "the README's snippet is the clients page's");
    assert!(readme.contains("Client::connect(\"fusion-example\")"), "{readme}");
    assert!(!readme.contains("imu_publisher(0)"), "{readme}");
}

/// Every `cargo bench -p PACKAGE … --bench NAME` the guide and the README give
/// names a package that has that benchmark (docs/zenoh.md named the daemon's).
#[test]
fn every_bench_command_names_a_bench_of_its_package() {
    let root = docs().join("..");
    let mut texts = vec![std::fs::read_to_string(root.join("README.md")).unwrap()];
    for entry in std::fs::read_dir(docs()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            texts.push(std::fs::read_to_string(path).unwrap());
        }
    }
    let mut checked = 0;
    for text in texts {
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        for (at, _) in text.match_indices("cargo bench ") {
            let command = text[at..].split('`').next().unwrap();
            let words: Vec<&str> = command.split(' ').collect();
            let after = |flag: &str| words.iter().position(|w| *w == flag).and_then(|i| words.get(i + 1)).copied();
            let (Some(package), Some(bench)) = (after("-p"), after("--bench")) else { continue };
            let dir = package.strip_prefix("fusion-").unwrap_or(package);
            let manifest = std::fs::read_to_string(root.join(dir).join("Cargo.toml"))
                .unwrap_or_else(|_| panic!("{command:?}: no package {package}"));
            assert!(
                manifest.contains(&format!("[[bench]]\nname = \"{bench}\"")),
                "{command:?}: {package} has no bench {bench}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 3, "{checked} bench commands found");
}

/// The ground-robot page's configuration is one fusiond takes, and it is what
/// the page says: `ins`, the constraint at its lever arm and at every speed, the
/// AHRS's attitude and the topics of robot_localization's Husky bag (the bag
/// itself is replayed with it in `ros_bags.rs`).
#[test]
fn the_ground_robot_page_configuration_is_valid() {
    let page = std::fs::read_to_string(docs().join("ground-robots.md")).unwrap();
    let start = page.find("```toml\n").expect("a ```toml block") + "```toml\n".len();
    let end = start + page[start..].find("```").unwrap();
    let config = fusion_daemon::config::Config::parse(&page[start..end]).unwrap_or_else(|e| panic!("{e}"));
    let fusion_daemon::config::ModelConfig::Ins(p) = &config.model else { panic!("not ins") };
    let c = p.constraints.expect("the constraint");
    assert_eq!((c.min_speed_mps, c.lever_arm_m), (0.0, [0.0, 0.3, -0.52]));
    let topics: Vec<_> = fusion_daemon::replay::bag::routes(&config).into_iter().map(|r| (r.topic, r.kinds)).collect();
    use fusion_shared::SampleKind::{Attitude, Imu, Odometry};
    assert_eq!(
        topics,
        [
            ("/imu/data".to_string(), vec![Imu, Attitude]),
            ("/husky_velocity_controller/odom".to_string(), vec![Odometry])
        ]
    );
}
