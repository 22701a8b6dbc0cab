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
