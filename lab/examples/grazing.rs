//! Where true walls break on real scans (docs/DESIGN.md, "Windows"): `D`
//! of the last pass on the windows of the map truth's counted pieces,
//! against incidence, range and interleave parity; and the fate of each
//! counted piece under the no-flag defaults (matched, no line, or which
//! gate a covering line misses). Windows of consecutive beams
//! (`same_turn_windows = false`), or with `turn` same-turn windows (the
//! default).
//!
//! `cargo run --release -p lms-lab --example grazing -- [EVERY] [RHO] [turn]`
//! (EVERY-th frame of every shared log, default 5; RHO the grazing term
//! `Params::grazing_noise`, default 0).

use std::path::Path;

use anyhow::Result;
use lms_core::Extractor;
use lms_lab::maptruth::{frame_truth, TruthConfig};

/// Upper edges of the incidence bins (degrees).
const INC: [f64; 8] = [30.0, 45.0, 60.0, 70.0, 75.0, 80.0, 85.0, 90.0];
/// Upper edges of the range bins (m).
const RANGE: [f64; 4] = [2.0, 4.0, 8.0, 80.0];

#[derive(Default, Clone)]
struct Bin {
    n: usize,
    broken: usize,
    broken_first: usize,
    d: Vec<f32>,
    even: (usize, usize),
    odd: (usize, usize),
}

impl Bin {
    fn add(&mut self, d_last: f32, d_first: f32, mid: usize, tau: f32) {
        self.n += 1;
        let b = d_last >= tau;
        self.broken += usize::from(b);
        self.broken_first += usize::from(d_first >= tau);
        self.d.push(d_last);
        let p = if mid.is_multiple_of(2) {
            &mut self.even
        } else {
            &mut self.odd
        };
        p.0 += 1;
        p.1 += usize::from(b);
    }
    fn row(&mut self, label: &str) {
        self.d.sort_by(f32::total_cmp);
        let q = |f: f64| {
            self.d
                .get(((self.d.len() as f64 - 1.0) * f) as usize)
                .copied()
                .unwrap_or(f32::NAN)
        };
        let r = |a: usize, b: usize| a as f64 / b.max(1) as f64;
        println!(
            "| {label} | {} | {:.3} | {:.3} | {:.2} | {:.1} | {:.1} | {:.3} | {:.3} |",
            self.n,
            r(self.broken_first, self.n),
            r(self.broken, self.n),
            q(0.5),
            q(0.9),
            q(0.99),
            r(self.even.1, self.even.0),
            r(self.odd.1, self.odd.0),
        );
    }
}

