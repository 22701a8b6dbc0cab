//! The C and Python mirrors of the wire types, generated from the Rust
//! declarations: each kind's code and name ([`fusion_shared::for_each_sample_kind!`]),
//! each wire type's layout and line ([`fusion_shared::sample::layout`]) and the
//! snapshot's constants. One generator writes
//!
//! - `client/python/fusion_client/wire.py`: the `ctypes` classes and every constant;
//! - `client/src/capi/generated.rs`: the C API's kind constants (`FUSION_KIND_*`,
//!   `FUSION_KIND_COUNT`), one `fusion_publish_<kind>` per kind, and the model
//!   codes (`FUSION_MODEL_*`);
//! - `client/include/fusion_client.h`: cbindgen's header of the C API, with each
//!   wire type under its C name (`FusionPoseSample`).
//!
//! The committed files must be what it writes now (a diff check);
//! `FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs` rewrites them.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use fusion_shared::sample::layout::{WireField, WireLayout};
use fusion_shared::snapshot::{self, Counters, SensorCounters, StateSnapshot};
use fusion_shared::{KindVisitor, SampleHeader, SampleKind, WireSample};
use iceoryx2::prelude::ZeroCopySend;

/// One wire type as the generator needs it.
struct Wire {
    rust: &'static str,
    type_name: String,
    doc: &'static str,
    kind: Option<SampleKind>,
    fields: Vec<WireField>,
}

fn wire<T: WireLayout + ZeroCopySend>(kind: Option<SampleKind>) -> Wire {
    // SAFETY: only reads the name the type declares.
    let type_name = unsafe { <T as ZeroCopySend>::type_name() }.to_string();
    let rust = std::any::type_name::<T>().rsplit("::").next().unwrap();
    T::check().unwrap();
    Wire { rust, type_name, doc: T::DOC, kind, fields: T::fields() }
}

/// Every sample kind's wire type, in code order.
fn kinds() -> Vec<Wire> {
    struct All(Vec<Wire>);
    impl KindVisitor for All {
        fn visit<T: WireSample>(&mut self) {
            self.0.push(wire::<T>(Some(T::KIND)));
        }
    }
    let mut all = All(Vec::new());
    SampleKind::visit_all(&mut all);
    all.0
}

/// `text` in lines of at most `width` characters (words kept whole).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split_whitespace() {
        let line = lines.last_mut().unwrap();
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
    }
    lines
}

/// `text` as `///` lines of Rust docs.
fn rust_doc(text: &str) -> String {
    wrap(text, 110).iter().map(|l| format!("/// {l}\n")).collect()
}

/// `text` with a lower-case first letter, to follow a colon (an acronym kept: "AHRS's").
fn lower_first(text: &str) -> String {
    let mut chars = text.chars();
    match (chars.next(), chars.next()) {
        (Some(a), Some(b)) if !b.is_uppercase() => a.to_lowercase().chain(text[a.len_utf8()..].chars()).collect(),
        _ => text.to_string(),
    }
}

/// "An" before a vowel, else "A".
fn article(word: &str) -> &'static str {
    if word.starts_with(['a', 'e', 'i', 'o', 'u']) { "An" } else { "A" }
}

fn upper(name: &str) -> String {
    name.to_uppercase()
}

/// A `ctypes` class.
fn class(out: &mut String, w: &Wire, base: &str) {
    writeln!(out, "\n\nclass {}({base}):", w.rust).unwrap();
    let doc = format!("{} (``{}``).", w.doc.trim_end_matches('.').replace('`', "``"), w.type_name);
    writeln!(out, "    \"\"\"{}\"\"\"\n", wrap(&doc, 100).join("\n    ")).unwrap();
    writeln!(out, "    TYPE_NAME = \"{}\"", w.type_name).unwrap();
    if let Some(k) = w.kind {
        writeln!(out, "    KIND = KIND_{}", upper(k.name())).unwrap();
    }
    out.push_str("    _fields_ = [\n");
    for f in &w.fields {
        let ty = f.scalar.ctypes();
        let count = match f.count {
            1 => String::new(),
            n if n == snapshot::MAX_STATE && f.name == "x" => " * MAX_STATE".into(),
            n if n == snapshot::MAX_COV * snapshot::MAX_COV => " * MAX_COV_LEN".into(),
            n if n == snapshot::MAX_SENSORS && f.name == "sensors" => " * MAX_SENSORS".into(),
            n if n == snapshot::rejection::MAX && f.name == "rejections" => " * MAX_REJECTIONS".into(),
            n => format!(" * {n}"),
        };
        writeln!(out, "        (\"{}\", {ty}{count}),", f.name).unwrap();
    }
    out.push_str("    ]\n");
}

