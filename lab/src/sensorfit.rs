//! The realistic sensor model ([`lms_scene::LmsModel`]) fitted to the
//! shared real logs, with the map-derived truth of
//! [`crate::maptruth`] telling which beams are on walls.
//!
//! # The statistic
//! For three consecutive beams on one counted true piece, with the residual
//! `ε_j = d_j − r / cos(φ_j − α)` against the piece's own least-squares line
//! (the oracle's, so pose and map error drop out), the second difference
//! `Δ²ε_j = ε_{j−1} − 2ε_j + ε_{j+1}` has variance `6σ²` for independent
//! noise of σ. Binned by incidence θ = |φ_j − α|: the robust σ̂ =
//! 1.4826·MAD(Δ²ε)/√6 and the rms σ̂ = √(mean(Δ²ε²)/6) (which also sees the
//! heavy tails: stair-steps, mixed pixels).
//!
//! # The fit
//! Per log: the quantisation step q (5 cm if nine in ten ranges are whole
//! multiples of 5 cm, else the unit), then [`fit`]: `σ̂² − q²/12` against
//! the bin's means of `(d·tan θ)²` and, in 0.5° logs, `1/cos²θ` — the
//! model's `σ(θ, d)² = σ₀² + (κ·d·tan θ)²` and the interleaved turns δ apart. The check: the same statistic on
//! synthetic scans drawn from the fitted model (random rooms, corridors,
//! rooms with a box; the true lines of [`lms_scene::TrueScan`]).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use host_bridge::carmen::{self, Scan, Unit, UnitMode};
use lms_scene::{Bearings, LmsModel, LogMode, LogValue, Pose, Scene};

use crate::maptruth::{build_map, frame_truth, FrameTruth, TruthConfig};

/// Upper edges of the incidence bins (degrees).
pub const BINS_DEG: [f64; 8] = [30.0, 45.0, 60.0, 70.0, 75.0, 80.0, 85.0, 90.0];

/// One triple: incidence (rad), range (m), second difference (m).
pub type Triple = (f64, f64, f64);

/// The triples of one frame's counted pieces (see the module docs).
pub fn triples(scan: &Scan, truth: &FrameTruth) -> Vec<Triple> {
    let lines = crate::realtruth::oracle_lines(truth);
    let g = scan.frame.geometry();
    let r = scan.frame.ranges();
    let mut out = Vec::new();
    for (l, p) in lines.iter().zip(truth.pieces.iter().filter(|p| p.counted)) {
        let eps = |j: usize| {
            let c = (f64::from(g.bearing(j)) - l.alpha).cos();
            (truth.on_wall[j] == Some(p.line) && c > 0.02).then(|| f64::from(r[j]) - l.r / c)
        };
        for j in p.first + 1..p.last {
            if let (Some(a), Some(b), Some(c)) = (eps(j - 1), eps(j), eps(j + 1)) {
                let theta = lms_scene::wrap_angle(f64::from(g.bearing(j)) - l.alpha).abs();
                let d = f64::from(scan.frame.ranges()[j]);
                out.push((theta, d, a - 2.0 * b + c));
            }
        }
    }
    out
}

/// The triples of a synthetic scan: readings against the true lines.
pub fn synthetic_triples(truth: &lms_scene::TrueScan, values: &[LogValue]) -> Vec<Triple> {
    let mut out = Vec::new();
    for l in &truth.lines {
        let eps = |j: usize| {
            let h = truth.hits[j]?;
            if h.surface != l.surface {
                return None;
            }
            let LogValue::Range(d) = values[j] else {
                return None;
            };
            let c = (truth.bearings.bearing(j) - l.alpha).cos();
            // The real truth's on-wall test: within 0.1 m of the line.
            (c > 0.02 && ((d - l.r / c) * c).abs() <= 0.1).then(|| d - l.r / c)
        };
        for j in l.first_beam + 1..l.last_beam {
            if let (Some(a), Some(b), Some(c)) = (eps(j - 1), eps(j), eps(j + 1)) {
                let theta = lms_scene::wrap_angle(truth.bearings.bearing(j) - l.alpha).abs();
                let d = truth.hits[j].map_or(0.0, |h| h.range);
                out.push((theta, d, a - 2.0 * b + c));
            }
        }
    }
    out
}

