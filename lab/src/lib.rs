//! # lms-lab — the evaluation of the LMS 2xx feature extractor
//!
//! Research tooling, not the product: `lms-lab evaluate` measures the
//! paper's claims — accuracy against ground truth on synthetic scans, the
//! scale space, two baselines, and real scans — and writes the tables and
//! SVG figures of a Markdown report (`docs/evaluation/README.md`); the
//! conclusions are written by hand in `docs/evaluation/FINDINGS.md`. No
//! stability promise: it uses the core's internals through
//! `lms_core::unstable` (feature `unstable-lab`) and the product's library
//! (`host-bridge`: CARMEN reader, synthetic frames, plots).
//!
//! * [`scenes`] — the synthetic scene families and their noisy scans.
//! * [`metrics`] — ground truth per scan, matching, TruePos/FalsePos,
//!   errors against the Cramér–Rao bound, NEES, corners.
//! * [`baselines`] — split-and-merge and the Gaussian mask, on the core's
//!   own §7–8 back end.
//! * [`variants`] — experimental changes of the smoothing and the fit
//!   (window stride, weight rule, split before reject, information gate).
//! * [`scale`] — segments, lines and errors against passes and q.
//! * [`real`] — CARMEN logs: features per scan, beams explained, time.
//! * [`report`] — the Markdown tables of the report; [`figures`] its
//!   figures, drawn with [`charts`].
#![forbid(unsafe_code)]

pub mod ablation;
pub mod baselines;
pub mod charts;
pub mod figures;
pub mod maptruth;
pub mod metrics;
pub mod real;
pub mod realfigures;
pub mod realistic;
pub mod realtruth;
pub mod report;
pub mod scale;
pub mod scenes;
pub mod sensorfit;
pub mod sweep;
pub mod variants;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{ensure, Context, Result};
use clap::Args;
use lms_core::{Extractor, Params};

use baselines::{run_core, Extraction, Tables};
use metrics::{
    scan_truth, score_corners, score_lines, CornerScore, Gates, LineScore, ScanTruth, Tally,
};
use scenes::{Family, NoiseSpec, Sample};

/// Options of `lms-lab evaluate`.
#[derive(Args, Clone, Debug)]
pub struct EvaluateArgs {
    /// Folder the report (README.md) and its figures are written to (created if missing)
    #[arg(long, short, value_name = "DIR", default_value = "evaluation")]
    pub output: PathBuf,
    /// Synthetic scans per scene family and noise level
    #[arg(long, value_name = "N", default_value_t = 400)]
    pub scans: usize,
    /// Range noise levels σ of the synthetic scans (m), comma-separated
    #[arg(
        long,
        value_name = "S,S,..",
        value_delimiter = ',',
        allow_negative_numbers = true,
        default_values_t = [0.005, 0.01, 0.02, 0.03]
    )]
    pub sigmas: Vec<f64>,
    /// Probability of a no-echo dropout per synthetic beam
    #[arg(long, value_name = "P", default_value_t = 0.01)]
    pub dropout: f64,
    /// Seed of the synthetic scenes, poses and noise
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scans per scene family for the scale-space sweep (passes × q)
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub scale_scans: usize,
    /// Folder of CARMEN logs (*.log.gz) for the real-scan part
    #[arg(long, value_name = "DIR", default_value = "../shared/data/carmen")]
    pub data: PathBuf,
    /// Use every K-th scan of each log
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub real_every: usize,
    /// Skip the real scans
    #[arg(long)]
    pub no_real: bool,
    /// Write no figures (tables only)
    #[arg(long)]
    pub no_plots: bool,
    /// Which truth the real scans are scored against (section 5): `settled`
    /// (registered poses, leave-one-wall-out, neutral and unexplained
    /// lines) or `legacy` (SLAM poses, verified pieces)
    #[arg(long, value_enum, value_name = "TRUTH", default_value_t = TruthChoice::Settled)]
    pub truth: TruthChoice,
}

