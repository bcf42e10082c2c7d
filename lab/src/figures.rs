//! The report's figures, SVG files beside `README.md`, drawn with
//! [`crate::charts`]: detection and accuracy against σ, the corner
//! evidence, and the scale space against passes and against q.

use std::path::Path;

use anyhow::Result;
use plotters::style::RGBColor;

use crate::charts::{figure, Legend, Panel, Series, COLOURS};
use crate::metrics::{inside, Summary, Tally};
use crate::report::mm;
use crate::scale::{Scale, PASSES, QS};
use crate::Synthetic;

/// Colour of the dashed goal lines.
const GOAL: RGBColor = RGBColor(0x55, 0x55, 0x55);
/// Colour of the dashed τ line.
const TAU: RGBColor = RGBColor(0xE4, 0x1A, 0x1C);

/// The `k`-th curve colour (cycling).
fn colour(k: usize) -> RGBColor {
    COLOURS[k % COLOURS.len()]
}

/// The legend text of a noise level.
fn sigma_name(sigma: f64) -> String {
    format!("σ = {}", mm(sigma))
}

/// Detection and accuracy of `methods` against σ (mm), all scene families
/// pooled, each panel with its goal dashed.
pub fn accuracy_vs_sigma(path: &Path, syn: &Synthetic, methods: &[&str]) -> Result<()> {
    let x = |s: f64| s * 1e3;
    let series = |value: fn(&Summary) -> f64, goal: f64, name: &str| -> Vec<Series> {
        let mut v: Vec<Series> = methods
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let pts = syn
                    .sigmas
                    .iter()
                    .map(|&s| (x(s), value(&syn.pooled(s, m, &[]).summary())))
                    .collect();
                Series::new(*m, pts, colour(k))
            })
            .collect();
        let ideal = syn.sigmas.iter().map(|&s| (x(s), goal)).collect();
        v.push(Series::dashed(name, ideal, GOAL));
        v
    };
    let panels = [
        Panel::new(
            "TruePos (resolvable walls)",
            "σ (mm)",
            "TruePos",
            series(|s| s.true_pos, 0.95, "goal 0.95"),
        )
        .y_range(0.4, 1.02)
        .legend(Legend::LowerLeft),
        Panel::new(
            "FalsePos (neutral lines left out)",
            "σ (mm)",
            "FalsePos",
            series(|s| s.false_pos, 0.02, "goal 0.02"),
        )
        .y_range(0.0, 0.6)
        .legend(Legend::UpperLeft),
        Panel::new(
            "σΔα / Cramér–Rao bound",
            "σ (mm)",
            "RMS normalised error",
            series(|s| s.crb_alpha, 1.2, "goal 1.2"),
        )
        .y_range(0.8, 2.6)
        .legend(Legend::UpperLeft),
        Panel::new(
            "mean line NEES",
            "σ (mm)",
            "NEES",
            series(|s| s.nees_line, 2.0, "ideal 2"),
        )
        .y_range(1.0, 8.0)
        .legend(Legend::UpperLeft),
    ];
    figure(
        path,
        "Synthetic scans: detection and accuracy against the noise σ (all scene families)",
        &panels,
        2,
    )
}

/// The fraction of true corners whose noise-free first-pass `D` is at most
/// x, against log10 x, one curve per σ, with τ = 9 dashed.
pub fn corner_evidence(path: &Path, syn: &Synthetic) -> Result<()> {
    let mut series: Vec<Series> = syn
        .sigmas
        .iter()
        .zip(&syn.corner_evidence)
        .enumerate()
        .map(|(k, (&sigma, e))| {
            let pts = (0..=50)
                .map(|i| {
                    let x = -2.0 + 0.1 * i as f64;
                    (x, inside(e, 10f64.powf(x)))
                })
                .collect();
            Series::new(sigma_name(sigma), pts, colour(k))
        })
        .collect();
    let tau = 9f64.log10();
    series.push(Series::dashed("τ = 9", vec![(tau, 0.0), (tau, 1.0)], TAU));
    let panel = Panel::new(
        "fraction of true corners with noise-free D ≤ x",
        "log10 D",
        "fraction of corners",
        series,
    )
    .y_range(0.0, 1.02)
    .legend(Legend::LowerRight);
    figure(
        path,
        "Corner evidence: noise-free first-pass D at the true corners",
        &[panel],
        1,
    )
}