/// One incidence bin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bin {
    /// Triples.
    pub n: usize,
    /// Trimmed σ̂ (m): the largest 2 % of Δ²ε left out (robust, and
    /// meaningful on cm-quantised data where a MAD is not).
    pub robust: f64,
    /// Mean of 1/cos²θ.
    pub sec2: f64,
    /// rms σ̂ (m).
    pub rms: f64,
    /// Mean of (d·tan θ)² (m²).
    pub dtan2: f64,
}

/// The bins of `triples`.
pub fn bins(triples: &[Triple]) -> Vec<Bin> {
    let mut lo = 0.0;
    BINS_DEG
        .iter()
        .map(|&hi| {
            let sel: Vec<&Triple> = triples
                .iter()
                .filter(|t| t.0.to_degrees() >= lo && t.0.to_degrees() < hi)
                .collect();
            lo = hi;
            let n = sel.len();
            if n == 0 {
                return Bin::default();
            }
            let mut sq: Vec<f64> = sel.iter().map(|t| t.2 * t.2).collect();
            sq.sort_by(f64::total_cmp);
            let kept = &sq[..(n - n / 50).max(1)];
            let t85 = lms_scene::lms::MAX_INCIDENCE;
            Bin {
                n,
                robust: (kept.iter().sum::<f64>() / kept.len() as f64 / 6.0).sqrt(),
                rms: (sq.iter().sum::<f64>() / n as f64 / 6.0).sqrt(),
                sec2: sel
                    .iter()
                    .map(|t| 1.0 / t.0.min(t85).cos().powi(2))
                    .sum::<f64>()
                    / n as f64,
                dtan2: sel
                    .iter()
                    .map(|t| (t.1 * t.0.min(t85).tan()).powi(2))
                    .sum::<f64>()
                    / n as f64,
            }
        })
        .collect()
}

/// `(σ₀, κ, δ)` by non-negative least squares of relative errors (weights
/// `n / σ̂⁴`) on the bins below 85°: `σ̂² −
/// q²/12 = σ₀² + κ²·mean((d·tan θ)²) + (2/3)·δ²·mean(1/cos²θ)`, the last
/// term only for interleaved scans (`interleaved`): the two mirror turns
/// seen from poses δ apart (normal to the wall) put every other beam
/// `δ / cos θ` off.
pub fn fit(bins: &[Bin], q: f64, interleaved: bool) -> (f64, f64, f64) {
    let rows: Vec<([f64; 3], f64, f64)> = bins
        .iter()
        .take(BINS_DEG.len() - 1)
        .filter(|b| b.n >= 20)
        .map(|b| {
            let x = [
                1.0,
                b.dtan2,
                if interleaved { 2.0 / 3.0 * b.sec2 } else { 0.0 },
            ];
            // Relative errors: σ̂² spans three decades over the bins.
            let y2 = (b.robust * b.robust).max(q * q);
            (
                x,
                b.robust * b.robust - q * q / 12.0,
                b.n as f64 / (y2 * y2),
            )
        })
        .collect();
    let mut best: Option<(f64, [f64; 3])> = None;
    // Every subset of the terms; the best fit with no negative coefficient.
    for mask in 1u8..8 {
        let terms: Vec<usize> = (0..3).filter(|k| mask & (1 << k) != 0).collect();
        let Some(c) = solve(&rows, &terms) else {
            continue;
        };
        if c.iter().any(|v| *v < 0.0) {
            continue;
        }
        let sse: f64 = rows
            .iter()
            .map(|(x, y, w)| w * (y - (0..3).map(|k| c[k] * x[k]).sum::<f64>()).powi(2))
            .sum();
        if best.is_none_or(|(b, _)| sse < b) {
            best = Some((sse, c));
        }
    }
    best.map_or((f64::NAN, f64::NAN, f64::NAN), |(_, c)| {
        (c[0].sqrt(), c[1].sqrt(), c[2].sqrt())
    })
}

