//! The scale of the defaults (docs/DESIGN.md, "Parameters"): the smoothing
//! passes and the segmentation gate τ. The three-beam mask iterated
//! `iterations` times spreads over about √iterations beams, so 30 passes at
//! 1° smooth over twice the angle they do at 0.5° (where the same-turn
//! windows already take every other beam); fewer passes leave more noise
//! in `D`, which a larger τ answers. Per log of the settled truth (`lms-lab
//! truth`: the no-flag parameters, σ and range limit per data, only the
//! scale changed): preset `v3.1` (30 passes, τ = 9), the defaults (5
//! passes, τ = 12), 4 to 30 passes at τ = 12 and τ from 9 to 14 at 5
//! passes: TruePos overall and by piece length, FalsePos, unexplained
//! lines, coverage, fragmentation; pooled per resolution and over all logs;
//! on the 1° logs also τ, `min_points` and the σ_α gate; and the realistic
//! synthetic scenes (0.5°, `SCANS` per family and σ₀). Every frame (`EVERY`
//! = 1, the default) runs in about a minute.
//!
//! `cargo run --release -p lms-lab --example passes_per_resolution -- [EVERY] [SCANS]`

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use host_bridge::carmen::{self, UnitMode};
use lms_lab::baselines::run_core;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realtruth::{run_log, RealMethod, RealTally};
use lms_lab::sweep::{synthetic_table, Adjust};

/// The variants: the defaults, preset `v3.1`, then the passes at τ = 12
/// and τ at 5 passes.
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("5, τ 12 (defaults)", |p| p),
        ("30, τ 9 (v3.1)", |p| p.with_iterations(30).with_tau(9.0)),
        ("30, τ 12", |p| p.with_iterations(30)),
        ("12, τ 12", |p| p.with_iterations(12)),
        ("8, τ 12", |p| p.with_iterations(8)),
        ("6, τ 12", |p| p.with_iterations(6)),
        ("4, τ 12", |p| p.with_iterations(4)),
        ("5, τ 9", |p| p.with_tau(9.0)),
        ("5, τ 10", |p| p.with_tau(10.0)),
        ("5, τ 11", |p| p.with_tau(11.0)),
        ("5, τ 14", |p| p.with_tau(14.0)),
    ]
}

/// Other settings a 1° scan might want instead: the shortest segment and
/// the σ_α gate scaled by √2 (half the beams on a wall at 1°).
fn others() -> Vec<(&'static str, Adjust)> {
    vec![
        ("min_points=4", |p| p.with_min_points(4)),
        ("max_alpha_sd_deg=2.36 (√2·5/3)", |p| {
            p.with_max_alpha_sd_deg(2.36)
        }),
    ]
}

fn f(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3}")
    } else {
        "—".into()
    }
}

fn header(md: &mut String, setting: &str) {
    let _ = writeln!(
        md,
        "| log | {setting} | TruePos | ≥ 1 m | 0.5–1 m (pieces) | < 0.5 m | FalsePos | \
         unexplained | coverage | fragmented | walls fragmented | lines / frame |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
}

fn row(md: &mut String, log: &str, name: &str, t: &RealTally) {
    let s = t.summary();
    let (bad, of) = s.walls_fragmented;
    let _ = writeln!(
        md,
        "| {log} | {name} | {} | {} | {} ({}) | {} | {} | {} | {} | {} | {bad} of {of} | {:.2} |",
        f(s.true_pos),
        f(s.true_pos_1m),
        f(s.true_pos_mid),
        t.pieces_mid,
        f(s.true_pos_short),
        f(s.false_pos),
        f(s.unexplained),
        f(s.coverage),
        f(s.fragmented),
        s.lines_per_frame,
    );
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let vs = variants();
    let names: Vec<&str> = vs.iter().map(|v| v.0).collect();
    let adjust: Vec<Adjust> = vs.iter().map(|v| v.1).collect();
    let n = vs.len();
    let all: Vec<_> = vs.iter().chain(&others()).copied().collect();
    let all_names: Vec<&str> = all.iter().map(|v| v.0).collect();
    let methods: Vec<RealMethod> = all
        .iter()
        .map(|&(name, adjust)| RealMethod::no_flags_with(name, adjust))
        .collect();
    let cfg = TruthConfig::settled();
    // Pooled: [0] 1° logs, [1] 0.5° logs; per variant.
    let mut pooled = vec![vec![RealTally::default(); all.len()]; 2];
    let (mut md, mut other) = (String::new(), String::new());
    header(&mut md, "passes, τ");
    header(&mut other, "setting");
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let beams = carmen::read_log(&path, UnitMode::Auto)?
            .scans
            .first()
            .map_or(0, |s| s.frame.len());
        let coarse = beams <= 181;
        let r = run_log(&path, &methods, every, &cfg, None)?;
        let name = r.name.trim_end_matches("-corrected.log.gz");
        let label = format!("{name} ({}°, {beams})", if coarse { "1" } else { "0.5" });
        for (k, t) in r.tallies.iter().enumerate() {
            if k < n {
                row(&mut md, &label, all_names[k], t);
            } else if coarse {
                row(&mut other, &label, all_names[k], t);
            }
            pooled[usize::from(!coarse)][k].merge(t);
        }
        eprintln!("{label}: {} frames", r.frames);
    }
    println!("Settled truth, every {every}. frame, per log:\n\n{md}");
    let mut md = String::new();
    header(&mut md, "passes, τ");
    for (g, label) in [(0, "1° logs"), (1, "0.5° logs")] {
        for (k, t) in pooled[g].iter().enumerate().take(n) {
            row(&mut md, &format!("**{label}**"), all_names[k], t);
        }
        for (k, t) in pooled[g].iter().enumerate().skip(n) {
            row(&mut other, &format!("**{label}**"), all_names[k], t);
        }
    }
    for (k, t) in pooled[0].iter().enumerate().take(n) {
        let mut all = pooled[1][k].clone();
        all.merge(t);
        row(&mut md, "**all logs**", names[k], &all);
    }
    println!("Pooled:\n\n{md}");
    println!("Other settings at the defaults (1° logs, then pooled):\n\n{other}");
    println!(
        "Realistic synthetic scenes (0.5°), {scans} scans per family and σ₀:\n\n{}",
        synthetic_table(&names, scans, &|k, ex, frame, base| {
            run_core(ex, frame, &(adjust[k])(*base))
        })?
    );
    Ok(())
}
