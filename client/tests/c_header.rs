//! The committed C header (`client/include/fusion_client.h`) is what cbindgen
//! makes of `src/capi.rs` now. `FUSION_UPDATE_HEADER=1` rewrites it.

use std::path::Path;

#[test]
fn the_c_header_is_fresh() {
    let crate_dir = env!("CARGO_MANIFEST_DIR");
    let config = cbindgen::Config::from_file(Path::new(crate_dir).join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen")
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = Path::new(crate_dir).join("include/fusion_client.h");
    if std::env::var_os("FUSION_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is stale: run `FUSION_UPDATE_HEADER=1 cargo test -p fusion-client --test c_header` and commit it",
        path.display()
    );
    // Every sample kind can be published from C: its code, its struct under
    // the C API's name (a rename in cbindgen.toml), its publish function.
    struct Kinds<'a>(&'a str);
    impl fusion_shared::KindVisitor for Kinds<'_> {
        fn visit<T: fusion_shared::WireSample>(&mut self) {
            let (kind, header) = (T::KIND, self.0);
            let name = kind.name();
            let code = format!("#define FUSION_KIND_{} {}\n", name.to_uppercase(), kind as u8);
            assert!(header.contains(&code), "no `{}` in the C header", code.trim());
            let rust = std::any::type_name::<T>().rsplit("::").next().unwrap();
            assert!(
                header.contains(&format!("typedef struct Fusion{rust} {{")),
                "no struct Fusion{rust} in the C header (a rename in cbindgen.toml)"
            );
            assert!(header.contains(&format!("fusion_publish_{name}(")), "no C publish function for {kind:?}");
        }
    }
    fusion_shared::SampleKind::visit_all(&mut Kinds(&generated));
    // And every model's snapshot code.
    for m in fusion_shared::snapshot::Model::ALL {
        let code = format!("#define FUSION_MODEL_{} {}\n", m.name().to_uppercase(), m.code());
        assert!(generated.contains(&code), "no `{}` in the C header", code.trim());
    }
}
