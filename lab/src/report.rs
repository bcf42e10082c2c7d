//! The report: `README.md` with the measured tables, the SVG figures of
//! [`crate::figures`] beside it, and a link to the hand-written
//! `FINDINGS.md` (the tool writes no conclusions: numbers, headings and
//! short captions only).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use lms_core::{Frame, Params};

use crate::figures;
use crate::metrics::{
    false_pos_goal, inside, median, Summary, Tally, CRB_GOAL, NEUTRAL_CHI2, TRUE_POS_GOAL,
};
use crate::real::{LogResult, CALIBRATION_SIGMAS};
use crate::scale::{Scale, PASSES, QS};
use crate::scenes::Family;
use crate::{
    EvaluateArgs, Synthetic, DEFAULTS, GAUSSIAN, NO_SHARED, PROPOSAL, PROPOSAL_INFO, SPEC,
    SPLIT_MERGE,
};
use host_bridge::input::InputFrame;
use host_bridge::plot::{self, FramePlot};

/// Wall-clock time of each part (s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    /// Synthetic scans.
    pub synthetic: f64,
    /// Scale-space sweep.
    pub scale: f64,
    /// Real scans.
    pub real: f64,
    /// Everything, report included.
    pub total: f64,
}

/// Whether a font for the figures' text is available.
pub fn fonts_available() -> bool {
    plot::ensure_font().is_ok()
}

/// Draw the scan figure of one real frame to `path` (SVG).
pub fn scan_figure(
    path: &Path,
    source: String,
    index: usize,
    frame: &Frame,
    params: &Params,
) -> Result<()> {
    let input = InputFrame {
        index,
        frame: frame.clone(),
        pose: None,
    };
    let fp = FramePlot::compute(source, &input, params, &[params.iterations])?;
    let mut text = String::new();
    {
        use plotters::prelude::*;
        let root = SVGBackend::with_string(&mut text, plot::SCAN_SIZE).into_drawing_area();
        plot::draw_scan(&root, &fp, None)?;
        root.present()
            .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", path.display()))?;
    }
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

// ------------------------------------------------------------ formatting --

/// `x` with `decimals` decimals, or "—" if it is not finite (a figure
/// with nothing to measure).
pub(crate) fn f(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        "—".to_string()
    }
}

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:.1} %", 100.0 * x)
    } else {
        "—".to_string()
    }
}

/// A noise level in whole millimetres where it is one, e.g. "20 mm".
pub(crate) fn mm(sigma: f64) -> String {
    let v = sigma * 1e3;
    if (v - v.round()).abs() < 1e-9 {
        format!("{} mm", v.round())
    } else {
        format!("{v:.1} mm")
    }
}

fn header(md: &mut String, cells: &[&str]) {
    let _ = writeln!(md, "| {} |", cells.join(" | "));
    let _ = writeln!(
        md,
        "|{}|",
        cells
            .iter()
            .enumerate()
            .map(|(i, _)| if i == 0 { ":---" } else { "---:" })
            .collect::<Vec<_>>()
            .join("|")
    );
}

fn row(md: &mut String, cells: Vec<String>) {
    let _ = writeln!(md, "| {} |", cells.join(" | "));
}

fn mark(ok: bool) -> &'static str {
    if ok {
        "✓"
    } else {
        "✗"
    }
}

// --------------------------------------------------------------- context --

struct Ctx<'a> {
    args: &'a EvaluateArgs,
    syn: &'a Synthetic,
    scale: &'a Scale,
    real: &'a [LogResult],
    /// Synthetic scenes from the realistic sensor model: (σ₀, method, tally).
    realistic: &'a [(f64, String, Tally)],
    figures: bool,
    headline: f64,
}

impl Ctx<'_> {
    fn t(&self, sigma: f64, method: &str) -> Tally {
        self.syn.pooled(sigma, method, &[])
    }

    fn s(&self, sigma: f64, method: &str) -> Summary {
        self.t(sigma, method).summary()
    }

    fn has(&self, sigma: f64, method: &str) -> bool {
        self.syn
            .cells
            .iter()
            .any(|c| c.sigma == sigma && c.method == method)
    }

    fn evidence(&self, sigma: f64) -> &[f64] {
        self.syn
            .sigmas
            .iter()
            .position(|&s| s == sigma)
            .and_then(|i| self.syn.corner_evidence.get(i))
            .map_or(&[], Vec::as_slice)
    }

    fn scale_at(&self, sigma: f64, q: f32, pass: u16) -> Option<Summary> {
        self.scale.get(sigma, q, pass).map(Tally::summary)
    }
}

/// The metrics a method should win, with the direction of "better".
struct Metric {
    name: &'static str,
    value: fn(&Summary) -> f64,
    /// Lower is better (after `value`).
    lower: bool,
    fmt: fn(f64) -> String,
}

