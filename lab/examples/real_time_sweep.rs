//! Scratch: settings at 6 passes.
use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let v: Vec<(&'static str, Adjust)> = vec![
        ("30", |p| p),
        ("6", |p| p.with_iterations(6)),
        ("6 tau 7", |p| p.with_iterations(6).with_tau(7.0)),
        ("6 tau 8", |p| p.with_iterations(6).with_tau(8.0)),
        ("6 tau 10", |p| p.with_iterations(6).with_tau(10.0)),
        ("6 tau 12", |p| p.with_iterations(6).with_tau(12.0)),
        ("6 chi2 3", |p| p.with_iterations(6).with_max_chi2(3.0)),
        ("6 chi2 5", |p| p.with_iterations(6).with_max_chi2(5.0)),
        ("6 mp 6", |p| p.with_iterations(6).with_min_points(6)),
        ("7", |p| p.with_iterations(7)),
    ];
    print_sweep(&v, 1, 200)
}
