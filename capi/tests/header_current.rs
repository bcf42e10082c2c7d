//! The checked-in header is what cbindgen generates from the sources now.
//! To regenerate it: `LMS_UPDATE_HEADER=1 cargo test -p lms-capi --test header_current`.

use std::path::Path;

#[test]
fn checked_in_header_is_current() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("capi/cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen cannot generate the header")
        .write(&mut generated);
    let path = crate_dir.join("include/lms_features.h");
    if std::env::var_os("LMS_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("cannot write the header");
        return;
    }
    let checked_in = std::fs::read(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "{} is not the header cbindgen generates from capi/src; regenerate it with\n  \
         LMS_UPDATE_HEADER=1 cargo test -p lms-capi --test header_current\nand commit it",
        path.display()
    );
}