/// Weighted least squares of `rows` on the columns `terms` (others 0).
fn solve(rows: &[([f64; 3], f64, f64)], terms: &[usize]) -> Option<[f64; 3]> {
    let m = terms.len();
    if rows.len() < m {
        return None;
    }
    let mut a = vec![vec![0.0; m + 1]; m];
    for (x, y, w) in rows {
        for (i, &ti) in terms.iter().enumerate() {
            for (j, &tj) in terms.iter().enumerate() {
                a[i][j] += w * x[ti] * x[tj];
            }
            a[i][m] += w * x[ti] * y;
        }
    }
    // Gauss–Jordan with partial pivoting.
    for col in 0..m {
        let piv = (col..m).max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))?;
        a.swap(col, piv);
        if a[col][col].abs() < 1e-30 {
            return None;
        }
        let pivot_row = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / pivot_row[col];
                for (v, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                    *v -= f * p;
                }
            }
        }
    }
    let mut out = [0.0; 3];
    for (i, &t) in terms.iter().enumerate() {
        out[t] = a[i][m] / a[i][i];
    }
    Some(out)
}

/// The quantisation step of a log (m): 5 cm if nine in ten valid ranges
/// are whole multiples of it, else `unit`.
pub fn quantisation(scans: &[Scan], unit: f64) -> f64 {
    let (mut n, mut k) = (0usize, 0usize);
    for s in scans.iter().step_by(10) {
        for (b, &d) in s.frame.beams().iter().zip(s.frame.ranges()) {
            if b.is_valid() && d < 40.0 {
                n += 1;
                let v = f64::from(d) / 0.05;
                k += usize::from((v - v.round()).abs() < 1e-3);
            }
        }
    }
    if n > 0 && k as f64 >= 0.9 * n as f64 {
        0.05
    } else {
        unit
    }
}

/// One log's fit.
#[derive(Clone, Debug)]
pub struct LogFit {
    /// File name.
    pub name: String,
    /// Beams per frame.
    pub beams: usize,
    /// Quantisation step (m).
    pub q: f64,
    /// Fitted σ₀ (m).
    pub sigma0: f64,
    /// Fitted κ (rad).
    pub kappa: f64,
    /// Fitted interleave offset δ (m; 0.5° logs).
    pub delta: f64,
    /// Real bins.
    pub real: Vec<Bin>,
    /// Bins of the fitted model on synthetic scans.
    pub model: Vec<Bin>,
}

/// The fitted model of a log.
pub fn model_for(mode: LogMode, q: f64, sigma0: f64, kappa: f64) -> LmsModel {
    LmsModel {
        mode,
        step: q,
        sigma0: if sigma0.is_finite() { sigma0 } else { 0.005 },
        kappa: if kappa.is_finite() { kappa } else { 0.0 },
        ..LmsModel::lms200_cm()
    }
}

/// Synthetic triples of `model` at `bearings` (`scans` scenes), each scan
/// moving at √2·δ / turn time in a random direction (so the offset between
/// turns normal to a wall of random orientation has rms δ).
pub fn model_triples(
    model: &LmsModel,
    delta: f64,
    bearings: &Bearings,
    scans: usize,
) -> Vec<Triple> {
    use rand::Rng;
    let mut rng = lms_scene::seeded_rng(14);
    let mut out = Vec::new();
    for k in 0..scans {
        let scene = if k % 2 == 0 {
            Scene::random_room(&mut rng)
        } else {
            Scene::corridor()
        };
        let pose = if k % 2 == 0 {
            Pose::IDENTITY
        } else {
            Pose::new(0.3 * (k % 7) as f64, 0.0, 0.1 * (k % 5) as f64 - 0.2)
        };
        let truth = scene.cast_with_max_range(bearings, pose, 30.0);
        let dir: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let v = if delta.is_finite() {
            2f64.sqrt() * delta / model.turn_time
        } else {
            0.0
        };
        let m = model.moving([v * dir.cos(), v * dir.sin(), 0.0]);
        let values = m.scan(&scene, bearings, pose, &mut rng);
        out.extend(synthetic_triples(&truth, &values));
    }
    out
}