/// One curve per σ of `value` at the points `(x, q, pass)` of the sweep.
fn sweep(sc: &Scale, points: &[(f64, f32, u16)], value: fn(&Summary) -> f64) -> Vec<Series> {
    sc.sigmas
        .iter()
        .enumerate()
        .map(|(k, &sigma)| {
            let pts = points
                .iter()
                .map(|&(x, q, p)| {
                    let y = sc
                        .get(sigma, q, p)
                        .map(Tally::summary)
                        .map_or(f64::NAN, |s| value(&s));
                    (x, y)
                })
                .collect();
            Series::new(sigma_name(sigma), pts, colour(k))
        })
        .collect()
}

/// Features and errors against the number of passes (q = 0), with the
/// resolvable walls per scan dashed in the lines panel.
pub fn scale_passes(path: &Path, sc: &Scale) -> Result<()> {
    let points: Vec<(f64, f32, u16)> = PASSES.iter().map(|&p| (f64::from(p), 0.0, p)).collect();
    let by_pass = |value: fn(&Summary) -> f64| sweep(sc, &points, value);
    let (first, last) = (f64::from(PASSES[0]), f64::from(PASSES[PASSES.len() - 1]));
    let mut lines = by_pass(|s| s.lines_per_scan);
    for (k, &sigma) in sc.sigmas.iter().enumerate() {
        let truth = sc
            .get(sigma, 0.0, PASSES[0])
            .map_or(f64::NAN, |t| t.summary().true_per_scan);
        lines.push(Series::dashed(
            format!("resolvable walls, σ = {}", mm(sigma)),
            vec![(first, truth), (last, truth)],
            colour(k),
        ));
    }
    let panels = [
        Panel::new(
            "lines per scan (dashed: resolvable walls per scan)",
            "passes",
            "lines / scan",
            lines,
        )
        .legend(Legend::UpperRight),
        Panel::new(
            "segments per scan",
            "passes",
            "segments / scan",
            by_pass(|s| s.segments_per_scan),
        )
        .legend(Legend::UpperRight),
        Panel::new("TruePos", "passes", "TruePos", by_pass(|s| s.true_pos))
            .y_range(0.4, 1.0)
            .legend(Legend::LowerLeft),
        Panel::new("FalsePos", "passes", "FalsePos", by_pass(|s| s.false_pos))
            .y_range(0.0, 0.7)
            .legend(Legend::UpperRight),
        Panel::new(
            "σΔα / CRB",
            "passes",
            "RMS normalised error",
            by_pass(|s| s.crb_alpha),
        )
        .legend(Legend::UpperRight),
        Panel::new("mean line NEES", "passes", "NEES", by_pass(|s| s.nees_line))
            .legend(Legend::UpperRight),
    ];
    figure(
        path,
        "Scale space: features and errors against the number of passes (q = 0)",
        &panels,
        3,
    )
}

/// Features and errors against the process noise q (30 passes), q on a
/// categorical axis.
pub fn scale_q(path: &Path, sc: &Scale) -> Result<()> {
    let points: Vec<(f64, f32, u16)> = QS
        .iter()
        .enumerate()
        .map(|(i, &q)| (i as f64, q, 30))
        .collect();
    let by_q = |value: fn(&Summary) -> f64| sweep(sc, &points, value);
    let cats: Vec<String> = QS.iter().map(|q| format!("{q:e}")).collect();
    let panels = [
        Panel::new(
            "lines per scan",
            "q (m²)",
            "lines / scan",
            by_q(|s| s.lines_per_scan),
        )
        .categories(&cats)
        .legend(Legend::UpperRight),
        Panel::new("TruePos", "q (m²)", "TruePos", by_q(|s| s.true_pos))
            .categories(&cats)
            .y_range(0.0, 1.0)
            .legend(Legend::LowerLeft),
        Panel::new("FalsePos", "q (m²)", "FalsePos", by_q(|s| s.false_pos))
            .categories(&cats)
            .y_range(0.0, 0.7)
            .legend(Legend::UpperLeft),
        Panel::new(
            "σΔα / CRB",
            "q (m²)",
            "RMS normalised error",
            by_q(|s| s.crb_alpha),
        )
        .categories(&cats)
        .legend(Legend::UpperLeft),
    ];
    figure(
        path,
        "Scale space: features and errors against the process noise q (30 passes)",
        &panels,
        2,
    )
}