fn metrics_list() -> Vec<Metric> {
    vec![
        Metric {
            name: "TruePos",
            value: |s| s.true_pos,
            lower: false,
            fmt: |x| f(x, 3),
        },
        Metric {
            name: "FalsePos",
            value: |s| s.false_pos,
            lower: true,
            fmt: |x| f(x, 3),
        },
        Metric {
            name: "FalsePos without lines on arcs",
            value: |s| s.false_pos_no_arc,
            lower: true,
            fmt: |x| f(x, 3),
        },
        Metric {
            name: "σΔα / CRB (distance from 1)",
            value: |s| (s.crb_alpha - 1.0).abs(),
            lower: true,
            fmt: |x| format!("±{}", f(x, 2)),
        },
        Metric {
            name: "σΔr / CRB (distance from 1)",
            value: |s| (s.crb_r - 1.0).abs(),
            lower: true,
            fmt: |x| format!("±{}", f(x, 2)),
        },
        Metric {
            name: "mean line NEES (distance from 2)",
            value: |s| (s.nees_line - 2.0).abs(),
            lower: true,
            fmt: |x| format!("±{}", f(x, 2)),
        },
        Metric {
            name: "corners found",
            value: |s| s.corner_rate,
            lower: false,
            fmt: |x| f(x, 3),
        },
        Metric {
            name: "corner RMS error (mm)",
            value: |s| s.corner_rms * 1e3,
            lower: true,
            fmt: |x| f(x, 1),
        },
        Metric {
            name: "mean corner NEES (distance from 2)",
            value: |s| (s.corner_nees - 2.0).abs(),
            lower: true,
            fmt: |x| format!("±{}", f(x, 2)),
        },
    ]
}

fn better(m: &Metric, a: f64, b: f64) -> bool {
    if !a.is_finite() {
        return false;
    }
    if !b.is_finite() {
        return true;
    }
    if m.lower {
        a < b
    } else {
        a > b
    }
}

/// Metrics on which `method` beats both baselines at `sigma`.
fn wins(ctx: &Ctx, sigma: f64, method: &str) -> (usize, usize) {
    let ms = metrics_list();
    let s = ctx.s(sigma, method);
    let a = ctx.s(sigma, SPLIT_MERGE);
    let b = ctx.s(sigma, GAUSSIAN);
    let n = ms
        .iter()
        .filter(|m| {
            let v = (m.value)(&s);
            better(m, v, (m.value)(&a)) && better(m, v, (m.value)(&b))
        })
        .count();
    (n, ms.len())
}

// ---------------------------------------------------------------- report --