/// A code -> name table.
fn table<K: std::fmt::Display, V: AsRef<str>>(name: &str, entries: impl IntoIterator<Item = (K, V)>) -> String {
    let body: Vec<String> = entries.into_iter().map(|(k, v)| format!("    {k}: \"{}\",", v.as_ref())).collect();
    format!("{name} = {{\n{}\n}}\n", body.join("\n"))
}

/// `client/python/fusion_client/wire.py`.
fn python() -> String {
    use fusion_shared::snapshot::{aux, health, rejection};
    let kinds = kinds();
    let mut out = String::from(
        "\"\"\"ctypes mirrors of fusiond's wire types (crate ``fusion-shared``), and its constants.\n\n\
         Generated from the Rust declarations by\n\
         ``FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs``: do not edit.\n\
         Same fields, same layout, same versioned type names as the Rust types, so that\n\
         iceoryx2 opens fusiond's services with them. ``tests/check_layout.py`` checks\n\
         every size, offset and type name against the Rust build.\n\"\"\"\n\nimport ctypes\n\n",
    );
    writeln!(out, "MAX_STATE = {}", snapshot::MAX_STATE).unwrap();
    writeln!(out, "MAX_COV = {}", snapshot::MAX_COV).unwrap();
    out.push_str("MAX_COV_LEN = MAX_COV * MAX_COV\n");
    writeln!(out, "MAX_SENSORS = {}\n", snapshot::MAX_SENSORS).unwrap();
    out.push_str("#: Sample kind codes (``SampleHeader.kind``), and their service names.\n");
    for w in &kinds {
        let k = w.kind.unwrap();
        writeln!(out, "KIND_{} = {}", upper(k.name()), k as u32).unwrap();
    }
    out.push_str("#: Kind codes in use: ``1..=KIND_COUNT``.\n");
    writeln!(out, "KIND_COUNT = {}", SampleKind::COUNT).unwrap();
    out.push_str(&table("KIND_NAMES", SampleKind::ALL.iter().map(|&k| (k as u32, k.name()))));
    out.push_str("#: ``StateSnapshot.input_kind`` of a snapshot sent because the health changed.\n");
    writeln!(out, "INPUT_NONE = {}\n", snapshot::INPUT_NONE).unwrap();
    let states = [health::INITIALISING, health::OK, health::DEGRADED];
    out.push_str(&table("HEALTH_NAMES", states.map(|s| (s, health::name(s)))));
    out.push_str("#: ``GeodeticSample.fix_type`` codes and their names.\n");
    for (code, name) in fusion_shared::fix::NAMES.iter().enumerate() {
        writeln!(out, "FIX_{} = {code}", upper(name)).unwrap();
    }
    out.push_str(&table("FIX_NAMES", fusion_shared::fix::NAMES.iter().enumerate()));
    out.push_str(&table("MODEL_NAMES", snapshot::Model::ALL.iter().map(|m| (m.code(), m.name()))));
    out.push_str("#: Each model's own state length and covariance side (before auxiliary states).\n");
    let dims: Vec<String> =
        snapshot::Model::ALL.iter().map(|m| format!("{}: [{}, {}]", m.code(), m.state_len(), m.cov_dim())).collect();
    writeln!(out, "MODEL_DIMS = {{{}}}", dims.join(", ")).unwrap();
    out.push_str("#: ``StateSnapshot.aux_states`` bits: auxiliary states after the model's own, in bit order.\n");
    writeln!(out, "AUX_ODOMETRY_SCALE = {}", aux::ODOMETRY_SCALE).unwrap();
    writeln!(out, "AUX_BARO_BIAS = {}", aux::BARO_BIAS).unwrap();
    writeln!(out, "AUX_POSE_FRAME = {}", aux::POSE_FRAME).unwrap();
    out.push_str("#: The bits of the auxiliary states each sample kind brings (0: none).\n");
    let bits: Vec<String> = SampleKind::ALL
        .iter()
        .map(|&k| format!("    KIND_{}: {},", upper(k.name()), aux::KINDS[k as usize].bits()))
        .collect();
    writeln!(out, "AUX_KIND_BITS = {{\n{}\n}}", bits.join("\n")).unwrap();
    out.push_str(&table("AUX_NAMES", aux::ALL));
    out.push_str("#: Why a sample was refused in validation: the index of ``StateSnapshot.rejections``\n");
    out.push_str("#: and ``SensorCounters.last_rejection`` (entry 0 unused).\n");
    writeln!(out, "MAX_REJECTIONS = {}", rejection::MAX).unwrap();
    for (name, code) in rejection::CONSTANTS {
        writeln!(out, "REJECTION_{name} = {code}").unwrap();
    }
    out.push_str(&table("REJECTION_NAMES", rejection::ALL));
    out.push_str(
        "\n\nclass _Wire(ctypes.Structure):\n    \"\"\"A wire type: its iceoryx2 type name is ``TYPE_NAME``.\"\"\"\n\n    \
         TYPE_NAME = \"\"\n\n    @classmethod\n    def type_name(cls) -> str:\n        return cls.TYPE_NAME\n",
    );
    class(&mut out, &wire::<SampleHeader>(None), "_Wire");
    out.push_str("\n\nclass _Sample(_Wire):\n    KIND = 0\n");
    for w in &kinds {
        class(&mut out, w, "_Sample");
    }
    let names: Vec<&str> = kinds.iter().map(|w| w.rust).collect();
    writeln!(out, "\n\nSAMPLE_TYPES = (\n    {},\n)", names.join(",\n    ")).unwrap();
    for w in [wire::<Counters>(None), wire::<SensorCounters>(None), wire::<StateSnapshot>(None)] {
        class(&mut out, &w, "_Wire");
    }
    out.push_str("\n\n#: Every mirror, for the layout check.\nALL_TYPES = (SampleHeader,) + SAMPLE_TYPES + (Counters, SensorCounters, StateSnapshot)\n");
    out
}

