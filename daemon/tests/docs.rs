//! The user guide (`docs/`, an mdBook) against the code it describes: pages that
//! are generated from the code, and pages that must name every kind.

use std::path::PathBuf;

use fusion_daemon::config::default_config_text;
use fusion_shared::SampleKind;

fn docs() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs")
}

/// `docs/config-reference.md` is `fusiond print-config`'s output in a TOML
/// block: the one source of every default ([`UPDATE`] rewrites it).
#[test]
fn the_configuration_reference_is_print_config() {
    generated_part(&docs().join("config-reference.md"), "```toml\n", "```", &default_config_text());
}

/// Whether the generated files are to be rewritten rather than checked
/// (`FUSION_UPDATE_GENERATED=1`, which the mirrors' test reads too).
fn updating() -> bool {
    std::env::var_os("FUSION_UPDATE_GENERATED").is_some()
}

/// The command that rewrites every generated file: the mirrors and these pages.
const UPDATE: &str = "FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs";

/// The part of `page` between `begin` and `end`, replaced by `text` when
/// [`updating`], otherwise checked to be `text`.
fn generated_part(path: &std::path::Path, begin: &str, end: &str, text: &str) {
    let page = std::fs::read_to_string(path).unwrap();
    let start = page.find(begin).unwrap_or_else(|| panic!("{} has no {begin:?}", path.display())) + begin.len();
    let stop = start + page[start..].find(end).unwrap_or_else(|| panic!("{} has no {end:?}", path.display()));
    if updating() {
        std::fs::write(path, format!("{}{text}{}", &page[..start], &page[stop..])).unwrap();
        return;
    }
    assert!(page[start..stop] == *text, "{} is not what the code gives; run {UPDATE}", path.display());
}

/// `docs/sensor-kinds.md`'s table and sections, from the kind list and what
/// each kind declares: its code, name and wire type, the values one sample
/// gives an update, whether each model of the model list fuses it, and its
/// health timeout; then each kind's own section, `docs/kinds/<kind>.md`.
fn sensor_kinds_text() -> String {
    use fusion_core::measurement::Steps;
    use std::fmt::Write as _;
    macro_rules! models {
        ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident, $params:ident, $cov:literal, [$($layout:expr),* $(,)?];)*) => {
            [$(($name, <fusion_core::model::$module::$ty as Steps>::accepts as fn(SampleKind) -> bool)),*]
        };
    }
    let models = fusion_shared::for_each_model!(models);
    struct Types(Vec<&'static str>);
    impl fusion_shared::KindVisitor for Types {
        fn visit<T: fusion_shared::WireSample>(&mut self) {
            self.0.push(std::any::type_name::<T>().rsplit("::").next().unwrap());
        }
    }
    let mut types = Types(Vec::new());
    SampleKind::visit_all(&mut types);
    let health = fusion_core::health::HealthConfig::default();
    let mut t = String::from("\n| code | kind | wire type | values fused |");
    for (name, _) in &models {
        write!(t, " `{name}` |").unwrap();
    }
    t.push_str(" stale after |\n|---|---|---|---|");
    t.push_str(&"---|".repeat(models.len() + 1));
    t.push('\n');
    for (&kind, ty) in SampleKind::ALL.iter().zip(&types.0) {
        let name = kind.name();
        let dim = match kind.innovation_dim() {
            0 => "drives the propagation".to_string(),
            n => n.to_string(),
        };
        write!(t, "| {} | `{name}` | `{ty}` | {dim} |", kind as u8).unwrap();
        for (_, accepts) in &models {
            t.push_str(if accepts(kind) { " yes |" } else { " refused at start-up |" });
        }
        writeln!(t, " {} s |", health.timeout_ns(kind) as f64 * 1e-9).unwrap();
    }
    t.push_str("\n\"Stale after\" is the default of `[health] <kind>_timeout_ns`. At equal time the IMU\n");
    t.push_str("goes first, then positions and geodetic fixes, then the rest.\n");
    for &kind in SampleKind::ALL {
        write!(t, "\n{{{{#include kinds/{}.md}}}}\n", kind.name()).unwrap();
    }
    t.push('\n');
    t
}

/// `docs/sensor-kinds.md` is generated from the kind list (its table, and
/// the include of each kind's section), and each kind has its section,
/// `docs/kinds/<kind>.md`, headed by its name; no section is of a kind not in
/// the list.
#[test]
fn the_sensor_kinds_page_is_the_kind_list() {
    let begin = "<!-- Generated from the kind list: do not edit down to the end mark. -->\n";
    generated_part(&docs().join("sensor-kinds.md"), begin, "<!-- end of the generated part -->", &sensor_kinds_text());
    for &kind in SampleKind::ALL {
        let path = docs().join("kinds").join(format!("{}.md", kind.name()));
        let section = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e}: every kind has its section in the guide", path.display()));
        assert!(
            section.starts_with(&format!("## {}\n", kind.name())),
            "{} is not headed `## {}`",
            path.display(),
            kind.name()
        );
    }
    for entry in std::fs::read_dir(docs().join("kinds")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        let kind = name.strip_suffix(".md").unwrap_or(&name);
        assert!(SampleKind::ALL.iter().any(|k| k.name() == kind), "docs/kinds/{name} is not of a kind in the list");
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