/// Write the report; returns the path of `README.md`.
pub fn write(
    args: &EvaluateArgs,
    syn: &Synthetic,
    scale: &Scale,
    (real, sections): (&[LogResult], &crate::RealSections),
    timing: Timing,
) -> Result<PathBuf> {
    let figures = !args.no_plots && fonts_available();
    let headline = syn
        .sigmas
        .iter()
        .copied()
        .min_by(|a, b| (a - 0.02).abs().total_cmp(&(b - 0.02).abs()))
        .unwrap_or(0.02);
    let ctx = Ctx {
        args,
        syn,
        scale,
        real,
        realistic: &sections.realistic,
        figures,
        headline,
    };
    let mut md = String::new();
    intro(&mut md, &ctx, &timing);
    summary(&mut md, &ctx);
    accuracy(&mut md, &ctx)?;
    diagnosis(&mut md, &ctx)?;
    scale_space(&mut md, &ctx)?;
    real_scans(&mut md, &ctx);
    md.push_str(&sections.markdown(args.real_every));
    reproduce(&mut md, &ctx, &timing);
    let path = args.output.join("README.md");
    std::fs::write(&path, md).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

fn intro(md: &mut String, ctx: &Ctx, timing: &Timing) {
    let a = ctx.args;
    let _ = writeln!(
        md,
        "# Evaluation: accuracy against ground truth, scale space, baselines, real scans\n"
    );
    let _ = writeln!(
        md,
        "Tables and figures written by `lms-lab evaluate` (see [Reproduce](#reproduce)): {} \
         synthetic scans per scene family and noise level ({} families × {} noise levels = {} \
         scans, each run through every method), a scale-space sweep on {} further scans per \
         family, and {} real CARMEN logs. \
         Everything is seeded (seed {}); only the times change from run to run. Run time {:.0} s \
         on one core (synthetic {:.0} s, scale space {:.0} s, real scans {:.0} s).\n",
        a.scans,
        Family::ALL.len(),
        ctx.syn.sigmas.len(),
        a.scans * Family::ALL.len() * ctx.syn.sigmas.len(),
        a.scale_scans,
        ctx.real.len(),
        a.seed,
        timing.total,
        timing.synthetic,
        timing.scale,
        timing.real
    );
    let _ = writeln!(
        md,
        "The methods, the setup and its definitions, and what the numbers show are written \
         by hand in [FINDINGS.md](FINDINGS.md); this file holds the measured tables and \
         figures only.\n"
    );
}

/// The methods of the summary table, in its column order.
const SUMMARY_METHODS: [&str; 7] = [
    SPEC,
    DEFAULTS,
    NO_SHARED,
    SPLIT_MERGE,
    GAUSSIAN,
    PROPOSAL,
    PROPOSAL_INFO,
];

/// The noise levels of the comparison with the baselines: σ ≥ 10 mm.
fn high_sigmas(ctx: &Ctx) -> Vec<f64> {
    ctx.syn
        .sigmas
        .iter()
        .copied()
        .filter(|&s| s >= 0.01 - 1e-12)
        .collect()
}

fn summary(md: &mut String, ctx: &Ctx) {
    let h = ctx.headline;
    let _ = writeln!(md, "## Summary: the goals at σ = 10 mm and 20 mm\n");
    let _ = writeln!(
        md,
        "**TruePos** = matched resolvable walls / resolvable walls. **FalsePos** = false \
         lines / (extracted − neutral lines). A line matched to no wall is false, except \
         where half of its beams or more lie on curved walls (arcs) and the noise-free curve \
         over its beams lies within χ²₁ 95 % of a straight line: through the noise-free hits \
         of its beams the orthogonal least-squares line (α, r), and every beam's range \
         deviation d − r / cos(φ − α) within (deviation / σ)² ≤ {NEUTRAL_CHI2} — σ the scan's \
         range noise, with the realistic sensor model the beam's √(σ₀² + (κ·d·tan θ)²). No \
         test on the beams can tell such a line from a wall: it is **neutral**, neither true \
         nor false, and leaves both counts. *neutral* = neutral / extracted lines; *FalsePos \
         without lines on arcs* leaves every line on arcs (neutral or false) out of both \
         counts. Goals: TruePos ≥ {TRUE_POS_GOAL}; FalsePos ≤ {} at σ = 10 mm, ≤ {} at \
         σ = 20 mm; σΔα, σΔr ≤ {CRB_GOAL} × CRB.\n",
        false_pos_goal(0.01),
        false_pos_goal(0.02),
    );
    defaults_table(md, ctx);
    let _ = writeln!(md, "### Every method at σ = {}\n", mm(h));
    let sums: Vec<Summary> = SUMMARY_METHODS.iter().map(|m| ctx.s(h, m)).collect();
    let mut cols = vec!["goal", "target"];
    cols.extend_from_slice(&SUMMARY_METHODS);
    header(md, &cols);
    goal_rows(md, &sums, h);
    wins_row(md, ctx);
    info_rows(md, &sums);
    let _ = writeln!(md);
    baseline_tables(md, ctx);
}

/// The columns of [`goal_cells`].
pub(crate) const GOAL_COLUMNS: [&str; 6] = [
    "TruePos",
    "FalsePos",
    "neutral",
    "FalsePos without lines on arcs",
    "σΔα / CRB",
    "σΔr / CRB",
];

/// The goal figures of a summary at noise `sigma`, ✓/✗ against the goals.
pub(crate) fn goal_cells(sigma: f64, s: &Summary) -> Vec<String> {
    let check = |v: f64, ok: bool, d: usize| format!("{} {}", f(v, d), mark(v.is_finite() && ok));
    vec![
        check(s.true_pos, s.true_pos >= TRUE_POS_GOAL, 3),
        check(s.false_pos, s.false_pos <= false_pos_goal(sigma), 3),
        pct(s.neutral),
        f(s.false_pos_no_arc, 3),
        check(s.crb_alpha, s.crb_alpha <= CRB_GOAL, 2),
        check(s.crb_r, s.crb_r <= CRB_GOAL, 2),
    ]
}

/// The defaults at σ = 10 and 20 mm on the plain Gaussian scenes and the
/// realistic sensor model's, against the goals.
fn defaults_table(md: &mut String, ctx: &Ctx) {
    let _ = writeln!(
        md,
        "### The defaults (`Params::DEFAULT`, no flags) against the goals\n"
    );
    let mut cols = vec!["scenes", "σ"];
    cols.extend_from_slice(&GOAL_COLUMNS);
    header(md, &cols);
    for sigma in [0.01, 0.02] {
        if ctx.has(sigma, DEFAULTS) {
            let mut cells = vec!["plain Gaussian (sections 1–2)".to_string(), mm(sigma)];
            cells.extend(goal_cells(sigma, &ctx.s(sigma, DEFAULTS)));
            row(md, cells);
        }
    }
    for (sigma, name, t) in ctx.realistic {
        if name == DEFAULTS && [0.01, 0.02].iter().any(|g| (g - sigma).abs() < 1e-12) {
            let mut cells = vec!["realistic sensor model (section 7)".to_string(), mm(*sigma)];
            cells.extend(goal_cells(*sigma, &t.summary()));
            row(md, cells);
        }
    }
    let _ = writeln!(md);
}

/// The goals at noise `sigma`, one row each: value and ✓/✗ per method.
fn goal_rows(md: &mut String, sums: &[Summary], sigma: f64) {
    type Check = (
        &'static str,
        String,
        fn(&Summary) -> f64,
        Box<dyn Fn(f64) -> bool>,
        usize,
    );
    let fp_goal = false_pos_goal(sigma);
    let checks: [Check; 6] = [
        (
            "TruePos (resolvable walls)",
            format!("≥ {TRUE_POS_GOAL}"),
            |s| s.true_pos,
            Box::new(|x| x >= TRUE_POS_GOAL),
            3,
        ),
        (
            "FalsePos (neutral lines left out)",
            format!("≤ {fp_goal}"),
            |s| s.false_pos,
            Box::new(move |x| x <= fp_goal),
            3,
        ),
        (
            "σΔα / CRB",
            format!("≤ {CRB_GOAL}"),
            |s| s.crb_alpha,
            Box::new(|x| x <= CRB_GOAL),
            2,
        ),
        (
            "σΔr / CRB",
            format!("≤ {CRB_GOAL}"),
            |s| s.crb_r,
            Box::new(|x| x <= CRB_GOAL),
            2,
        ),
        (
            "mean line NEES",
            "1.8 … 2.2".to_string(),
            |s| s.nees_line,
            Box::new(|x| (1.8..=2.2).contains(&x)),
            2,
        ),
        (
            "mean corner NEES",
            "1.8 … 2.2".to_string(),
            |s| s.corner_nees,
            Box::new(|x| (1.8..=2.2).contains(&x)),
            2,
        ),
    ];
    for (name, target, value, ok, d) in checks {
        let mut cells = vec![name.to_string(), target];
        for s in sums {
            let v = value(s);
            cells.push(format!("{} {}", f(v, d), mark(v.is_finite() && ok(v))));
        }
        row(md, cells);
    }
}

/// The row "beats both baselines at σ ≥ 10 mm": metrics won of all.
fn wins_row(md: &mut String, ctx: &Ctx) {
    let high = high_sigmas(ctx);
    let mut cells = vec![
        format!(
            "beats both baselines at σ ≥ 10 mm ({} metrics × {} noise levels)",
            metrics_list().len(),
            high.len()
        ),
        "all".to_string(),
    ];
    for m in SUMMARY_METHODS {
        if m == SPLIT_MERGE || m == GAUSSIAN {
            cells.push("—".to_string());
            continue;
        }
        let (won, total) = high.iter().fold((0, 0), |acc, &s| {
            let (w, t) = wins(ctx, s, m);
            (acc.0 + w, acc.1 + t)
        });
        cells.push(format!(
            "{won} of {total} {}",
            mark(won == total && total > 0)
        ));
    }
    row(md, cells);
}

/// Rows for information (in italics, no goal).
fn info_rows(md: &mut String, sums: &[Summary]) {
    type Info = (&'static str, fn(&Summary) -> String);
    let info: [Info; 7] = [
        ("neutral lines (of all extracted)", |s| pct(s.neutral)),
        ("FalsePos without lines on arcs", |s| {
            f(s.false_pos_no_arc, 3)
        }),
        ("TruePos, all walls ≥ 5 beams and ≥ 0.1 m", |s| {
            f(s.true_pos_detectable, 3)
        }),
        ("median line NEES (χ²₂: 1.39)", |s| {
            f(s.nees_line_median, 2)
        }),
        ("σΔα / CRB, σΔr / CRB without gross errors", |s| {
            format!("{} / {}", f(s.crb_alpha_inliers, 2), f(s.crb_r_inliers, 2))
        }),
        ("corners found", |s| f(s.corner_rate, 3)),
        ("median corner NEES (χ²₂: 1.39)", |s| {
            f(s.corner_nees_median, 2)
        }),
    ];
    for (name, value) in info {
        let mut cells = vec![format!("*{name}*"), "—".to_string()];
        cells.extend(sums.iter().map(value));
        row(md, cells);
    }
}

/// Per σ ≥ 10 mm: every metric of the spec and the proposals against the
/// baselines, ✓ where better than both.
fn baseline_tables(md: &mut String, ctx: &Ctx) {
    let _ = writeln!(md, "### Against the baselines at σ ≥ 10 mm\n");
    let _ = writeln!(
        md,
        "Each cell: the method's value; ✓ where it is better than *both* baselines. Accuracy \
         ratios and NEES are compared by their distance from the ideal (1 resp. 2).\n"
    );
    for sigma in high_sigmas(ctx) {
        let _ = writeln!(md, "**σ = {}**\n", mm(sigma));
        header(
            md,
            &[
                "metric",
                SPEC,
                DEFAULTS,
                PROPOSAL,
                PROPOSAL_INFO,
                SPLIT_MERGE,
                GAUSSIAN,
            ],
        );
        let sm = ctx.s(sigma, SPLIT_MERGE);
        let ga = ctx.s(sigma, GAUSSIAN);
        for m in metrics_list() {
            let mut cells = vec![m.name.to_string()];
            for method in [SPEC, DEFAULTS, PROPOSAL, PROPOSAL_INFO] {
                let v = (m.value)(&ctx.s(sigma, method));
                let w = better(&m, v, (m.value)(&sm)) && better(&m, v, (m.value)(&ga));
                cells.push(format!("{} {}", (m.fmt)(v), if w { "✓" } else { "" }));
            }
            cells.push((m.fmt)((m.value)(&sm)));
            cells.push((m.fmt)((m.value)(&ga)));
            row(md, cells);
        }
        let _ = writeln!(md);
    }
}

/// A table of the main methods at every σ: columns σ, method, then
/// `columns` with the cells `cells` makes of the method's pooled tally.
fn method_table(md: &mut String, ctx: &Ctx, columns: &[&str], cells: fn(&Tally) -> Vec<String>) {
    let mut cols = vec!["σ", "method"];
    cols.extend_from_slice(columns);
    header(md, &cols);
    for &sigma in &ctx.syn.sigmas {
        for m in main_names(ctx) {
            if !ctx.has(sigma, m) {
                continue;
            }
            let mut r = vec![mm(sigma), m.to_string()];
            r.extend(cells(&ctx.t(sigma, m)));
            row(md, r);
        }
    }
}

fn detection_table(md: &mut String, ctx: &Ctx) {
    let columns = [
        "TruePos",
        "TruePos ≥ 5 beams",
        "coverage",
        "FalsePos",
        "neutral",
        "FalsePos w/o arcs",
        "lines / scan",
        "segments / scan",
        "ms / scan",
    ];
    method_table(md, ctx, &columns, |t| {
        let s = t.summary();
        vec![
            f(s.true_pos, 3),
            f(s.true_pos_detectable, 3),
            f(s.coverage, 2),
            f(s.false_pos, 3),
            pct(s.neutral),
            f(s.false_pos_no_arc, 3),
            f(s.lines_per_scan, 2),
            f(s.segments_per_scan, 2),
            f(s.ms_per_scan, 3),
        ]
    });
}

fn accuracy_table(md: &mut String, ctx: &Ctx) {
    let columns = [
        "pairs",
        "σΔα (mrad)",
        "σΔr (mm)",
        "σΔα / CRB",
        "σΔr / CRB",
        "gross errors",
        "/CRB w/o gross (α / r)",
        "NEES mean / median / ≤ 9.21",
    ];
    method_table(md, ctx, &columns, |t| {
        let s = t.summary();
        vec![
            s.matched_pairs.to_string(),
            f(s.sd_alpha * 1e3, 2),
            f(s.sd_r * 1e3, 2),
            f(s.crb_alpha, 2),
            f(s.crb_r, 2),
            pct(s.outliers),
            format!("{} / {}", f(s.crb_alpha_inliers, 2), f(s.crb_r_inliers, 2)),
            format!(
                "{} / {} / {}",
                f(s.nees_line, 2),
                f(s.nees_line_median, 2),
                pct(s.nees_line_inside)
            ),
        ]
    });
}

fn corner_table(md: &mut String, ctx: &Ctx) {
    let columns = [
        "true corners",
        "found",
        "RMS error (mm)",
        "NEES mean / median / ≤ 9.21",
        "corner FalsePos",
    ];
    method_table(md, ctx, &columns, |t| {
        let s = t.summary();
        vec![
            t.corners.true_corners.to_string(),
            f(s.corner_rate, 3),
            f(s.corner_rms * 1e3, 1),
            format!(
                "{} / {} / {}",
                f(s.corner_nees, 2),
                f(s.corner_nees_median, 2),
                pct(s.corner_nees_inside)
            ),
            f(s.corner_false_pos, 3),
        ]
    });
}

/// False lines by what they lie on and missed walls by cause.
fn causes_table(md: &mut String, ctx: &Ctx) {
    let columns = [
        "lines",
        "neutral: arc",
        "false: arc",
        "duplicate",
        "unresolvable",
        "off",
        "mixed",
        "resolvable walls",
        "missed: merged",
        "fragmented",
        "other",
    ];
    method_table(md, ctx, &columns, |t| {
        let l = &t.lines;
        [
            l.extracted,
            l.neutral_arc,
            l.fp_arc,
            l.fp_split,
            l.fp_unresolvable,
            l.fp_off,
            l.fp_mixed,
            l.true_resolvable,
            l.missed_merged,
            l.missed_fragmented,
            l.missed_other,
        ]
        .iter()
        .map(ToString::to_string)
        .collect()
    });
}

fn main_names<'a>(ctx: &Ctx<'a>) -> Vec<&'a str> {
    ctx.syn.methods.iter().map(String::as_str).collect()
}

