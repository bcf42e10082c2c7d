//! The scale space (ALGORITHM.md §5): segments, lines and line errors after
//! each number of passes (1…50) and for each process noise q.
//!
//! One 50-pass run per scan and q (`Extractor::run_observed`) hands over `D`
//! after every pass; the passes in [`PASSES`] are segmented and fitted by the
//! back end of [`crate::baselines`] (the core's §6–8 bit for bit), so pass
//! `p` of the sweep is exactly the core run with `iterations = p`.

use anyhow::Result;
use lms_core::{Extractor, Params};

use crate::baselines::{extraction_from_d, Tables};
use crate::metrics::{scan_truth, Gates, Tally};
use crate::scenes::{self, Family, NoiseSpec};
use crate::EvaluateArgs;

/// Passes evaluated.
pub const PASSES: [u16; 13] = [1, 2, 3, 5, 7, 10, 15, 20, 25, 30, 35, 40, 50];
/// Process noise values evaluated (m²); 1 is the paper's "unity".
pub const QS: [f32; 6] = [0.0, 1e-6, 1e-5, 1e-4, 1e-2, 1.0];

/// One point of the sweep.
#[derive(Clone, Debug)]
pub struct ScaleCell {
    /// Noise σ (m).
    pub sigma: f64,
    /// Process noise (m²).
    pub q: f32,
    /// Passes.
    pub pass: u16,
    /// Scores over all families.
    pub tally: Tally,
}

/// The sweep.
#[derive(Clone, Debug, Default)]
pub struct Scale {
    /// Scans per family.
    pub scans: usize,
    /// Noise levels.
    pub sigmas: Vec<f64>,
    /// All points.
    pub cells: Vec<ScaleCell>,
    /// Per σ: detectable pieces per scan (the "true number" of lines).
    pub detectable_per_scan: Vec<f64>,
}

impl Scale {
    /// The tally at (σ, q, pass).
    pub fn get(&self, sigma: f64, q: f32, pass: u16) -> Option<&Tally> {
        self.cells
            .iter()
            .find(|c| c.sigma == sigma && c.q == q && c.pass == pass)
            .map(|c| &c.tally)
    }
}

/// Progress units of the sweep.
pub fn units(args: &EvaluateArgs) -> u64 {
    (args.sigmas.len() * Family::ALL.len() * args.scale_scans) as u64
}

/// Run the sweep.
pub fn run(args: &EvaluateArgs, bar: &indicatif::ProgressBar) -> Result<Scale> {
    let gates = Gates::default();
    let mut ex = Extractor::new();
    let mut out = Scale {
        scans: args.scale_scans,
        sigmas: args.sigmas.clone(),
        ..Scale::default()
    };
    let last = *PASSES.last().unwrap_or(&50);
    for &sigma in &args.sigmas {
        bar.set_message(format!("scale space, σ = {} mm", sigma * 1e3));
        let mut tallies = vec![Tally::default(); QS.len() * PASSES.len()];
        let (mut detectable, mut scans) = (0usize, 0usize);
        for family in Family::ALL {
            for k in 0..args.scale_scans {
                let noise = NoiseSpec {
                    sigma,
                    dropout: args.dropout,
                };
                // Other scans than the main tables' (index offset).
                let s = scenes::sample(family, 100_000 + k, args.seed, noise)?;
                let tables = Tables::for_frame(&s.frame);
                let base = Params::PAPER.with_sigma(sigma as f32);
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                detectable += truth.pieces.iter().filter(|p| p.detectable).count();
                scans += 1;
                for (qi, &q) in QS.iter().enumerate() {
                    let params = base.with_q(q).with_iterations(last);
                    let mut captured: Vec<(u16, Vec<f32>)> = Vec::new();
                    let _ = ex.run_observed(
                        &s.frame,
                        &params.validate().expect("sweep parameters"),
                        &mut lms_core::Trace::new(),
                        |pass, d, _| {
                            if PASSES.contains(&pass) {
                                captured.push((pass, d.to_vec()));
                            }
                        },
                    );
                    for (pi, (_, d)) in captured.iter().enumerate() {
                        let x = extraction_from_d(&s.frame, &tables, d, &params);
                        let (ls, cs) = crate::score(&truth, &x, &s.frame, sigma, &gates);
                        tallies[qi * PASSES.len() + pi].add(&ls, &cs, x.segments.len(), 0.0);
                    }
                }
                bar.inc(1);
            }
        }
        out.detectable_per_scan
            .push(detectable as f64 / scans.max(1) as f64);
        for (qi, &q) in QS.iter().enumerate() {
            for (pi, &pass) in PASSES.iter().enumerate() {
                out.cells.push(ScaleCell {
                    sigma,
                    q,
                    pass,
                    tally: std::mem::take(&mut tallies[qi * PASSES.len() + pi]),
                });
            }
        }
    }
    Ok(out)
}
