//! What the defaults' false lines on the realistic synthetic scenes lie on:
//! a pillar (a full circle), a curved wall (an open arc), or a straight
//! surface (then the evaluation's classes: a duplicate of a matched piece,
//! a piece too short to resolve, off the gates, mixed), with the median
//! points, length and σ_α of each class and how many of each class have a
//! range jump (> 0.3 m) or a no-echo beam next to both of their ends.
//!
//! `cargo run --release -p lms-lab --example false_lines -- [SCANS] [--stop23]`

use std::collections::BTreeMap;

use anyhow::Result;
use lms_core::{Extractor, Line, Params};
use lms_lab::baselines::run_core;
use lms_lab::metrics::{median, scan_truth, score_lines, Gates};
use lms_lab::realistic::{realistic_model, sample, DELTA, SIGMAS};
use lms_lab::scenes::Family;
use lms_lab::sweep::count_and_flags;
use lms_scene::Surface;

#[derive(Default)]
struct Class {
    n: usize,
    points: Vec<f64>,
    length: Vec<f64>,
    sd_alpha_deg: Vec<f64>,
    isolated: usize,
}

fn length(l: &Line) -> f64 {
    let [a, b] = l.endpoints;
    f64::from((a[0] - b[0]).hypot(a[1] - b[1]))
}

fn main() -> Result<()> {
    let (scans, args) = count_and_flags(100)?;
    let base = if args.iter().any(|a| a == "--stop23") {
        Params::STOP23
    } else {
        Params::DEFAULT
    };
    let mut ex = Extractor::new();
    for sigma in SIGMAS {
        let model = realistic_model(sigma);
        let gates = Gates {
            kappa: model.kappa,
            ..Gates::default()
        };
        let params = Params {
            sigma: sigma as f32,
            ..base
        };
        let mut classes: BTreeMap<&'static str, Class> = BTreeMap::new();
        let mut lines = 0;
        for family in Family::ALL {
            for k in 0..scans {
                let s = sample(family, k, 1, &model, DELTA)?;
                let truth = scan_truth(&s.truth, &s.scene, &params, sigma, &gates);
                let x = run_core(&mut ex, &s.frame, &params);
                let score = score_lines(&truth, &x.lines, s.frame.beams(), sigma, &gates);
                lines += x.lines.len();
                let matched: Vec<usize> = score.pairs.iter().map(|p| p.line).collect();
                let beams = s.frame.beams();
                let ranges = s.frame.ranges();
                let range = |j: usize| {
                    beams
                        .get(j)
                        .filter(|b| b.is_valid())
                        .and_then(|_| ranges.get(j).copied())
                };
                for (e, l) in x.lines.iter().enumerate() {
                    if matched.contains(&e) {
                        continue;
                    }
                    let (f, t) = (usize::from(l.first), usize::from(l.last));
                    let mid = (f..=t)
                        .filter_map(|j| s.truth.hits.get(j).copied().flatten())
                        .map(|h| h.surface)
                        .collect::<Vec<_>>();
                    let arc_kind = |id| match s.scene.surface(id) {
                        Some(Surface::Arc(a)) if a.is_full_circle() => Some("pillar"),
                        Some(Surface::Arc(_)) => Some("curved wall"),
                        _ => None,
                    };
                    let on = |kind| mid.iter().filter(|&&id| arc_kind(id) == Some(kind)).count();
                    let half = (t - f + 1).div_euclid(2);
                    let kind = if on("pillar") > half {
                        "pillar"
                    } else if on("curved wall") > half {
                        "curved wall"
                    } else {
                        "straight (dup/unres/off/mixed)"
                    };
                    let jump = |a: usize, b: usize| match (range(a), range(b)) {
                        (Some(x), Some(y)) => (x - y).abs() > 0.3,
                        _ => true,
                    };
                    let isolated =
                        (f == 0 || jump(f, f - 1)) && (t + 1 >= beams.len() || jump(t, t + 1));
                    let c = classes.entry(kind).or_default();
                    c.n += 1;
                    c.points.push(f64::from(l.points));
                    c.length.push(length(l));
                    c.sd_alpha_deg.push(f64::from(l.cov.a).sqrt().to_degrees());
                    c.isolated += usize::from(isolated);
                }
            }
        }
        println!("\nσ₀ = {} mm, {lines} lines", sigma * 1e3);
        println!("| on | false lines | share of all lines | median points | median length (m) | median σα (°) | jump at both ends |");
        println!("|---|---:|---:|---:|---:|---:|---:|");
        for (kind, c) in &classes {
            println!(
                "| {kind} | {} | {:.3} | {:.0} | {:.2} | {:.2} | {} |",
                c.n,
                c.n as f64 / lines as f64,
                median(&c.points),
                median(&c.length),
                median(&c.sd_alpha_deg),
                c.isolated
            );
        }
    }
    Ok(())
}