fn accuracy(md: &mut String, ctx: &Ctx) -> Result<()> {
    let _ = writeln!(md, "## 1. Accuracy against ground truth\n");
    if ctx.figures {
        let file = "accuracy-vs-sigma.svg";
        figures::accuracy_vs_sigma(&ctx.args.output.join(file), ctx.syn, &main_names(ctx))?;
        let _ = writeln!(md, "![detection and accuracy against σ]({file})\n");
    }
    let _ = writeln!(md, "### Detection\n");
    detection_table(md, ctx);
    let _ = writeln!(
        md,
        "\n### Line accuracy (matched lines on resolvable walls)\n"
    );
    accuracy_table(md, ctx);
    let _ = writeln!(md, "\n### Corners\n");
    corner_table(md, ctx);
    family_table(md, ctx);
    let _ = writeln!(md);
    Ok(())
}

/// The main methods (without `fit_shared_points = false`) per scene family
/// at the headline σ.
fn family_table(md: &mut String, ctx: &Ctx) {
    let h = ctx.headline;
    let _ = writeln!(md, "\n### Per scene family at σ = {}\n", mm(h));
    header(
        md,
        &[
            "family",
            "method",
            "TruePos",
            "FalsePos",
            "FalsePos w/o arcs",
            "σΔα / CRB",
            "σΔr / CRB",
            "NEES mean / median",
            "corners found",
            "corner NEES mean",
        ],
    );
    for fam in Family::ALL {
        for m in [
            SPEC,
            DEFAULTS,
            SPLIT_MERGE,
            GAUSSIAN,
            PROPOSAL,
            PROPOSAL_INFO,
        ] {
            let s = ctx.syn.pooled(h, m, &[fam]).summary();
            row(
                md,
                vec![
                    fam.name().to_string(),
                    m.to_string(),
                    f(s.true_pos, 3),
                    f(s.false_pos, 3),
                    f(s.false_pos_no_arc, 3),
                    f(s.crb_alpha, 2),
                    f(s.crb_r, 2),
                    format!("{} / {}", f(s.nees_line, 2), f(s.nees_line_median, 2)),
                    f(s.corner_rate, 3),
                    f(s.corner_nees, 2),
                ],
            );
        }
    }
}