/// Options of `lms-lab truth`.
#[derive(Args, Clone, Debug)]
pub struct TruthArgs {
    /// Folder real-truth.md and its figures are written to (created if missing)
    #[arg(long, short, value_name = "DIR", default_value = "evaluation")]
    pub output: PathBuf,
    /// Folder of CARMEN logs (*.log.gz)
    #[arg(long, value_name = "DIR", default_value = "../shared/data/carmen")]
    pub data: PathBuf,
    /// Use every K-th frame of each log (the map is built from all)
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub every: usize,
    /// Write no figures
    #[arg(long)]
    pub no_plots: bool,
    /// Synthetic scans per scene family and σ₀ from the realistic sensor model (0: none)
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub synthetic_scans: usize,
    /// Which truth: `settled` (registered poses, leave-one-wall-out, neutral
    /// and unexplained lines) or `legacy` (SLAM poses, verified pieces)
    #[arg(long, value_enum, value_name = "TRUTH", default_value_t = TruthChoice::Settled)]
    pub truth: TruthChoice,
}

/// The map truth a run scores against (`--truth` of `lms-lab truth` and
/// `lms-lab evaluate`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum TruthChoice {
    /// [`maptruth::TruthConfig::settled`], the evaluation's default.
    #[default]
    Settled,
    /// [`maptruth::TruthConfig::legacy`].
    Legacy,
}

impl TruthChoice {
    /// Its settings.
    pub fn config(self) -> maptruth::TruthConfig {
        match self {
            TruthChoice::Settled => maptruth::TruthConfig::settled(),
            TruthChoice::Legacy => maptruth::TruthConfig::legacy(),
        }
    }
}

/// The real-scan parts of the report (sections 5–7): the map truth, the
/// sensor model and the realistic synthetic scenes.
#[derive(Clone, Debug, Default)]
pub struct RealSections {
    /// Real logs against map-derived truth.
    pub truth: Vec<realtruth::LogTruth>,
    /// The sensor model fitted to each log.
    pub fits: Vec<sensorfit::LogFit>,
    /// Synthetic scenes from the realistic model: (σ₀, method, tally).
    pub realistic: Vec<(f64, String, metrics::Tally)>,
    /// Scans per family and σ₀ of `realistic`.
    pub realistic_scans: usize,
}

impl RealSections {
    /// Sections 5–7 in Markdown (those that ran).
    pub fn markdown(&self, every: usize) -> String {
        let mut md = String::new();
        if !self.truth.is_empty() {
            md.push_str(&realtruth::markdown(&self.truth, every));
            md.push('\n');
        }
        if !self.fits.is_empty() {
            md.push_str(&sensorfit::markdown(&self.fits));
            md.push('\n');
        }
        if !self.realistic.is_empty() {
            md.push_str(&realistic::markdown(&self.realistic, self.realistic_scans));
            md.push('\n');
        }
        md
    }
}

/// Synthetic scans drawn from each log's fitted sensor model.
pub const SENSOR_FIT_SCANS: usize = 60;

