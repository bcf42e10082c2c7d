//! Diagnostic for `Params::per_turn` (ALGORITHM.md §10 proposal (d)): on
//! the 0.5° logs, the no-flag defaults on the whole scan, on one mirror turn alone (the even beams as
//! a 1° scan), per turn with the turns' lines fused, and a hybrid (per
//! turn plus the whole scan's lines no per-turn line covers half of),
//! against the verified map truth.
//!
//! `cargo run --release -p lms-lab --example one_turn -- [EVERY]`

use std::path::Path;

use anyhow::{Context, Result};
use host_bridge::carmen::{self, UnitMode};
use lms_core::pipeline::turns::turn_frame;
use lms_core::{Extractor, Params};
use lms_lab::baselines::{run_core, Extraction};
use lms_lab::maptruth::{build_map, frame_truth, TruthConfig};
use lms_lab::realtruth::{no_flag_params, score_frame, RealTally, ScoredLine};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let cfg = TruthConfig::default();
    let dir = Path::new("../shared/data/carmen");
    let mut names: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    names.sort();
    let mut pooled = vec![RealTally::default(); 4];
    let lines = |x: &Extraction, k: usize| -> Vec<ScoredLine> {
        x.lines
            .iter()
            .map(|l| {
                let mut s = ScoredLine::from(l);
                (s.first, s.last) = (k * s.first, k * s.last);
                s
            })
            .collect()
    };
    for path in names {
        let log = carmen::read_log(&path, UnitMode::Auto)?;
        if log.scans.first().is_none_or(|s| s.frame.len() < 300) {
            continue;
        }
        let params = no_flag_params(&path)?;
        let cfg = cfg.for_data(params.max_range);
        let map = build_map(&log.scans, &cfg);
        let per_turn = Params {
            per_turn: true,
            ..params
        };
        let mut ex = Extractor::new();
        let mut t = vec![RealTally::default(); 4];
        for scan in log.scans.iter().step_by(every) {
            let truth = frame_truth(scan, &map, &cfg);
            let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
            let whole = lines(&run_core(&mut ex, &scan.frame, &params), 1);
            let even = lines(
                &run_core(
                    &mut ex,
                    &turn_frame(&scan.frame, 0, 2).context("a frame too short for its turns")?,
                    &params,
                ),
                2,
            );
            let fused = lines(&run_core(&mut ex, &scan.frame, &per_turn), 1);
            // Hybrid (measured, not built): per turn, plus the whole scan's
            // lines that no per-turn line covers half of.
            let mut hybrid = fused.clone();
            for w in &whole {
                let covered = fused
                    .iter()
                    .map(|f| (w.last.min(f.last) + 1).saturating_sub(w.first.max(f.first)))
                    .max()
                    .unwrap_or(0);
                if 2 * covered < w.last - w.first + 1 {
                    hybrid.push(*w);
                }
            }
            for (k, l) in [whole, even, fused, hybrid].iter().enumerate() {
                score_frame(&truth, l, &valid, &mut t[k]);
            }
        }
        let s: Vec<_> = t.iter().map(RealTally::summary).collect();
        println!(
            "{}: TruePos / FalsePos whole {:.3} / {:.3}, even turn {:.3} / {:.3}, per turn fused {:.3} / {:.3}",
            path.display(),
            s[0].true_pos,
            s[0].false_pos,
            s[1].true_pos,
            s[1].false_pos,
            s[2].true_pos,
            s[2].false_pos
        );
        for (p, x) in pooled.iter_mut().zip(&t) {
            p.merge(x);
        }
    }
    let s: Vec<_> = pooled.iter().map(RealTally::summary).collect();
    println!(
        "pooled: TruePos / ≥ 1 m / FalsePos whole {:.3} / {:.3} / {:.3}, even turn {:.3} / {:.3} / {:.3}, per turn fused {:.3} / {:.3} / {:.3}, hybrid {:.3} / {:.3} / {:.3}",
        s[0].true_pos, s[0].true_pos_1m, s[0].false_pos,
        s[1].true_pos, s[1].true_pos_1m, s[1].false_pos,
        s[2].true_pos, s[2].true_pos_1m, s[2].false_pos,
        s[3].true_pos, s[3].true_pos_1m, s[3].false_pos
    );
    Ok(())
}