fn diagnosis(md: &mut String, ctx: &Ctx) -> Result<()> {
    let _ = writeln!(
        md,
        "## 2. Where the lines go: false lines and missed walls\n"
    );
    let _ = writeln!(
        md,
        "Unmatched lines by what they lie on, and missed resolvable walls by cause (the \
         categories: [FINDINGS.md](FINDINGS.md#reading-the-tables)). *neutral: arc*: lines \
         on arcs within χ²₁ 95 % of a straight line (neither true nor false, see the \
         summary); every other column of unmatched lines is false.\n"
    );
    causes_table(md, ctx);
    let _ = writeln!(md, "\n### Corner evidence in one window\n");
    let _ = writeln!(
        md,
        "For every true corner: the largest `D` of the windows around it on the **noise-free** \
         ranges (first pass, the core's window filter with σ of the row; `D ∝ 1/σ²`).\n"
    );
    evidence_table(md, ctx);
    if ctx.figures {
        let file = "corner-evidence.svg";
        figures::corner_evidence(&ctx.args.output.join(file), ctx.syn)?;
        let _ = writeln!(md, "\n![corner evidence]({file})");
    }
    variants_table(md, ctx);
    let _ = writeln!(md);
    Ok(())
}

/// The noise-free corner evidence per σ.
fn evidence_table(md: &mut String, ctx: &Ctx) {
    header(
        md,
        &[
            "σ",
            "true corners",
            "median noise-free D",
            "below τ = 9",
            "below τ = 4",
            "spec: corners found",
        ],
    );
    for &sigma in &ctx.syn.sigmas {
        let e = ctx.evidence(sigma);
        row(
            md,
            vec![
                mm(sigma),
                e.len().to_string(),
                f(median(e), 2),
                pct(inside(e, 9.0)),
                pct(inside(e, 4.0)),
                f(ctx.s(sigma, SPEC).corner_rate, 3),
            ],
        );
    }
}

