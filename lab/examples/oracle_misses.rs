//! Why the unverified map truth caps the oracle near 0.8: each counted
//! piece's own-hit TLS fit against its map line, broken down by the gate
//! that fails and by the piece's length, with the rms distance of the hits
//! from the map line. The misses are what `TruthConfig::verify` leaves
//! uncounted (`lab/src/maptruth.rs`, step 4).
//!
//! `cargo run --release -p lms-lab --example oracle_misses -- [EVERY] [settled]`

use std::path::Path;

use anyhow::Result;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realtruth::{gate_offsets, ScoredLine, GATE_ALPHA_DEG, GATE_R};

/// Upper edges of the length bins (m).
const LENGTH: [f64; 4] = [0.5, 1.0, 2.0, f64::INFINITY];

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    // Every piece the map gives, whatever the frame says; `-- K settled`:
    // the settled truth (registered poses, leave-one-wall-out, Δr at the
    // line's middle).
    let settled = std::env::args().nth(2).as_deref() == Some("settled");
    let tol: Option<f64> = std::env::args().nth(3).map(|s| s.parse()).transpose()?;
    let mut cfg = if settled {
        TruthConfig::settled()
    } else {
        TruthConfig {
            verify: false,
            ..TruthConfig::default()
        }
    };
    if let Some(t) = tol {
        cfg.beam_tol = t;
    }
    let dir = Path::new("../shared/data/carmen");
    let mut names: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    names.sort();
    println!(
        "| log | pieces | misses | Δα only | Δr only | both | misses / pieces by length \
         < 0.5, < 1, < 2, ≥ 2 m | median rms of hits from the map line, matched / missed (mm) |"
    );
    for path in names {
        let loaded = lms_lab::realtruth::load_with_map(&path, &cfg)?;
        let lms_lab::realtruth::LogWithMap { log, .. } = &loaded;
        let (mut n, mut gates) = (0, [0usize; 3]);
        let mut by_len = [(0usize, 0usize); 4];
        let (mut rms_hit, mut rms_miss) = (Vec::new(), Vec::new());
        for (k, scan) in log.scans.iter().enumerate().step_by(every) {
            let truth = loaded.truth(k);
            let (g, rg) = (scan.frame.geometry(), scan.frame.ranges());
            for p in truth.pieces.iter().filter(|p| p.counted) {
                n += 1;
                let own = ScoredLine {
                    alpha: p.own_alpha,
                    r: p.own_r,
                    first: p.first,
                    last: p.last,
                    middle: p.own_middle,
                };
                let (da, dr) = gate_offsets(&own, (p.alpha, p.r), p.gate_at_middle);
                let fa = da.to_degrees().abs() >= GATE_ALPHA_DEG;
                let fr = dr.abs() >= GATE_R;
                let bin = LENGTH.iter().position(|&l| p.length < l).unwrap_or(3);
                by_len[bin].0 += 1;
                let e2: Vec<f64> = (p.first..=p.last)
                    .filter(|&j| truth.on_wall[j] == Some(p.line))
                    .map(|j| {
                        let e = f64::from(rg[j]) * (f64::from(g.bearing(j)) - p.alpha).cos() - p.r;
                        e * e
                    })
                    .collect();
                let rms = (e2.iter().sum::<f64>() / e2.len().max(1) as f64).sqrt() * 1e3;
                if fa || fr {
                    by_len[bin].1 += 1;
                    rms_miss.push(rms);
                    gates[usize::from(fr) + 2 * usize::from(fa) - 1] += 1;
                } else {
                    rms_hit.push(rms);
                }
            }
        }
        let misses = gates.iter().sum::<usize>();
        println!(
            "| {} | {n} | {misses} ({:.3}) | {} | {} | {} | {} | {:.0} / {:.0} |",
            path.file_name().unwrap_or_default().to_string_lossy(),
            misses as f64 / n.max(1) as f64,
            gates[1],
            gates[0],
            gates[2],
            by_len
                .iter()
                .map(|(t, m)| format!("{m}/{t}"))
                .collect::<Vec<_>>()
                .join(", "),
            median(&mut rms_hit),
            median(&mut rms_miss)
        );
    }
    Ok(())
}