/// `lms-lab truth`: the map-truth evaluation of the real logs alone.
pub fn run_truth(args: &TruthArgs) -> Result<()> {
    let started = Instant::now();
    let path = realtruth::run_standalone(args)?;
    eprintln!(
        "lms-lab truth: wrote {} ({:.1} s)",
        path.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// How a method cuts a scan into segments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// The core (`Extractor::run`).
    Core,
    /// Split-and-merge (IEPF) with threshold `k·σ`.
    SplitMerge {
        /// Threshold in units of σ.
        k: f32,
    },
    /// Gaussian mask of `s` beams, then `D` and τ.
    Gaussian {
        /// Kernel standard deviation (beams).
        s: f64,
    },
    /// An experimental variant of the smoothing ([`variants`]).
    Variant(variants::Options),
}

/// An extractor with its parameter changes against the spec's defaults.
#[derive(Clone, Debug)]
pub struct Method {
    /// Name in the tables.
    pub name: String,
    /// What it runs.
    pub kind: Kind,
    /// Parameter changes (σ is always set to the scan's noise).
    pub adjust: fn(Params) -> Params,
}

impl Method {
    /// A method without parameter changes.
    pub fn new(name: &str, kind: Kind) -> Self {
        Method {
            name: name.to_string(),
            kind,
            adjust: |p| p,
        }
    }

    /// A method with parameter changes.
    pub fn with(name: &str, kind: Kind, adjust: fn(Params) -> Params) -> Self {
        Method {
            name: name.to_string(),
            kind,
            adjust,
        }
    }

    /// The parameters for scans with noise `sigma`: ALGORITHM.md v1's
    /// defaults ([`Params::PAPER`], "the spec" of every table; the
    /// baselines and variants replicate its back end) with σ, then the
    /// method's changes.
    pub fn params(&self, sigma: f64) -> Params {
        (self.adjust)(Params::PAPER.with_sigma(sigma as f32))
    }

    /// Run on `frame`.
    pub fn extract(&self, ex: &mut Extractor, s: &Sample, tables: &Tables) -> Extraction {
        let p = self.params(s.sigma);
        match self.kind {
            Kind::Core => run_core(ex, &s.frame, &p),
            Kind::SplitMerge { k } => baselines::split_and_merge(&s.frame, tables, &p, k),
            Kind::Gaussian { s: w } => baselines::gaussian_mask(&s.frame, tables, &p, w),
            Kind::Variant(o) => variants::extract(&s.frame, tables, &p, &o),
        }
    }
}

/// Kernel width of the Gaussian-mask baseline (beams): the width whose
/// white-noise reduction equals that of the core's 30 passes on a wall
/// (range RMS × 0.455–0.460, README "Measured figures"): 1/√(2√π·s) = 0.4575.
pub const GAUSS_EQUAL_SMOOTHING: f64 = 1.35;
/// Split threshold of the split-and-merge baseline in units of σ.
pub const SPLIT_K: f32 = 4.0;

/// The split-before-reject depth of the proposal.
pub const PROPOSED_SPLIT_DEPTH: u8 = 8;
/// The information gate of the second proposal: σ_α ≤ 5°/3 (rad).
pub const INFO_GATE_SD_ALPHA: f32 = 5.0 / 3.0 * core::f32::consts::PI / 180.0;

fn no_shared(p: Params) -> Params {
    p.with_fit_shared_points(false)
}

/// Name of the spec's method in every table.
pub const SPEC: &str = "spec (--preset paper)";
/// Name of the defaults' method ([`Params::DEFAULT`] with σ, no flags) in
/// every table.
pub const DEFAULTS: &str = "defaults";
/// Name of the `fit_shared_points = false` method.
pub const NO_SHARED: &str = "fit_shared_points = false";
/// Name of the split-and-merge baseline.
pub const SPLIT_MERGE: &str = "split-and-merge (4σ)";
/// Name of the Gaussian-mask baseline.
pub const GAUSSIAN: &str = "Gaussian mask (s = 1.35)";
/// Name of the first proposal.
pub const PROPOSAL: &str = "proposal A: split before reject";
/// Name of the second proposal.
pub const PROPOSAL_INFO: &str = "proposal B: A + information gate";

/// The methods of the main tables (run at every σ).
pub fn main_methods() -> Vec<Method> {
    use variants::Options;
    let a = Options {
        split_depth: PROPOSED_SPLIT_DEPTH,
        arc_guard: true,
        reject_failing: true,
        ..Options::default()
    };
    vec![
        Method::new(SPEC, Kind::Core),
        defaults_method(),
        Method::with(NO_SHARED, Kind::Core, no_shared),
        Method::new(SPLIT_MERGE, Kind::SplitMerge { k: SPLIT_K }),
        Method::new(
            GAUSSIAN,
            Kind::Gaussian {
                s: GAUSS_EQUAL_SMOOTHING,
            },
        ),
        Method::with(PROPOSAL, Kind::Variant(a), no_shared),
        Method::with(
            PROPOSAL_INFO,
            Kind::Variant(Options {
                max_sd_alpha: INFO_GATE_SD_ALPHA,
                ..a
            }),
            no_shared,
        ),
    ]
}

/// The defaults: [`Params::DEFAULT`] with the scan's σ, no flags.
pub fn defaults_method() -> Method {
    Method::with(DEFAULTS, Kind::Core, |p| {
        Params::DEFAULT.with_sigma(p.sigma)
    })
}

/// The diagnostic variants (run at [`VARIANT_SIGMAS`]): one change each
/// against the spec, to find out why a goal is missed.
pub fn diagnostic_variants() -> Vec<Method> {
    use variants::{Options, Rule};
    let o = Options::default();
    let sbr = Options {
        split_depth: PROPOSED_SPLIT_DEPTH,
        ..o
    };
    vec![
        Method::with("τ = 4", Kind::Core, |p| p.with_tau(4.0)),
        Method::with("τ = 16", Kind::Core, |p| p.with_tau(16.0)),
        Method::with("3 passes", Kind::Core, |p| p.with_iterations(3)),
        Method::with("100 passes", Kind::Core, |p| p.with_iterations(100)),
        Method::with("q = 1e-4 m²", Kind::Core, |p| p.with_q(1e-4)),
        Method::new(
            "normalised observation weight",
            Kind::Variant(Options {
                rule: Rule::Normalised,
                ..o
            }),
        ),
        Method::new(
            "fit on smoothed ranges",
            Kind::Variant(Options {
                fit_smoothed: true,
                ..o
            }),
        ),
        Method::with("max χ² = 2", Kind::Core, |p| p.with_max_chi2(2.0)),
        Method::with("max χ² = 8", Kind::Core, |p| p.with_max_chi2(8.0)),
        Method::with("no merge", Kind::Core, |p| p.with_merge(false)),
        Method::new("window stride 2", Kind::Variant(Options { stride: 2, ..o })),
        Method::new("window stride 4", Kind::Variant(Options { stride: 4, ..o })),
        Method::new("split before reject, no arc guard", Kind::Variant(sbr)),
        Method::new(
            "split before reject + arc guard",
            Kind::Variant(Options {
                arc_guard: true,
                ..sbr
            }),
        ),
        Method::with(
            "A without rejecting what still fails χ²",
            Kind::Variant(Options {
                arc_guard: true,
                ..sbr
            }),
            no_shared,
        ),
        Method::with(
            "split before reject depth 1 + arc guard, no shared",
            Kind::Variant(Options {
                split_depth: 1,
                arc_guard: true,
                ..o
            }),
            no_shared,
        ),
        Method::with(
            "information gate only, no shared",
            Kind::Variant(Options {
                max_sd_alpha: INFO_GATE_SD_ALPHA,
                ..o
            }),
            no_shared,
        ),
        Method::new("split-and-merge (3σ)", Kind::SplitMerge { k: 3.0 }),
        Method::new("split-and-merge (5σ)", Kind::SplitMerge { k: 5.0 }),
        Method::new("Gaussian mask (s = 2)", Kind::Gaussian { s: 2.0 }),
        Method::new("Gaussian mask (s = 3)", Kind::Gaussian { s: 3.0 }),
    ]
}

/// Noise levels of the diagnostic variants (m).
pub const VARIANT_SIGMAS: [f64; 2] = [0.01, 0.02];

/// One tally: a method on one family at one noise level.
#[derive(Clone, Debug)]
pub struct Cell {
    /// Noise σ (m).
    pub sigma: f64,
    /// Scene family.
    pub family: Family,
    /// Method name.
    pub method: String,
    /// The scores.
    pub tally: Tally,
}

/// Everything measured on the synthetic scans.
#[derive(Clone, Debug, Default)]
pub struct Synthetic {
    /// Noise levels.
    pub sigmas: Vec<f64>,
    /// Method names of the main tables, in order.
    pub methods: Vec<String>,
    /// Method names of the diagnostic variants, in order.
    pub variants: Vec<String>,
    /// Noise level of the diagnostic variants (m).
    pub variant_sigmas: Vec<f64>,
    /// All cells.
    pub cells: Vec<Cell>,
    /// Scans per family and noise level.
    pub scans: usize,
    /// Per σ: the noise-free corner evidence of every counted true corner
    /// ([`metrics::corner_evidence`]).
    pub corner_evidence: Vec<Vec<f64>>,
}

impl Synthetic {
    /// The pooled tally of `method` at `sigma` over `families` (all if empty).
    pub fn pooled(&self, sigma: f64, method: &str, families: &[Family]) -> Tally {
        let mut t = Tally::default();
        for c in &self.cells {
            if c.sigma == sigma
                && c.method == method
                && (families.is_empty() || families.contains(&c.family))
            {
                t.merge(&c.tally);
            }
        }
        t
    }
}

/// Score one extraction against the truth (lines with the reasons for
/// misses, and corners).
pub fn score(
    truth: &ScanTruth,
    x: &Extraction,
    frame: &lms_core::Frame,
    sigma: f64,
    gates: &Gates,
) -> (LineScore, CornerScore) {
    let mut ls = score_lines(truth, &x.lines, frame.beams(), sigma, gates);
    let spans: Vec<(usize, usize)> = x
        .segments
        .iter()
        .map(|s| (s.first as usize, s.last as usize))
        .collect();
    let matched = std::mem::take(&mut ls.piece_matched);
    metrics::classify_misses(truth, &matched, &spans, &mut ls);
    (ls, score_corners(truth, &x.corners, gates))
}

/// Score `methods` on `sample`, adding to `cells` (one per method, same order).
pub fn score_sample(
    sample: &Sample,
    methods: &[Method],
    gates: &Gates,
    ex: &mut Extractor,
    tallies: &mut [Tally],
) -> ScanTruth {
    let tables = Tables::for_frame(&sample.frame);
    let base = methods[0].params(sample.sigma);
    let truth = scan_truth(&sample.truth, &sample.scene, &base, sample.sigma, gates);
    for (m, tally) in methods.iter().zip(tallies.iter_mut()) {
        let started = Instant::now();
        let x = m.extract(ex, sample, &tables);
        let seconds = started.elapsed().as_secs_f64();
        let (ls, cs) = score(&truth, &x, &sample.frame, sample.sigma, gates);
        tally.add(&ls, &cs, x.segments.len(), seconds);
    }
    truth
}

/// A progress bar on a terminal, hidden otherwise.
pub fn progress(total: u64) -> indicatif::ProgressBar {
    if std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(total);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{spinner} evaluating {bar:30} {pos}/{len} {msg} ({eta} left)",
        ) {
            bar.set_style(style);
        }
        bar
    } else {
        indicatif::ProgressBar::hidden()
    }
}

