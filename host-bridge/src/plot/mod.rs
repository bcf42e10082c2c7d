//! `host-bridge plot`: figures of one frame, for people rather than parsers.
//!
//! Two figures per frame, drawn with `plotters` as SVG or PNG:
//!
//! * **scan** (paper Fig. 7–12): the frame in the sensor frame, **x forward
//!   drawn up, y left drawn to the left** (the view from above with the
//!   sensor looking up the page), one metre the same length on both axes.
//!   Raw points (grey dots), smoothed points (black dots), edge points (red
//!   stars), fitted lines between their endpoints (one colour each),
//!   corners (diamonds: green well-conditioned, magenta ill-conditioned)
//!   with their 2σ covariance ellipses — enlarged by a stated factor when
//!   they would be too small to see — and the sensor (triangle at the
//!   origin).
//! * **mahalanobis** (paper Fig. 10): `D` per window against the window's
//!   centre beam on a log axis, after each selected pass (default: 1 and the
//!   last), with the segmentation gate τ as a dashed line; invalid windows
//!   are left out (and windows with an invalid beam shaded).
//!
//! Text is laid out with `ab_glyph` from a TrueType font read at run time
//! ([`find_font`]: `$HOST_BRIDGE_FONT`, else DejaVu Sans or another system
//! font); nothing is linked against fontconfig or freetype. SVG text is
//! drawn by the viewer (`font-family="sans-serif"`).
//!
//! Colours are public constants so that tests can find the elements in the
//! SVG text: fitted lines are the only 2-point `<polyline>`s of the scan
//! figure; corners are 4-point `<polygon>`s (diamonds) in
//! [`WELL_CONDITIONED`] or [`ILL_CONDITIONED`]; edge stars are three
//! `<line>`s in [`EDGE`]. The legend shows one sample of each marker.

//!
//! # Layout (in the order of the data flow)
//!
//! * `args` — [`PlotArgs`] and its value types; `output` — the files
//!   ([`outputs`]).
//! * `frame` — [`FramePlot`]: one frame through the pipeline, `D` kept
//!   after the selected passes.
//! * `scan_figure` ([`draw_scan`]) and `d_figure` ([`draw_mahalanobis`]),
//!   on `geometry` (ellipses, scales, clipping), `style` (colours, markers,
//!   legend, title) and `font` ([`find_font`], [`ensure_font`]).
//! * This module — [`run`]: the frame, the figures, the files.

mod args;
mod d_figure;
mod font;
mod frame;
mod geometry;
mod output;
mod scan_figure;
mod style;

use std::path::Path;

use anyhow::{anyhow, bail, ensure, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

pub use args::{Figure, Format, PassList, PlotArgs};
pub use d_figure::draw_mahalanobis;
pub use font::{ensure_font, find_font, FONT_CANDIDATES};
pub use frame::{FramePlot, PassD, ScanDrawn};
pub use geometry::{ellipse, equal_scale, nice_scale};
pub use output::{outputs, Outputs};
pub use scan_figure::draw_scan;
pub use style::{
    EDGE, ELLIPSE_VERTICES, ILL_CONDITIONED, LINE_COLOURS, MAHALANOBIS_SIZE, PASS_COLOURS, RAW,
    SCAN_SIZE, SMOOTHED, TAU, WELL_CONDITIONED,
};

use crate::defaults;
use crate::input::InputFrame;
use crate::synthetic;

/// Render one figure to `path`.
fn render<T>(
    path: &Path,
    format: Format,
    size: (u32, u32),
    svg: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<T>,
    png: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<T>,
) -> Result<T> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the output directory {}", dir.display()))?;
    }
    // Fail early, with the path, if the file cannot be written.
    std::fs::File::create(path).with_context(|| format!("cannot write {}", path.display()))?;
    match format {
        Format::Svg => {
            let mut text = String::new();
            let out = {
                let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
                svg(&root)?
            };
            std::fs::write(path, text)
                .with_context(|| format!("cannot write {}", path.display()))?;
            Ok(out)
        }
        Format::Png => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            png(&root).with_context(|| format!("cannot write {}", path.display()))
        }
    }
}

/// The passes whose `D` is drawn: `--passes`, or 1 and the last.
fn selected_passes(args: &PlotArgs, iterations: u16) -> Result<Vec<u16>> {
    let passes = match &args.passes {
        Some(list) => list.0.clone(),
        None => {
            let mut v = vec![1, iterations];
            v.dedup();
            v
        }
    };
    if let Some(&p) = passes.iter().find(|&&p| p > iterations) {
        bail!(
            "--passes {}: pass {p} is beyond the {iterations} passes run (raise --iterations)",
            args.passes
                .as_ref()
                .map_or_else(String::new, ToString::to_string),
        );
    }
    Ok(passes)
}

