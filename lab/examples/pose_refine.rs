//! The map truth with every frame registered to the map's walls
//! (`TruthConfig::refine_pose`) against the SLAM poses as they are: per log
//! the registration's corrections, the share of pieces the frame confirms,
//! and the defaults, the split-and-merge baseline and the oracle scored
//! against both truths (docs/DESIGN.md, "Evaluation").
//!
//! `cargo run --release -p lms-lab --example pose_refine -- [EVERY]`

use std::path::Path;

use anyhow::Result;
use lms_lab::maptruth::{refine_pose, TruthConfig};
use lms_lab::realtruth::{load_with_map, methods, pooled_table, run_log, LogWithMap, RealTally};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn percentile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let k = ((v.len() as f64 - 1.0) * q).round() as usize;
    v.get(k).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let wanted = ["defaults, no flags", "split-and-merge", "oracle"];
    let methods: Vec<_> = methods()
        .into_iter()
        .filter(|m| wanted.iter().any(|w| m.name.starts_with(w)))
        .collect();
    let slam = TruthConfig::default();
    let mut pooled = [
        vec![RealTally::default(); methods.len()],
        vec![RealTally::default(); methods.len()],
    ];
    println!(
        "| log | median / 95 % \\|Δθ\\| (°) | median / 95 % \\|Δxy\\| (mm) | verified, SLAM → registered |"
    );
    println!("|:---|---:|---:|---:|");
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let LogWithMap { log, cfg, map, .. } = load_with_map(&path, &slam)?;
        let registered = TruthConfig {
            refine_pose: true,
            ..cfg
        };
        let all: Vec<usize> = (0..map.walls.len()).collect();
        let (mut dth, mut dxy) = (Vec::new(), Vec::new());
        for scan in log.scans.iter().step_by(every) {
            let p = refine_pose(scan, &map.walls, &all, &registered);
            let q = scan.meta.pose;
            dth.push(lms_scene::wrap_angle(p[2] - q[2]).abs().to_degrees());
            dxy.push((p[0] - q[0]).hypot(p[1] - q[1]) * 1e3);
        }
        let a = run_log(&path, &methods, every, &slam, None)?;
        let b = run_log(&path, &methods, every, &registered, None)?;
        println!(
            "| {} | {:.2} / {:.2} | {:.0} / {:.0} | {:.3} → {:.3} |",
            a.name,
            median(dth.clone()),
            percentile(dth, 0.95),
            median(dxy.clone()),
            percentile(dxy, 0.95),
            a.verified_share,
            b.verified_share
        );
        for (k, t) in a.tallies.iter().enumerate() {
            pooled[0][k].merge(t);
        }
        for (k, t) in b.tallies.iter().enumerate() {
            pooled[1][k].merge(t);
        }
    }
    for (truth, tallies) in ["SLAM poses", "registered"].iter().zip(&pooled) {
        let names: Vec<String> = methods
            .iter()
            .map(|m| format!("{truth} · {}", m.name))
            .collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        println!("\n{}", pooled_table(&names, tallies));
        for (m, t) in methods.iter().zip(tallies) {
            let s = t.summary();
            println!(
                "{truth} · {}: σΔα {:.2}°, σΔr {:.1} mm",
                m.name, s.sd_alpha_deg, s.sd_r_mm
            );
        }
    }
    Ok(())
}