/// The diagnostic variants (one change each) at their noise levels.
fn variants_table(md: &mut String, ctx: &Ctx) {
    let vs = &ctx.syn.variant_sigmas;
    if vs.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n### One change at a time (σ = {})\n",
        vs.iter().map(|&s| mm(s)).collect::<Vec<_>>().join(", ")
    );
    let _ = writeln!(
        md,
        "Each row changes one thing against the spec (the variants: \
         [FINDINGS.md](FINDINGS.md#reading-the-tables)).\n"
    );
    header(
        md,
        &[
            "σ",
            "variant",
            "TruePos",
            "FalsePos",
            "FalsePos w/o arcs",
            "neutral on arcs",
            "false on arcs",
            "σΔα / CRB",
            "σΔr / CRB",
            "NEES mean / median",
            "corners found",
            "corner NEES mean / median",
            "ms / scan",
        ],
    );
    for &sigma in vs {
        let names = std::iter::once(SPEC).chain(ctx.syn.variants.iter().map(String::as_str));
        for m in names {
            let t = ctx.t(sigma, m);
            let s = t.summary();
            row(
                md,
                vec![
                    mm(sigma),
                    m.to_string(),
                    f(s.true_pos, 3),
                    f(s.false_pos, 3),
                    f(s.false_pos_no_arc, 3),
                    t.lines.neutral_arc.to_string(),
                    t.lines.fp_arc.to_string(),
                    f(s.crb_alpha, 2),
                    f(s.crb_r, 2),
                    format!("{} / {}", f(s.nees_line, 2), f(s.nees_line_median, 2)),
                    f(s.corner_rate, 3),
                    format!("{} / {}", f(s.corner_nees, 2), f(s.corner_nees_median, 2)),
                    f(s.ms_per_scan, 3),
                ],
            );
        }
    }
}

