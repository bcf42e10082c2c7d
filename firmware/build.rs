//! Link setup (as in cortex-m-quickstart): put the workspace's `memory.x`
//! where cortex-m-rt's `link.x` finds it, and link with `link.x` and
//! defmt's `defmt.x`. Also turns `LMS_EXIT_AFTER_SCANS` into a constant.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"))
        .join("..")
        .join("memory.x");
    fs::copy(&memory_x, out.join("memory.x")).expect("copy ../memory.x into OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");

    // Scans after which the `exit-after-scans` build exits (semihosting, code 0).
    println!("cargo:rerun-if-env-changed=LMS_EXIT_AFTER_SCANS");
    let scans: u32 = match env::var("LMS_EXIT_AFTER_SCANS") {
        Ok(s) => s
            .trim()
            .parse()
            .expect("LMS_EXIT_AFTER_SCANS must be a whole number"),
        Err(_) => 100,
    };
    // The parameters of this build: a preset of the core (`LMS_PRESET`,
    // default `default`), with its smoothing passes replaced where
    // `LMS_ITERATIONS` gives them (the budget measurements build with 1).
    println!("cargo:rerun-if-env-changed=LMS_PRESET");
    let preset = match env::var("LMS_PRESET").as_deref().map(str::trim) {
        Ok("default") | Err(_) => "DEFAULT",
        Ok("v3.2") => "V3_2",
        Ok("v3.1") => "V3_1",
        Ok("v3.0") => "V3_0",
        Ok("v2") => "V2",
        Ok("paper") => "PAPER",
        Ok(other) => {
            panic!("LMS_PRESET must be default, v3.2, v3.1, v3.0, v2 or paper, not {other}")
        }
    };
    println!("cargo:rerun-if-env-changed=LMS_ITERATIONS");
    let iterations = match env::var("LMS_ITERATIONS") {
        Ok(s) => {
            let n: u16 = s
                .trim()
                .parse()
                .expect("LMS_ITERATIONS must be a whole number 1..=1000");
            format!("Some({n})")
        }
        Err(_) => "None".to_string(),
    };
    // The scan variant the co-processor brings the LMS up with until its
    // client sets one (`3B`): 180°/0.5° unless `LMS_VARIANT` (FOV/RES in
    // degrees) says otherwise (the cycle estimates per LMS mode build with
    // each).
    println!("cargo:rerun-if-env-changed=LMS_VARIANT");
    let variant = match env::var("LMS_VARIANT").as_deref().map(str::trim) {
        Ok("180/1") => "Fov180Res100",
        Ok("180/0.5") | Err(_) => "Fov180Res50",
        Ok("100/1") => "Fov100Res100",
        Ok("100/0.5") => "Fov100Res50",
        Ok("100/0.25") => "Fov100Res25",
        Ok(other) => {
            panic!("LMS_VARIANT must be 180/1, 180/0.5, 100/1, 100/0.5 or 100/0.25, not {other}")
        }
    };
    // The board's crystal (Hz): 8 MHz on the STM32F4-Discovery, 25 MHz on
    // a Netduino Plus 2; rcc.rs checks at compile time that the PLL gets
    // exactly 168 MHz from it.
    println!("cargo:rerun-if-env-changed=LMS_HSE_HZ");
    let hse_hz: u32 = match env::var("LMS_HSE_HZ") {
        Ok(s) => s
            .trim()
            .parse()
            .expect("LMS_HSE_HZ must be a whole number (Hz)"),
        Err(_) => 8_000_000,
    };
    fs::write(
        out.join("build_config.rs"),
        format!(
            "/// Scans after which an `exit-after-scans` build exits (`LMS_EXIT_AFTER_SCANS` at build time).\n\
             pub const EXIT_AFTER_SCANS: u32 = {scans};\n\
             /// The preset the parameters start from (`LMS_PRESET` at build time, default `default`).\n\
             pub const PRESET: lms_core::Params = lms_core::Params::{preset};\n\
             /// Smoothing passes instead of the preset's (`LMS_ITERATIONS` at build time; `None`: the preset's).\n\
             pub const ITERATIONS: Option<u16> = {iterations};\n\
             /// The board's crystal (`LMS_HSE_HZ` at build time, default 8 MHz).\n\
             pub const HSE_HZ: u32 = {hse_hz};\n\
             /// The scan variant the LMS is brought up with (`LMS_VARIANT` at build time, default 180/0.5).\n\
             pub const VARIANT: lms_core::Variant = lms_core::Variant::{variant};\n"
        ),
    )
    .expect("write build_config.rs");
}
