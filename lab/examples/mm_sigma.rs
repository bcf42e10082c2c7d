//! σ on mm data (docs/DESIGN.md, "Inputs"): the no-flag parameters take
//! σ = 5 mm on ranges in mm (the LMS 2xx's statistical error,
//! `sigma_for_step`), 10 mm on cm data. Real walls scatter more than the
//! statistical error (the LMS's systematic error varies with reflectivity
//! and incidence along a wall). σ on mm data from 5 to 15 mm, on the
//! settled truth (every `EVERY`-th frame; only the mm log changes) and the
//! realistic synthetic scenes (unchanged: their σ₀ is 10 or 20 mm).
//!
//! `cargo run --release -p lms-lab --example mm_sigma -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{settled_sweep, Adjust};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(0), |s| s.parse())?;
    let variants: [(&'static str, Adjust); 5] = [
        ("5 mm (defaults)", |p| p),
        ("7.5 mm", |p| p.with_sigma(p.sigma.max(0.0075))),
        ("10 mm", |p| p.with_sigma(p.sigma.max(0.01))),
        ("12.5 mm", |p| p.with_sigma(p.sigma.max(0.0125))),
        ("15 mm", |p| p.with_sigma(p.sigma.max(0.015))),
    ];
    print!(
        "{}",
        settled_sweep("σ on mm data", &variants, &[], every, scans)?
    );
    Ok(())
}