fn scale_space(md: &mut String, ctx: &Ctx) -> Result<()> {
    let sc = ctx.scale;
    let _ = writeln!(md, "## 3. Scale space: passes and q\n");
    let _ = writeln!(
        md,
        "Measured on {} scans per family (other scans than section 1), the spec's parameters, one \
         50-pass run per scan and q, segmented and fitted after each listed pass (pass p is \
         exactly the core run with `iterations = p`).\n",
        sc.scans
    );
    if ctx.figures && !sc.sigmas.is_empty() {
        let file = "scale-passes.svg";
        figures::scale_passes(&ctx.args.output.join(file), sc)?;
        let _ = writeln!(md, "![scale space, passes]({file})\n");
        let file = "scale-q.svg";
        figures::scale_q(&ctx.args.output.join(file), sc)?;
        let _ = writeln!(md, "![scale space, q]({file})\n");
    }
    let walls: Vec<String> = sc
        .sigmas
        .iter()
        .map(|&s| {
            let per_scan = ctx
                .scale_at(s, 0.0, 1)
                .map_or(f64::NAN, |x| x.true_per_scan);
            format!("{} at σ = {}", f(per_scan, 2), mm(s))
        })
        .collect();
    let _ = writeln!(
        md,
        "**Against passes (q = 0).** Each cell: lines per scan · TruePos · FalsePos · \
         σΔα/CRB. Resolvable walls per scan: {}.\n",
        walls.join(", ")
    );
    scale_header(md, ctx, "passes");
    for &p in &PASSES {
        scale_row(md, ctx, p.to_string(), 0.0, p);
    }
    let _ = writeln!(
        md,
        "\n**Against q (30 passes).** Same cells; q = 1 m² is the paper's \"unity\".\n"
    );
    scale_header(md, ctx, "q (m²)");
    for &q in &QS {
        scale_row(md, ctx, format!("{q:e}"), q, 30);
    }
    let _ = writeln!(md);
    Ok(())
}

/// The header of a scale-space table: `first`, then one column per σ.
fn scale_header(md: &mut String, ctx: &Ctx, first: &str) {
    let mut cols: Vec<String> = vec![first.into()];
    cols.extend(ctx.scale.sigmas.iter().map(|&s| format!("σ = {}", mm(s))));
    header(md, &cols.iter().map(String::as_str).collect::<Vec<_>>());
}

/// One row of a scale-space table at process noise `q` after `pass`
/// passes; each cell lines per scan · TruePos · FalsePos · σΔα/CRB.
fn scale_row(md: &mut String, ctx: &Ctx, label: String, q: f32, pass: u16) {
    let cell = |s: Summary| {
        format!(
            "{} · {} · {} · {}",
            f(s.lines_per_scan, 2),
            f(s.true_pos, 3),
            f(s.false_pos, 3),
            f(s.crb_alpha, 2)
        )
    };
    let mut cells = vec![label];
    cells.extend(ctx.scale.sigmas.iter().map(|&s| {
        ctx.scale_at(s, q, pass)
            .map_or_else(|| "—".to_string(), cell)
    }));
    row(md, cells);
}