/// Fit every log of `logs`.
pub fn run(logs: &[std::path::PathBuf], model_scans: usize) -> Result<Vec<LogFit>> {
    let cfg = TruthConfig::default();
    let mut out = Vec::new();
    for path in logs {
        let log = carmen::read_log(path, UnitMode::Auto)?;
        let map = build_map(&log.scans, &cfg);
        let mut t = Vec::new();
        for scan in &log.scans {
            t.extend(triples(scan, &frame_truth(scan, &map, &cfg)));
        }
        let (unit, mode) = match log.unit {
            Unit::Millimetre => (0.001, LogMode::Mm32),
            _ => (0.01, LogMode::Cm80),
        };
        let q = quantisation(&log.scans, unit);
        let real = bins(&t);
        let beams = log.scans.first().map_or(0, |s| s.frame.len());
        let interleaved = beams >= 360;
        let (sigma0, kappa, delta) = fit(&real, q, interleaved);
        let delta = if interleaved { delta } else { 0.0 };
        let bearings = match beams {
            361 | 360 => Bearings::lms_180_half_deg(),
            _ => Bearings::lms_180_1deg(),
        };
        let model = bins(&model_triples(
            &model_for(mode, q, sigma0, kappa),
            delta,
            &bearings,
            model_scans,
        ));
        out.push(LogFit {
            name: path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            beams,
            q,
            sigma0,
            kappa,
            delta,
            real,
            model,
        });
    }
    Ok(out)
}

/// The Markdown section.
pub fn markdown(fits: &[LogFit]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## 6. Sensor model fitted to the real logs\n\n`lms_scene::LmsModel` \
         (`scene/src/lms.rs`) with `σ(θ, d)² = σ₀² + (κ·d·tan θ)²` and, in the 0.5° logs, \
         the two mirror turns δ apart (rms, normal to the wall), fitted per log to the \
         second differences of the residuals of beams on map-truth walls \
         (`lab/src/sensorfit.rs`). Each cell: trimmed σ̂ (mm; largest 2 % left out) of \
         the real log / of the fitted model on synthetic scans (full rms σ̂ in \
         brackets, which also sees the tails); `n` triples of the real log.\n"
    );
    let _ = writeln!(
        md,
        "| log | beams | q (mm) | σ₀ (mm) | κ (mrad) | δ (mm) |\n|:---|---:|---:|---:|---:|---:|"
    );
    for f in fits {
        let _ = writeln!(
            md,
            "| {} | {} | {:.0} | {:.1} | {:.2} | {:.1} |",
            f.name,
            f.beams,
            f.q * 1e3,
            f.sigma0 * 1e3,
            f.kappa * 1e3,
            f.delta * 1e3
        );
    }
    let mut head = String::from("\n| log |");
    let mut lo = 0.0;
    for hi in BINS_DEG {
        let _ = write!(head, " θ {lo:.0}–{hi:.0}° |");
        lo = hi;
    }
    let _ = writeln!(md, "{head}");
    let _ = writeln!(md, "|:---|{}", "---:|".repeat(BINS_DEG.len()));
    for f in fits {
        let cells: Vec<String> = f
            .real
            .iter()
            .zip(&f.model)
            .map(|(r, m)| {
                if r.n == 0 {
                    "—".to_string()
                } else {
                    format!(
                        "{:.1} / {:.1} ({:.1} / {:.1}), n {}",
                        r.robust * 1e3,
                        m.robust * 1e3,
                        r.rms * 1e3,
                        m.rms * 1e3,
                        r.n
                    )
                }
            })
            .collect();
        let _ = writeln!(md, "| {} | {} |", f.name, cells.join(" | "));
    }
    md
}

/// Write the section alone into `output/sensor-fit.md`.
pub fn run_standalone(
    data: &Path,
    output: &Path,
    model_scans: usize,
) -> Result<std::path::PathBuf> {
    let logs = crate::real::find_logs(data)?;
    std::fs::create_dir_all(output)?;
    let fits = run(&logs, model_scans)?;
    let path = output.join("sensor-fit.md");
    std::fs::write(&path, markdown(&fits))?;
    Ok(path)
}
