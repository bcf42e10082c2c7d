//! Real scans: every CARMEN log of a folder through the core and the
//! baselines — lines and corners per scan, the fraction of valid beams
//! explained by lines, time per scan — and a σ calibration (median line
//! `chi2` per σ: 1 when σ matches the data's scatter about its lines).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use lms_core::{Extractor, Frame};

use crate::baselines::{self, run_core, Extraction, Tables};
use crate::metrics::{mean, median};
use crate::{main_methods, Kind, Method};
use host_bridge::carmen::{self, Unit, UnitMode};

/// σ used for a log in `unit` (m): 10 mm for the cm logs (quantised to
/// 1 cm, scattering more than the LMS's mm-mode 5 mm), 5 mm for mm logs;
/// the report's calibration table backs both.
pub fn sigma_for(unit: Unit) -> f64 {
    match unit {
        Unit::Centimetre => 0.01,
        Unit::Millimetre => 0.005,
        // A CARMEN log is read in cm or mm only.
        Unit::Decimetre => 0.01,
    }
}

/// σ values of the calibration table (m).
pub const CALIBRATION_SIGMAS: [f64; 4] = [0.005, 0.01, 0.02, 0.03];

/// One method on one log.
#[derive(Clone, Debug, PartialEq)]
pub struct RealStats {
    /// Method name.
    pub method: String,
    /// Lines per scan.
    pub lines: f64,
    /// Well-conditioned corners per scan.
    pub corners: f64,
    /// Mean fraction of valid beams inside an accepted line's span.
    pub explained: f64,
    /// Mean time per scan (ms).
    pub ms_mean: f64,
    /// Largest time of a scan (ms).
    pub ms_max: f64,
    /// Median `chi2` of the accepted lines.
    pub median_chi2: f64,
}

/// One log.
#[derive(Clone, Debug, PartialEq)]
pub struct LogResult {
    /// File name.
    pub name: String,
    /// Range unit.
    pub unit: String,
    /// Outdoor (Freiburg campus) rather than indoor.
    pub outdoor: bool,
    /// Scans evaluated.
    pub scans: usize,
    /// Beams per scan.
    pub beams: usize,
    /// σ used (m).
    pub sigma: f64,
    /// Per method.
    pub methods: Vec<RealStats>,
    /// Per calibration σ: (σ, median line chi2, lines per scan) of the spec.
    pub calibration: Vec<(f64, f64, f64)>,
    /// The representative scan plotted (FLASER index) and the figure's file name.
    pub plot: Option<(usize, String)>,
}

/// The `*.log.gz` / `*.log` files of `dir`, sorted; an error if `dir` is
/// not a readable directory or holds no log (a mistyped `--data` must not
/// evaluate no real scans in silence).
pub fn find_logs(dir: &Path) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|e| {
        anyhow::anyhow!(
            "--data {}: {e} (give the folder of the CARMEN logs, or --no-real)",
            dir.display()
        )
    })?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let n = p
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            n.ends_with(".log.gz") || n.ends_with(".log")
        })
        .collect();
    v.sort();
    anyhow::ensure!(
        !v.is_empty(),
        "--data {}: no *.log or *.log.gz file in it (give the folder of the CARMEN logs, or --no-real)",
        dir.display()
    );
    Ok(v)
}

/// Progress units known before the logs are read (they are added as each
/// log is read).
pub fn count_units(_logs: &[PathBuf], _every: usize) -> u64 {
    0
}

/// Valid beams inside the span of some line / valid beams.
pub fn explained(frame: &Frame, x: &Extraction) -> f64 {
    let beams = frame.beams();
    let valid = beams.iter().filter(|b| b.is_valid()).count();
    if valid == 0 {
        return f64::NAN;
    }
    let mut covered = vec![false; beams.len()];
    for l in &x.lines {
        for c in covered
            .iter_mut()
            .take(l.last as usize + 1)
            .skip(l.first as usize)
        {
            *c = true;
        }
    }
    let n = (0..beams.len())
        .filter(|&j| covered[j] && beams[j].is_valid())
        .count();
    n as f64 / valid as f64
}

fn extract(
    m: &Method,
    ex: &mut Extractor,
    frame: &Frame,
    tables: &Tables,
    sigma: f64,
) -> Extraction {
    let p = m.params(sigma);
    match m.kind {
        Kind::Core => run_core(ex, frame, &p),
        Kind::SplitMerge { k } => baselines::split_and_merge(frame, tables, &p, k),
        Kind::Gaussian { s } => baselines::gaussian_mask(frame, tables, &p, s),
        Kind::Variant(o) => crate::variants::extract(frame, tables, &p, &o),
    }
}

/// Per-scan values of one method on one log.
#[derive(Clone, Debug, Default)]
struct Acc {
    lines: Vec<f64>,
    corners: Vec<f64>,
    explained: Vec<f64>,
    ms: Vec<f64>,
    chi2: Vec<f64>,
}