/// `client/src/capi/generated.rs`, before rustfmt.
fn c_kinds() -> String {
    let kinds = kinds();
    let mut out = String::from(
        "//! The C API's sample kinds (each kind's code and its publish function) and\n\
         //! models (each model's code in a snapshot).\n//!\n\
         //! Generated from the kind and model lists by `FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs`:\n\
         //! do not edit.\n\n\
         use super::FusionPublisher;\nuse super::FusionStatus;\nuse super::publish::publish;\n\n",
    );
    for w in &kinds {
        let k = w.kind.unwrap();
        let doc = format!(
            "{} {} sample (`Fusion{}`): {} Its code in `FusionSampleHeader.kind`, and the `kind` of \
             `fusion_publisher_new` and `fusion_publish`.",
            article(k.name()),
            k.name(),
            w.rust,
            lower_first(w.doc)
        );
        out.push_str(&rust_doc(&doc));
        writeln!(out, "pub const FUSION_KIND_{}: u32 = {};", upper(k.name()), k as u32).unwrap();
    }
    out.push_str("/// Kind codes in use: `1..=FUSION_KIND_COUNT` (a larger code is no kind).\n");
    writeln!(out, "pub const FUSION_KIND_COUNT: u32 = {};\n", SampleKind::COUNT).unwrap();
    for m in snapshot::Model::ALL {
        let doc = format!(
            "`FusionStateSnapshot.model`: the `{}` model ({} states, a {}×{} covariance, then the auxiliary states of \
             `aux_states`).",
            m.name(),
            m.state_len(),
            m.cov_dim(),
            m.cov_dim()
        );
        out.push_str(&rust_doc(&doc));
        writeln!(out, "pub const FUSION_MODEL_{}: u32 = {};", upper(m.name()), m.code()).unwrap();
    }
    out.push('\n');
    for w in &kinds {
        let name = w.kind.unwrap().name();
        let doc = format!(
            "Publishes {} {name} sample: {} `*reached` (if not NULL) is the number of readers it reached: 0 when \
             no fusiond runs. The same as `fusion_publish` with `FUSION_KIND_{}`.",
            article(name).to_lowercase(),
            lower_first(w.doc),
            upper(name)
        );
        out.push_str(&rust_doc(&doc));
        writeln!(
            out,
            "///\n/// # Safety\n\
             /// `publisher` null or live; `sample` null or valid; `reached` null or writable.\n\
             #[unsafe(no_mangle)]\n\
             pub unsafe extern \"C\" fn fusion_publish_{name}(publisher: *mut FusionPublisher, sample: *const fusion_shared::{}, reached: *mut usize) -> FusionStatus {{\n\
             // SAFETY: forwarded contract.\nunsafe {{ publish(publisher, sample, reached) }}\n}}\n",
            w.rust
        )
        .unwrap();
    }
    out
}