/// The synthetic part: `methods` at every σ, `variants` at `variant_sigmas`.
pub fn run_synthetic(
    args: &EvaluateArgs,
    methods: &[Method],
    variants: &[Method],
    variant_sigmas: &[f64],
    bar: &indicatif::ProgressBar,
) -> Result<Synthetic> {
    let gates = Gates::default();
    let mut ex = Extractor::new();
    let mut out = Synthetic {
        sigmas: args.sigmas.clone(),
        methods: methods.iter().map(|m| m.name.clone()).collect(),
        variants: variants.iter().map(|m| m.name.clone()).collect(),
        variant_sigmas: variant_sigmas.to_vec(),
        scans: args.scans,
        ..Synthetic::default()
    };
    for &sigma in &args.sigmas {
        let mut evidence = Vec::new();
        let mut all: Vec<Method> = methods.to_vec();
        if variant_sigmas.contains(&sigma) {
            all.extend(variants.iter().cloned());
        }
        for family in Family::ALL {
            bar.set_message(format!("σ = {} mm, {}", sigma * 1e3, family.name()));
            let mut tallies = vec![Tally::default(); all.len()];
            for k in 0..args.scans {
                let noise = NoiseSpec {
                    sigma,
                    dropout: args.dropout,
                };
                let s = scenes::sample(family, k, args.seed, noise)?;
                let truth = score_sample(&s, &all, &gates, &mut ex, &mut tallies);
                evidence.extend(metrics::corner_evidence(
                    &s.truth,
                    &truth.corners,
                    &s.frame,
                    sigma,
                ));
                bar.inc(1);
            }
            for (m, tally) in all.iter().zip(tallies) {
                out.cells.push(Cell {
                    sigma,
                    family,
                    method: m.name.clone(),
                    tally,
                });
            }
        }
        out.corner_evidence.push(evidence);
    }
    Ok(out)
}

