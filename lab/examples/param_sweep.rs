//! The defaults' other parameters one at a time: τ, the footprint κ,
//! `max_chi2`, `min_points`, `merge_gap_beams`, `corner_gap`, the passes,
//! `max_alpha_sd_deg` and the split's work bound. On the defaults, or with
//! `--stop23` on stop 23's (`Params::STOP23`, as measured in
//! docs/ALGORITHM-v3-section10.md §10.9; §10.11 has the sweep on the
//! defaults). Realistic synthetic scenes (`SCANS` per family and σ₀) and
//! the real logs' map truth (every 5th frame), pooled. None wins every
//! column.
//!
//! `cargo run --release -p lms-lab --example param_sweep -- [SCANS] [--stop23]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{count_and_flags, print_sweep_over, Adjust};

fn main() -> Result<()> {
    let (scans, args) = count_and_flags(100)?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("defaults", |p| p),
        ("τ 12", |p| Params { tau: 12.0, ..p }),
        ("τ 16", |p| Params { tau: 16.0, ..p }),
        ("κ 2 mrad", |p| Params {
            footprint: 0.002,
            ..p
        }),
        ("κ 4 mrad", |p| Params {
            footprint: 0.004,
            ..p
        }),
        ("max_chi2 3", |p| Params { max_chi2: 3.0, ..p }),
        ("max_chi2 5", |p| Params { max_chi2: 5.0, ..p }),
        ("min_points 6", |p| Params { min_points: 6, ..p }),
        ("merge_gap 6", |p| Params {
            merge_gap_beams: 6,
            ..p
        }),
        ("corner_gap 0.3", |p| Params {
            corner_gap: 0.3,
            ..p
        }),
        ("iterations 20", |p| Params {
            iterations: 20,
            ..p
        }),
        ("iterations 40", |p| Params {
            iterations: 40,
            ..p
        }),
        ("max σα 1.25°", |p| Params {
            max_alpha_sd_deg: 1.25,
            ..p
        }),
        ("split_budget 722", |p| Params {
            split_budget: 722,
            ..p
        }),
    ];
    if args.iter().any(|a| a == "--stop23") {
        print_sweep_over(|p| on_data(Params::STOP23, p), &v, 5, scans)
    } else {
        print_sweep_over(|p| p, &v, 5, scans)
    }
}