fn real_scans(md: &mut String, ctx: &Ctx) {
    let _ = writeln!(md, "## 4. Real scans\n");
    if ctx.real.is_empty() {
        let _ = writeln!(
            md,
            "No CARMEN logs were evaluated (none found in `{}`, or `--no-real`).\n",
            ctx.args.data.display()
        );
        return;
    }
    let _ = writeln!(
        md,
        "{} of each log in `{}` (read by `host_bridge::carmen`): the cm logs run with \
         **σ = 10 mm**, the mm logs with **σ = 5 mm**. *Explained* is the fraction of valid \
         beams inside the beam range of an accepted line. Times are per scan on one core shared \
         with other jobs, this build.\n",
        if ctx.args.real_every == 1 {
            "Every scan".to_string()
        } else {
            format!("Every {}-th scan", ctx.args.real_every)
        },
        ctx.args.data.display(),
    );
    real_table(md, ctx);
    calibration_table(md, ctx);
    representative_scans(md, ctx);
    let _ = writeln!(md);
}

/// Features, beams explained and time per log and main method.
fn real_table(md: &mut String, ctx: &Ctx) {
    header(
        md,
        &[
            "log",
            "scans × beams",
            "method",
            "lines / scan",
            "well-conditioned corners / scan",
            "beams explained",
            "median line χ²",
            "ms / scan (mean, max)",
        ],
    );
    for l in ctx.real {
        for m in &l.methods {
            row(
                md,
                vec![
                    format!("{}{}", l.name, if l.outdoor { " (outdoor)" } else { "" }),
                    format!("{} × {} ({})", l.scans, l.beams, l.unit),
                    m.method.clone(),
                    f(m.lines, 2),
                    f(m.corners, 2),
                    pct(m.explained),
                    f(m.median_chi2, 2),
                    format!("{}, {}", f(m.ms_mean, 3), f(m.ms_max, 3)),
                ],
            );
        }
    }
}

/// The spec on every log at each σ of [`CALIBRATION_SIGMAS`].
fn calibration_table(md: &mut String, ctx: &Ctx) {
    let _ = writeln!(
        md,
        "\n**σ calibration.** The spec with each σ: median χ² of the accepted lines · lines \
         per scan.\n"
    );
    let mut cols: Vec<String> = vec!["log".into()];
    cols.extend(CALIBRATION_SIGMAS.iter().map(|&s| format!("σ = {}", mm(s))));
    header(md, &cols.iter().map(String::as_str).collect::<Vec<_>>());
    for l in ctx.real {
        let mut cells = vec![l.name.clone()];
        cells.extend(
            l.calibration
                .iter()
                .map(|&(_, chi2, lines)| format!("{} · {}", f(chi2, 2), f(lines, 2))),
        );
        row(md, cells);
    }
}

/// The links to the scan figures of the logs that have one.
fn representative_scans(md: &mut String, ctx: &Ctx) {
    let plots: Vec<&LogResult> = ctx.real.iter().filter(|l| l.plot.is_some()).collect();
    if plots.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n**Representative scans** (the first scan of each log whose line count is the \
         log's median; the spec at the log's σ; drawn by `host_bridge::plot::draw_scan`).\n"
    );
    for l in plots {
        if let Some((k, file)) = &l.plot {
            let _ = writeln!(
                md,
                "![{} scan {k}]({file})\n\n*{}{}, scan {k}.*\n",
                l.name,
                l.name,
                if l.outdoor { " (outdoor)" } else { "" }
            );
        }
    }
}

fn reproduce(md: &mut String, ctx: &Ctx, timing: &Timing) {
    let a = ctx.args;
    let _ = writeln!(md, "## Reproduce\n");
    let _ = writeln!(
        md,
        "```sh\ncargo run --release -p lms-lab -- evaluate -o docs/evaluation{}{}\n```\n",
        if a.scans == 400 && a.scale_scans == 100 {
            String::new()
        } else {
            format!(" --scans {} --scale-scans {}", a.scans, a.scale_scans)
        },
        if a.truth == crate::TruthChoice::Legacy {
            " --truth legacy"
        } else {
            ""
        }
    );
    let _ = writeln!(
        md,
        "Options: `--scans N` (per family and σ), `--sigmas 0.005,0.01,0.02,0.03`, `--dropout P`, \
         `--seed S`, `--scale-scans N`, `--data DIR` (CARMEN logs), `--real-every K`, `--no-real`, \
         `--no-plots`, `--truth settled|legacy` (section 5's truth). This run: {:.0} s in total. The definitions are in the module docs of \
         `lab/src/metrics.rs`; the scenes in `scenes.rs`; the baselines in `baselines.rs`; the \
         experimental variants in `variants.rs`.",
        timing.total
    );
}