/// Add the logs that could not be read to the report, with the reason.
fn append_left_out(report: &std::path::Path, left_out: &[(String, String)]) -> Result<()> {
    use std::io::Write as _;
    if left_out.is_empty() {
        return Ok(());
    }
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(report)
        .with_context(|| format!("cannot write {}", report.display()))?;
    let mut text = String::from("\n## Logs left out\n\nThese logs of `--data` could not be read; the tables above do not include them.\n\n");
    for (name, why) in left_out {
        text.push_str(&format!("- `{name}`: {why}\n"));
    }
    f.write_all(text.as_bytes())
        .with_context(|| format!("cannot write {}", report.display()))
}

/// `lms-lab evaluate`: run every part and write the report; logs that
/// cannot be read are left out, listed in the report, and make the run
/// fail after the report is written.
pub fn run(args: &EvaluateArgs) -> Result<()> {
    ensure!(args.scans > 0, "--scans must be at least 1");
    ensure!(!args.sigmas.is_empty(), "--sigmas needs at least one value");
    ensure!(
        args.sigmas.iter().all(|s| s.is_finite() && *s > 0.0),
        "--sigmas must be positive (metres)"
    );
    ensure!(
        (0.0..=1.0).contains(&args.dropout),
        "--dropout must be a probability in 0..=1"
    );
    ensure!(args.real_every > 0, "--real-every must be at least 1");
    let started = Instant::now();
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("cannot create {}", args.output.display()))?;

    let methods = main_methods();
    let variants = diagnostic_variants();
    let variant_sigmas: Vec<f64> = args
        .sigmas
        .iter()
        .copied()
        .filter(|s| VARIANT_SIGMAS.iter().any(|v| (v - s).abs() < 1e-12))
        .collect();
    let logs = if args.no_real {
        Vec::new()
    } else {
        real::find_logs(&args.data)?
    };
    let real_units = real::count_units(&logs, args.real_every);
    let synthetic_units = (args.sigmas.len() * Family::ALL.len() * args.scans) as u64;
    let scale_units = scale::units(args);
    let bar = progress(synthetic_units + scale_units + real_units);

    let t0 = Instant::now();
    let synthetic = run_synthetic(args, &methods, &variants, &variant_sigmas, &bar)?;
    let t1 = Instant::now();
    let scale = scale::run(args, &bar)?;
    let t2 = Instant::now();
    let (real, left_out) = real::run(args, &logs, &bar)?;
    // The map truth and the sensor fit read only the logs that could be read.
    let readable: Vec<_> = logs
        .iter()
        .filter(|p| {
            !left_out
                .iter()
                .any(|(name, _)| *name == p.display().to_string())
        })
        .cloned()
        .collect();
    let truth_figures =
        (!args.no_plots && report::fonts_available()).then_some(args.output.as_path());
    let truth = realtruth::run_logs(
        &readable,
        args.real_every,
        &args.truth.config(),
        truth_figures,
        &bar,
    )?;
    let fits = sensorfit::run(&readable, SENSOR_FIT_SCANS.min(args.scans))?;
    let realistic = realistic::run(args.scans, args.seed, &bar)?;
    let t3 = Instant::now();
    bar.set_message("writing the report");
    let timing = report::Timing {
        synthetic: (t1 - t0).as_secs_f64(),
        scale: (t2 - t1).as_secs_f64(),
        real: (t3 - t2).as_secs_f64(),
        total: started.elapsed().as_secs_f64(),
    };
    let sections = RealSections {
        truth,
        fits,
        realistic,
        realistic_scans: args.scans,
    };
    let path = report::write(args, &synthetic, &scale, (&real, &sections), timing)?;
    append_left_out(&path, &left_out)?;
    bar.finish_and_clear();
    ensure!(
        left_out.is_empty(),
        "{} of {} logs could not be evaluated (listed in {} and above); the report covers the rest",
        left_out.len(),
        logs.len(),
        path.display()
    );
    eprintln!(
        "lms-lab evaluate: wrote {} ({:.1} s)",
        path.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