/// Defaults per data of a log: parameters and a warning line.
type LogDefaults = Option<(lms_core::Params, Option<String>)>;

/// Frame `k` of the log or capture at `path` (streamed: reading stops at
/// frame `k`; the input is read once), a description for titles, and the
/// log's defaults per data ([`defaults::for_file`]).
fn log_frame(path: &Path, args: &PlotArgs, k: usize) -> Result<(String, InputFrame, LogDefaults)> {
    let options = crate::input::ReadOptions {
        unit: args.unit,
        keep_damaged: false,
    };
    let mut file = crate::input::open_topic(path, options, args.topic.name())?;
    let found = defaults::for_file(&file, &args.params)?;
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let source = match file.kind() {
        crate::input::Kind::Log { unit, .. } => format!("{name} ({unit} ranges)"),
        crate::input::Kind::Capture => format!("{name} (capture)"),
        crate::input::Kind::Bag { unit } => format!("{name} (ROS 2 bag, {unit} ranges)"),
    };
    for scan in file.by_ref() {
        let scan = scan?;
        if scan.index == k {
            let input = InputFrame {
                index: scan.index,
                frame: scan.frame,
                pose: scan.pose,
            };
            return Ok((source, input, found));
        }
    }
    file.warn_if_cut();
    let total = file.read();
    let (what, frames) = match file.kind() {
        crate::input::Kind::Log { .. } => ("log has", "FLASER frames"),
        crate::input::Kind::Capture => ("capture has", "scans"),
        crate::input::Kind::Bag { .. } => ("bag's topic has", "scans"),
    };
    bail!(
        "{}: --frame {k} is out of range: the {what} {total} {frames} (0..{total})",
        path.display()
    )
}

/// Frame `k` of the synthetic scene, and a description for titles.
fn scene_frame(args: &PlotArgs, k: usize) -> Result<(String, InputFrame)> {
    let sc = &args.scene;
    ensure!(
        k < sc.count,
        "--frame {k} is out of range: the synthetic scene has {} frames (0..{}; more with --count)",
        sc.count,
        sc.count
    );
    let input = synthetic::frames_iter(sc)?
        .nth(k)
        .transpose()?
        .ok_or_else(|| anyhow!("--frame {k} is out of range"))?;
    let source = format!(
        "synthetic {} (seed {}, noise {} m, dropout {})",
        sc.scene_name(),
        sc.seed,
        sc.noise_sigma,
        sc.dropout
    );
    Ok((source, input))
}

/// `host-bridge plot`.
pub fn run(args: &PlotArgs) -> Result<()> {
    let params = args.params.to_params()?;
    let passes = selected_passes(args, params.iterations)?;
    if let Some(s) = args.ellipse_scale {
        ensure!(
            s.is_finite() && s > 0.0,
            "--ellipse-scale must be a positive number"
        );
    }
    let outs = outputs(&args.output, args.format, args.figure, args.frame)?;
    let k = args.frame;
    let (source, input, found) = match &args.log {
        Some(path) => log_frame(path, args, k)?,
        None => scene_frame(args, k).map(|(s, i)| (s, i, None))?,
    };
    // Defaults per data for a CARMEN log (σ, max_range; flags override).
    let params = match &args.log {
        Some(_) => match found {
            Some((params, warning)) => {
                warning
                    .into_iter()
                    .for_each(|w| eprintln!("host-bridge plot: {w}"));
                params
            }
            None => params,
        },
        None => params,
    };
    ensure_font()?;
    let fp = FramePlot::compute(source, &input, &params, &passes)?;
    if let Some(path) = &outs.scan {
        let scale = args.ellipse_scale;
        let drawn = render(
            path,
            outs.format,
            SCAN_SIZE,
            |root| draw_scan(root, &fp, scale),
            |root| draw_scan(root, &fp, scale),
        )?;
        eprintln!(
            "host-bridge plot: wrote {} (frame {k}: {} lines, {} corners drawn, {} out of view, \
             {} edge points, ellipses ×{} well- and ×{} ill-conditioned, 1 m = {:.1} px)",
            path.display(),
            drawn.lines,
            drawn.corners,
            drawn.corners_out_of_view,
            drawn.edges,
            drawn.ellipse_scale_well,
            drawn.ellipse_scale_ill,
            1.0 / drawn.metres_per_pixel
        );
    }
    if let Some(path) = &outs.mahalanobis {
        render(
            path,
            outs.format,
            MAHALANOBIS_SIZE,
            |root| draw_mahalanobis(root, &fp),
            |root| draw_mahalanobis(root, &fp),
        )?;
        let list: Vec<String> = fp.passes.iter().map(|p| p.pass.to_string()).collect();
        eprintln!(
            "host-bridge plot: wrote {} (frame {k}: D after pass {})",
            path.display(),
            list.join(", ")
        );
    }
    Ok(())
}