/// `text` as rustfmt writes it with the workspace's settings.
fn rustfmt(text: &str) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut child = std::process::Command::new(std::env::var("RUSTFMT").unwrap_or_else(|_| "rustfmt".into()))
        .args(["--edition", "2024", "--emit", "stdout", "--config-path"])
        .arg(root.join("rustfmt.toml"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("rustfmt (rustup component add rustfmt)");
    child.stdin.take().unwrap().write_all(text.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "rustfmt failed on the generated code:\n{text}");
    String::from_utf8(out.stdout).unwrap()
}

/// The C header cbindgen makes of the crate's sources now, each wire type
/// renamed `Fusion<Type>`.
fn header() -> String {
    let crate_dir = env!("CARGO_MANIFEST_DIR");
    let mut config = cbindgen::Config::from_file(Path::new(crate_dir).join("cbindgen.toml")).unwrap();
    for w in kinds() {
        config.export.rename.insert(w.rust.to_string(), format!("Fusion{}", w.rust));
    }
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen")
        .write(&mut generated);
    String::from_utf8(generated).unwrap()
}

/// Writes `generated` to `path` when asked to; then it must be what is there.
fn fresh(path: PathBuf, generated: &str, stale: &mut Vec<String>) {
    if std::env::var_os("FUSION_UPDATE_GENERATED").is_some() {
        std::fs::write(&path, generated).unwrap();
    }
    if std::fs::read_to_string(&path).unwrap_or_default() != generated {
        stale.push(path.display().to_string());
    }
}

/// The committed mirrors are what the generator writes now, and the header
/// has each kind's code, its count, its struct and its publish functions.
#[test]
fn the_mirrors_are_generated_from_the_registry() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut stale = Vec::new();
    fresh(dir.join("python/fusion_client/wire.py"), &python(), &mut stale);
    fresh(dir.join("src/capi/generated.rs"), &rustfmt(&c_kinds()), &mut stale);
    // The header after generated.rs: cbindgen reads the sources as they are now.
    let header = header();
    fresh(dir.join("include/fusion_client.h"), &header, &mut stale);
    assert!(
        stale.is_empty(),
        "stale: {stale:?}; run `FUSION_UPDATE_GENERATED=1 cargo test --workspace --test mirrors --test docs` and commit them"
    );
    for w in kinds() {
        let k = w.kind.unwrap();
        let code = format!("#define FUSION_KIND_{} {}\n", upper(k.name()), k as u32);
        assert!(header.contains(&code), "no `{}` in the C header", code.trim());
        assert!(header.contains(&format!("typedef struct Fusion{} {{", w.rust)), "no struct Fusion{}", w.rust);
        assert!(header.contains(&format!("fusion_publish_{}(", k.name())), "no C publish function for {k:?}");
    }
    assert!(header.contains(&format!("#define FUSION_KIND_COUNT {}\n", SampleKind::COUNT)));
    assert!(header.contains(" fusion_publish(struct FusionPublisher *publisher,\n"), "no generic publish");
    for m in snapshot::Model::ALL {
        let code = format!("#define FUSION_MODEL_{} {}\n", m.name().to_uppercase(), m.code());
        assert!(header.contains(&code), "no `{}` in the C header", code.trim());
    }
}