/// Run every log; draws the representative scans into `figures` if given.
pub fn run_logs(
    logs: &[PathBuf],
    every: usize,
    figures: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<LogResult>> {
    let mut out = Vec::new();
    for path in logs {
        out.push(run_log(path, every, figures, bar)?);
    }
    Ok(out)
}

/// A log that could not be read: its path and why.
pub type LeftOut = (String, String);

/// Every log that can be read, and for each one that cannot its name and
/// why: one bad log does not stop the others (the report lists it).
pub fn run_logs_reporting(
    logs: &[PathBuf],
    every: usize,
    figures: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> (Vec<LogResult>, Vec<LeftOut>) {
    let mut out = Vec::new();
    let mut failed = Vec::new();
    for path in logs {
        match run_log(path, every, figures, bar) {
            Ok(r) => out.push(r),
            Err(e) => {
                let name = path.display().to_string();
                bar.suspend(|| eprintln!("lms-lab evaluate: warning: {name} left out: {e:#}"));
                failed.push((name, format!("{e:#}")));
            }
        }
    }
    (out, failed)
}

/// One log through every method.
fn run_log(
    path: &Path,
    every: usize,
    figures: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> Result<LogResult> {
    let methods = main_methods();
    let mut ex = Extractor::new();
    {
        let log = carmen::read_log(path, UnitMode::Auto)?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let scans: Vec<&carmen::Scan> = log.scans.iter().step_by(every).collect();
        bar.inc_length(scans.len() as u64);
        bar.set_message(format!("real scans, {name}"));
        let sigma = sigma_for(log.unit);
        let mut per_method: Vec<Acc> = vec![Acc::default(); methods.len()];
        let mut spec_lines: Vec<usize> = Vec::new();
        let mut calib: Vec<(Vec<f64>, usize)> = vec![Default::default(); CALIBRATION_SIGMAS.len()];
        for scan in &scans {
            let tables = Tables::for_frame(&scan.frame);
            for (m, acc) in methods.iter().zip(per_method.iter_mut()) {
                let started = Instant::now();
                let x = extract(m, &mut ex, &scan.frame, &tables, sigma);
                acc.ms.push(started.elapsed().as_secs_f64() * 1e3);
                acc.lines.push(x.lines.len() as f64);
                acc.corners
                    .push(x.corners.iter().filter(|c| c.well_conditioned).count() as f64);
                acc.explained.push(explained(&scan.frame, &x));
                acc.chi2.extend(x.lines.iter().map(|l| l.chi2 as f64));
                if std::ptr::eq(m, &methods[0]) {
                    spec_lines.push(x.lines.len());
                }
            }
            for (&s, c) in CALIBRATION_SIGMAS.iter().zip(calib.iter_mut()) {
                let x = extract(&methods[0], &mut ex, &scan.frame, &tables, s);
                c.0.extend(x.lines.iter().map(|l| l.chi2 as f64));
                c.1 += x.lines.len();
            }
            bar.inc(1);
        }
        let n = scans.len().max(1) as f64;
        let stats = methods
            .iter()
            .zip(&per_method)
            .map(|(m, acc)| RealStats {
                method: m.name.clone(),
                lines: mean(&acc.lines),
                corners: mean(&acc.corners),
                explained: mean(&acc.explained),
                ms_mean: mean(&acc.ms),
                ms_max: acc.ms.iter().copied().fold(0.0, f64::max),
                median_chi2: median(&acc.chi2),
            })
            .collect();
        let calibration = CALIBRATION_SIGMAS
            .iter()
            .zip(&calib)
            .map(|(&s, c)| (s, median(&c.0), c.1 as f64 / n))
            .collect();
        // The representative scan: the first whose line count is the median.
        let mut sorted = spec_lines.clone();
        sorted.sort_unstable();
        let typical = sorted.get(sorted.len() / 2).copied().unwrap_or(0);
        let pick = spec_lines.iter().position(|&l| l == typical);
        let plot = match (figures, pick) {
            (Some(dir), Some(i)) => {
                let scan = scans[i];
                let stem = name.trim_end_matches(".gz").trim_end_matches(".log");
                let file = format!("real-{stem}-{}.svg", scan.index);
                let params = methods[0].params(sigma);
                crate::report::scan_figure(
                    &dir.join(&file),
                    format!("{name} ({} ranges), σ = {} m", log.unit, sigma),
                    scan.index,
                    &scan.frame,
                    &params,
                )?;
                Some((scan.index, file))
            }
            _ => None,
        };
        Ok(LogResult {
            outdoor: name.contains("campus"),
            name,
            unit: log.unit.to_string(),
            scans: scans.len(),
            beams: scans.first().map_or(0, |s| s.frame.len()),
            sigma,
            methods: stats,
            calibration,
            plot,
        })
    }
}

/// The real-scan part of `evaluate`: the logs evaluated, and those left
/// out with the reason.
pub fn run(
    args: &crate::EvaluateArgs,
    logs: &[PathBuf],
    bar: &indicatif::ProgressBar,
) -> Result<(Vec<LogResult>, Vec<LeftOut>)> {
    let figures =
        (!args.no_plots && crate::report::fonts_available()).then_some(args.output.as_path());
    Ok(run_logs_reporting(logs, args.real_every, figures, bar))
}
