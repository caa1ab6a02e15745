//! The checked-in C header `capi/include/superhelix.h` is what cbindgen generates from
//! the crate with `capi/cbindgen.toml`: this test fails when it is stale.
//!
//! To rewrite the header after changing the API:
//!
//! ```text
//! SUPERHELIX_UPDATE_HEADER=1 cargo test -p superhelix-capi --release --test header
//! ```

use std::path::Path;

#[test]
fn header_is_fresh() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let generated = String::from_utf8(generated).expect("UTF-8 header");
    let path = dir.join("include").join("superhelix.h");
    if std::env::var_os("SUPERHELIX_UPDATE_HEADER").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &generated).expect("write the header");
        eprintln!("wrote {}", path.display());
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "{} is stale (or missing): regenerate it with\n  \
         SUPERHELIX_UPDATE_HEADER=1 cargo test -p superhelix-capi --release --test header",
        path.display()
    );
}
