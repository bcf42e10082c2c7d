//! Prototype: the σ_α gate (`Params::max_alpha_sd_deg`) on the covariance
//! widened by the line's own χ² per point where that is above 1.
//!
//! `cargo run --release -p lms-lab --example widened_gate -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::Extractor;
use lms_lab::baselines::{corners_of, run_core};
use lms_lab::sweep::print_sweep_with;

const LIMITS_DEG: [f32; 4] = [5.0 / 3.0, 2.0, 2.5, 3.0];

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let names = [
        "defaults",
        "widened, 5/3°",
        "widened, 2°",
        "widened, 2.5°",
        "widened, 3°",
    ];
    print_sweep_with(
        &names,
        every,
        scans,
        &|k, ex: &mut Extractor, frame, params| {
            let mut x = run_core(ex, frame, params);
            if k > 0 {
                let lim = LIMITS_DEG[k - 1].to_radians();
                x.lines.retain(|l| l.cov.a * l.chi2.max(1.0) <= lim * lim);
                x.corners = corners_of(&x.lines, params);
            }
            x
        },
    )
}