fn bin_of(edges: &[f64], x: f64) -> usize {
    edges.iter().position(|&e| x < e).unwrap_or(edges.len() - 1)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let every: usize = args.get(1).map_or(Ok(5), |s| s.parse())?;
    let rho: f32 = args.get(2).map_or(Ok(0.0), |s| s.parse())?;
    let same_turn = args.get(3).is_some_and(|s| s == "turn");
    let logs = lms_lab::real::find_logs(Path::new("../shared/data/carmen"))?;
    let cfg = TruthConfig::default();
    for path in &logs {
        let lms_lab::realtruth::LogWithMap {
            log,
            no_flags: base,
            cfg,
            map,
            ..
        } = lms_lab::realtruth::load_with_map(path, &cfg)?;
        let params = base
            .with_grazing_noise(rho)
            .with_same_turn_windows(same_turn)
            .validate()?;
        let mut inc = vec![Bin::default(); INC.len()];
        let mut rng = vec![Bin::default(); RANGE.len()];
        let mut steps = std::collections::BTreeMap::<i64, usize>::new();
        let mut ex = Extractor::new();
        // Fate of counted pieces: matched, no line on it, best line's α, r or overlap off.
        let mut fate = [0usize; 5];
        let mut stats = vec![0u64; lms_core::Stats::FIELDS.len()];
        for scan in log.scans.iter().step_by(every) {
            let truth = frame_truth(scan, &map, &cfg);
            let mut first = Vec::new();
            let mut trace = lms_core::Trace::new();
            ex.run_observed(&scan.frame, &params, &mut trace, |pass, d, _| {
                if pass == 1 {
                    first = d.to_vec();
                }
            });
            for (k, (_, get)) in lms_core::Stats::FIELDS.iter().enumerate() {
                stats[k] += u64::from(get(ex.features().stats()));
            }
            for p in truth.pieces.iter().filter(|p| p.counted) {
                fate[piece_fate(ex.features().lines(), p)] += 1;
            }
            let d = trace.mahalanobis();
            let g = scan.frame.geometry();
            let r = scan.frame.ranges();
            for p in truth.pieces.iter().filter(|p| p.counted) {
                for i in p.first..p.last.saturating_sub(1) {
                    if (i..i + 3).any(|j| truth.on_wall[j] != Some(p.line)) {
                        continue;
                    }
                    let th = lms_scene::wrap_angle(f64::from(g.bearing(i + 1)) - p.alpha)
                        .abs()
                        .to_degrees();
                    let dist = f64::from(r[i + 1]);
                    inc[bin_of(&INC, th)].add(d[i], first[i], i + 1, params.tau);
                    rng[bin_of(&RANGE, dist)].add(d[i], first[i], i + 1, params.tau);
                    let step = ((r[i + 1] - r[i]).abs() * 1000.0).round() as i64;
                    if step > 0 && step < 100 {
                        *steps.entry(step).or_default() += 1;
                    }
                }
            }
        }
        println!(
            "\n### {} (σ {} mm, ρ {rho})\n",
            path.file_name().unwrap_or_default().to_string_lossy(),
            params.sigma * 1e3
        );
        println!("| bin | windows | broken pass 1 | broken last | D median | D p90 | D p99 | broken, even middle | broken, odd middle |\n|:--|--:|--:|--:|--:|--:|--:|--:|--:|");
        let mut lo = 0.0;
        for (k, b) in inc.iter_mut().enumerate() {
            b.row(&format!("incidence {lo}–{}°", INC[k]));
            lo = INC[k];
        }
        let mut lo = 0.0;
        for (k, b) in rng.iter_mut().enumerate() {
            b.row(&format!("range {lo}–{} m", RANGE[k]));
            lo = RANGE[k];
        }
        let tot = fate.iter().sum::<usize>().max(1) as f64;
        println!(
            "\ncounted pieces {}: matched {:.3}, no line overlapping {:.3}, best line's overlap < 50 % {:.3}, |Δα| ≥ 3° {:.3}, |Δr| ≥ 0.1 m {:.3}",
            tot,
            fate[0] as f64 / tot,
            fate[1] as f64 / tot,
            fate[2] as f64 / tot,
            fate[3] as f64 / tot,
            fate[4] as f64 / tot
        );
        let names: Vec<String> = lms_core::Stats::FIELDS
            .iter()
            .zip(&stats)
            .filter(|(_, &v)| v > 0)
            .map(|((n, _), v)| format!("{n} {v}"))
            .collect();
        println!("stats summed: {}", names.join(", "));
        let top: Vec<String> = {
            let mut v: Vec<(i64, usize)> = steps.into_iter().collect();
            v.sort_by_key(|x| std::cmp::Reverse(x.1));
            v.iter()
                .take(6)
                .map(|(s, n)| format!("{s} mm: {n}"))
                .collect()
        };
        println!(
            "\nmost common non-zero steps between consecutive on-wall ranges: {}",
            top.join(", ")
        );
    }
    Ok(())
}

/// 0 matched (any line within the gates), 1 no line overlaps the piece,
/// else the best-overlapping line misses: 2 overlap, 3 α, 4 r.
fn piece_fate(lines: &[lms_core::Line], p: &lms_lab::maptruth::Piece) -> usize {
    let mut best: Option<(usize, usize)> = None;
    for l in lines {
        let (f, la) = (l.first as usize, l.last as usize);
        let ov = la
            .min(p.last)
            .saturating_add(1)
            .saturating_sub(f.max(p.first));
        let frac = ov as f64 / (la - f + 1) as f64;
        let da = lms_scene::wrap_angle(f64::from(l.alpha) - p.alpha)
            .abs()
            .to_degrees();
        let dr = (f64::from(l.r) - p.r).abs();
        let fails = if frac < 0.5 {
            2
        } else if da >= 3.0 {
            3
        } else if dr >= 0.1 {
            4
        } else {
            0
        };
        if ov > 0 && fails == 0 {
            return 0;
        }
        if ov > 0 && best.is_none_or(|(o, _)| ov > o) {
            best = Some((ov, fails));
        }
    }
    best.map_or(1, |(_, f)| f)
}
