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

use std::ffi::OsStr;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::OnceLock;

use anyhow::{anyhow, bail, ensure, Context, Result};
use clap::{Args, ValueEnum};
use lms_core::{Extractor, Params};
use plotters::coord::Shift;
use plotters::element::{DashedPathElement, Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendCoord, DrawingErrorKind};

use crate::carmen::{self, UnitMode};
use crate::extract::{FrameRecord, InputFrame};
use crate::options::ParamArgs;
use crate::synthetic::{self, SceneArgs};

/// Raw scan points.
pub const RAW: RGBColor = RGBColor(0x9A, 0x9A, 0x9A);
/// Smoothed points.
pub const SMOOTHED: RGBColor = RGBColor(0x10, 0x10, 0x10);
/// Edge points (stars).
pub const EDGE: RGBColor = RGBColor(0xE4, 0x1A, 0x1C);
/// Well-conditioned corners and their ellipses.
pub const WELL_CONDITIONED: RGBColor = RGBColor(0x1B, 0x9E, 0x3A);
/// Ill-conditioned corners and their ellipses.
pub const ILL_CONDITIONED: RGBColor = RGBColor(0xD0, 0x00, 0xD0);
/// Fitted lines, one colour each, cycling (no red, green, magenta or grey).
pub const LINE_COLOURS: [RGBColor; 8] = [
    RGBColor(0x1F, 0x77, 0xB4),
    RGBColor(0xFF, 0x7F, 0x0E),
    RGBColor(0x94, 0x67, 0xBD),
    RGBColor(0x8C, 0x56, 0x4B),
    RGBColor(0x17, 0xBE, 0xCF),
    RGBColor(0xBC, 0xBD, 0x22),
    RGBColor(0x39, 0x3B, 0x79),
    RGBColor(0xE7, 0x96, 0x9C),
];
/// `D` curves, one colour per selected pass, cycling.
pub const PASS_COLOURS: [RGBColor; 6] = [
    RGBColor(0x1F, 0x77, 0xB4),
    RGBColor(0xFF, 0x7F, 0x0E),
    RGBColor(0x2C, 0xA0, 0x2C),
    RGBColor(0x94, 0x67, 0xBD),
    RGBColor(0x8C, 0x56, 0x4B),
    RGBColor(0x17, 0xBE, 0xCF),
];
/// The τ line of the `D` figure.
pub const TAU: RGBColor = RGBColor(0xE4, 0x1A, 0x1C);
const BAND: RGBColor = RGBColor(0xEC, 0xEC, 0xEC);
const GRID: RGBColor = RGBColor(0xE6, 0xE6, 0xE6);
const GRID_BOLD: RGBColor = RGBColor(0xC8, 0xC8, 0xC8);

/// Vertices of a covariance ellipse.
pub const ELLIPSE_VERTICES: usize = 64;
/// Size of the scan figure (px).
pub const SCAN_SIZE: (u32, u32) = (1600, 940);
/// Size of the `D` figure (px).
pub const MAHALANOBIS_SIZE: (u32, u32) = (1600, 720);
const TITLE_HEIGHT: u32 = 76;
const LEGEND_WIDTH: u32 = 360;
const FONT: &str = "sans-serif";

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Scalable vector graphics (text drawn by the viewer).
    Svg,
    /// Bitmap (text rendered here with the TTF font).
    Png,
}

impl Format {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Svg => "svg",
            Format::Png => "png",
        }
    }
}

/// Which figures to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Figure {
    /// Both figures.
    All,
    /// The scan with its features.
    Scan,
    /// D per window after the selected passes.
    Mahalanobis,
}

/// Range unit of a log's error codes (as for `extract`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum UnitArg {
    /// mm if any range has three decimals, else cm.
    Auto,
    /// Centimetre log.
    Cm,
    /// Millimetre log.
    Mm,
}

/// A comma-separated list of passes, e.g. `1,30`: ascending, unique, ≥ 1.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassList(pub Vec<u16>);

impl FromStr for PassList {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut passes = Vec::new();
        for part in s.split(',') {
            let p: u16 = part.trim().parse().map_err(|_| {
                format!(
                    "bad passes list {s:?}: expected passes >= 1 separated by commas, e.g. 1,30"
                )
            })?;
            if p == 0 {
                return Err(format!("bad passes list {s:?}: passes count from 1"));
            }
            passes.push(p);
        }
        passes.sort_unstable();
        passes.dedup();
        Ok(PassList(passes))
    }
}

impl fmt::Display for PassList {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self.0.iter().map(u16::to_string).collect();
        f.write_str(&parts.join(","))
    }
}

/// Options of `host-bridge plot`.
#[derive(Args, Clone, Debug)]
pub struct PlotArgs {
    /// CARMEN log (gzip or plain); without it, a synthetic scene is used
    pub log: Option<PathBuf>,
    /// Synthetic scene options (used without LOG).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Range unit of the log's error codes: auto = mm if any value has 3 decimals
    #[arg(long, value_enum, default_value_t = UnitArg::Auto, requires = "log")]
    pub unit: UnitArg,
    /// Pipeline parameters, as for `extract`.
    #[command(flatten)]
    pub params: ParamArgs,
    /// Frame to plot (index of the FLASER line, from 0; synthetic: 0..count)
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub frame: usize,
    /// Passes whose D is plotted, comma-separated [default: 1 and the last]
    #[arg(long, value_name = "P,P,..")]
    pub passes: Option<PassList>,
    /// Output directory (created if missing; files frame-K-scan.EXT and
    /// frame-K-mahalanobis.EXT), or a file name ending in .svg or .png
    #[arg(long, short, value_name = "DIR|FILE", default_value = ".")]
    pub output: PathBuf,
    /// Output format [default: svg, or the extension of a FILE output]
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Figures to draw
    #[arg(long, value_enum, default_value_t = Figure::All)]
    pub figure: Figure,
    /// Enlarge the corner ellipses by this factor [default: chosen so that
    /// they are visible; the factor is shown in the legend]
    #[arg(long, value_name = "F")]
    pub ellipse_scale: Option<f64>,
}

/// `D` of every window after one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct PassD {
    /// Pass number, from 1.
    pub pass: u16,
    /// `D` per window (`n − 2` entries, `+inf` where invalid).
    pub d: Vec<f32>,
}

/// One frame run through the pipeline, with everything the figures need.
#[derive(Clone, Debug)]
pub struct FramePlot {
    /// What the frame came from (for titles).
    pub source: String,
    /// Parameters of the run.
    pub params: Params,
    /// The record `extract` would write for the frame.
    pub record: FrameRecord,
    /// Bearing of every beam (rad, 0 = forward, positive to the left).
    pub bearings: Vec<f32>,
    /// `D` after the selected passes, ascending.
    pub passes: Vec<PassD>,
}

impl FramePlot {
    /// Run the extractor on `input`, keeping `D` after each pass in `passes`
    /// (all must be in `1..=params.iterations`).
    pub fn compute(
        source: String,
        input: &InputFrame,
        params: &Params,
        passes: &[u16],
    ) -> Result<Self> {
        params
            .validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        ensure!(!passes.is_empty(), "no pass selected for the D figure");
        if let Some(&p) = passes.iter().find(|&&p| p == 0 || p > params.iterations) {
            bail!(
                "--passes: pass {p} is not run (passes are 1..={}; set --iterations to run more)",
                params.iterations
            );
        }
        let mut ex = Extractor::new();
        let mut captured = Vec::with_capacity(passes.len());
        let valid = params
            .validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        ex.run_observed(&input.frame, &valid, |pass, d, _| {
            if passes.contains(&pass) {
                captured.push(PassD {
                    pass,
                    d: d.to_vec(),
                });
            }
        });
        let mut record = FrameRecord::from_run(input.index, &input.frame, &ex);
        record.pose = input.pose;
        let g = input.frame.geometry();
        Ok(FramePlot {
            source,
            params: *params,
            record,
            bearings: (0..input.frame.len()).map(|j| g.bearing(j)).collect(),
            passes: captured,
        })
    }

    fn point(&self, j: usize, r: f32) -> (f64, f64) {
        let phi = f64::from(self.bearings[j]);
        let r = f64::from(r);
        (r * phi.cos(), r * phi.sin())
    }

    /// Valid raw points `(x, y)` (m).
    pub fn raw_points(&self) -> Vec<(f64, f64)> {
        self.record
            .ranges
            .iter()
            .enumerate()
            .filter_map(|(j, r)| r.map(|r| self.point(j, r)))
            .collect()
    }

    /// Smoothed points `(x, y)` of valid beams (m).
    pub fn smoothed_points(&self) -> Vec<(f64, f64)> {
        self.record
            .smoothed
            .iter()
            .enumerate()
            .filter_map(|(j, r)| r.map(|r| self.point(j, r)))
            .collect()
    }

    fn params_text(&self) -> String {
        let p = &self.params;
        format!(
            "passes {}, q = {} m², τ = {}, σ = {} m, min points {}, max χ² {}",
            p.iterations, p.q, p.tau, p.sigma, p.min_points, p.max_chi2
        )
    }
}

/// What the scan figure drew.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScanDrawn {
    /// Fitted lines drawn.
    pub lines: usize,
    /// Corners drawn (inside the view).
    pub corners: usize,
    /// Corners outside the view (not drawn).
    pub corners_out_of_view: usize,
    /// Edge points drawn.
    pub edges: usize,
    /// Factor the 2σ ellipses of well-conditioned corners are enlarged by.
    pub ellipse_scale_well: f64,
    /// Factor the 2σ ellipses of ill-conditioned corners are enlarged by.
    pub ellipse_scale_ill: f64,
    /// Metres per pixel, the same on both axes.
    pub metres_per_pixel: f64,
}

// ---------------------------------------------------------------- fonts --

/// Where a TTF font for text layout is looked for, after `$HOST_BRIDGE_FONT`.
pub const FONT_CANDIDATES: [&str; 8] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// The TTF font to lay out text with: `$HOST_BRIDGE_FONT`, else the first of
/// [`FONT_CANDIDATES`] that exists, else the first `*.ttf` under
/// `/usr/share/fonts`.
pub fn find_font() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("HOST_BRIDGE_FONT") {
        return Some(PathBuf::from(p));
    }
    if let Some(p) = FONT_CANDIDATES.iter().map(Path::new).find(|p| p.is_file()) {
        return Some(p.to_path_buf());
    }
    first_ttf(Path::new("/usr/share/fonts"), 4)
}

fn first_ttf(dir: &Path, depth: u32) -> Option<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in &entries {
        if p.is_file()
            && p.extension()
                .and_then(OsStr::to_str)
                .is_some_and(|e| e.eq_ignore_ascii_case("ttf"))
        {
            return Some(p.clone());
        }
    }
    if depth == 0 {
        return None;
    }
    entries
        .iter()
        .filter(|p| p.is_dir())
        .find_map(|p| first_ttf(p, depth - 1))
}

/// Register the font of [`find_font`] with plotters, once per process.
pub fn ensure_font() -> Result<()> {
    static FONT_STATE: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let state = FONT_STATE.get_or_init(|| {
        let path = find_font().ok_or_else(|| {
            format!(
                "no TrueType font found for the plot text (looked at $HOST_BRIDGE_FONT, {} and \
                 /usr/share/fonts); install one (Debian: fonts-dejavu-core) or set \
                 HOST_BRIDGE_FONT=/path/to/font.ttf",
                FONT_CANDIDATES[0]
            )
        })?;
        let bytes = std::fs::read(&path)
            .map_err(|e| format!("cannot read the font {}: {e}", path.display()))?;
        // plotters keeps the font for the whole process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font(FONT, FontStyle::Normal, bytes)
            .map_err(|_| format!("{} is not a usable TrueType font", path.display()))?;
        if let Some(bold) = bold_sibling(&path) {
            if let Ok(b) = std::fs::read(bold) {
                let b: &'static [u8] = Box::leak(b.into_boxed_slice());
                let _ = plotters::style::register_font(FONT, FontStyle::Bold, b);
            }
        }
        Ok(path)
    });
    state.as_ref().map(|_| ()).map_err(|e| anyhow!("{e}"))
}

fn bold_sibling(path: &Path) -> Option<PathBuf> {
    let stem = path.file_stem()?.to_str()?;
    let ext = path.extension()?.to_str()?;
    let bold = stem
        .strip_suffix("-Regular")
        .map_or_else(|| format!("{stem}-Bold"), |s| format!("{s}-Bold"));
    let p = path.with_file_name(format!("{bold}.{ext}"));
    p.is_file().then_some(p)
}

// ---------------------------------------------------------------- maths --

/// The 2σ ellipse of covariance `cov` around `(x, y)`, enlarged `scale`
/// times, as [`ELLIPSE_VERTICES`] points. `None` if `cov` is not a finite
/// positive semi-definite matrix.
pub fn ellipse(x: f64, y: f64, cov: [[f32; 2]; 2], scale: f64) -> Option<Vec<(f64, f64)>> {
    let (a, b, c) = (
        f64::from(cov[0][0]),
        f64::from(cov[0][1]),
        f64::from(cov[1][1]),
    );
    let (l1, l2, theta) = eigen_sym2(a, b, c)?;
    let (s1, s2) = (2.0 * scale * l1.sqrt(), 2.0 * scale * l2.sqrt());
    let (ct, st) = (theta.cos(), theta.sin());
    Some(
        (0..ELLIPSE_VERTICES)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / ELLIPSE_VERTICES as f64;
                let (u, v) = (s1 * t.cos(), s2 * t.sin());
                (x + ct * u - st * v, y + st * u + ct * v)
            })
            .collect(),
    )
}

/// Eigenvalues (larger first, clamped at 0) and the angle of the first
/// eigenvector of `[[a, b], [b, c]]`.
fn eigen_sym2(a: f64, b: f64, c: f64) -> Option<(f64, f64, f64)> {
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    let mean = 0.5 * (a + c);
    let diff = 0.5 * (a - c);
    let rad = diff.hypot(b);
    let (l1, l2) = (mean + rad, mean - rad);
    if l1 < 0.0 {
        return None;
    }
    Some((l1, l2.max(0.0), 0.5 * (2.0 * b).atan2(a - c)))
}

/// Largest 2σ semi-axis (m) of a covariance.
fn semi_major(cov: [[f32; 2]; 2]) -> Option<f64> {
    let (l1, _, _) = eigen_sym2(
        f64::from(cov[0][0]),
        f64::from(cov[0][1]),
        f64::from(cov[1][1]),
    )?;
    Some(2.0 * l1.sqrt())
}

/// An ellipse enlargement from 1, 2, 5 × 10^k that makes a typical semi-axis
/// of `median_px` pixels at least `target_px` long (1 if it already is).
pub fn nice_scale(median_px: f64, target_px: f64) -> f64 {
    if median_px.is_nan() || median_px <= 0.0 || median_px >= target_px {
        return 1.0;
    }
    let need = target_px / median_px;
    let mut decade = 1.0;
    loop {
        for m in [1.0, 2.0, 5.0] {
            let s = m * decade;
            if s >= need {
                return s;
            }
        }
        decade *= 10.0;
        if decade > 1e9 {
            return decade;
        }
    }
}

/// Ranges `(h0..h1, v0..v1)` with the same metres per pixel on both axes,
/// holding the box `[h_min, h_max] × [v_min, v_max]` centred, for a plotting
/// area of `w × h` pixels. Returns the ranges and the metres per pixel.
pub fn equal_scale(
    (h_min, h_max): (f64, f64),
    (v_min, v_max): (f64, f64),
    (w, h): (u32, u32),
) -> ((f64, f64), (f64, f64), f64) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let span_h = (h_max - h_min).max(1e-3);
    let span_v = (v_max - v_min).max(1e-3);
    let mpp = (span_h / w).max(span_v / h);
    let (ch, cv) = (0.5 * (h_min + h_max), 0.5 * (v_min + v_max));
    (
        (ch - 0.5 * mpp * w, ch + 0.5 * mpp * w),
        (cv - 0.5 * mpp * h, cv + 0.5 * mpp * h),
        mpp,
    )
}

/// Clip a polygon to the rectangle `[h0, h1] × [v0, v1]` (Sutherland–Hodgman).
fn clip_polygon(
    poly: &[(f64, f64)],
    (h0, h1): (f64, f64),
    (v0, v1): (f64, f64),
) -> Vec<(f64, f64)> {
    type Edge = (fn(&(f64, f64), f64) -> bool, usize, f64);
    let edges: [Edge; 4] = [
        (|p, e| p.0 >= e, 0, h0),
        (|p, e| p.0 <= e, 0, h1),
        (|p, e| p.1 >= e, 1, v0),
        (|p, e| p.1 <= e, 1, v1),
    ];
    let mut out = poly.to_vec();
    for (inside, axis, e) in edges {
        let input = std::mem::take(&mut out);
        let Some(&last) = input.last() else {
            return out;
        };
        let mut prev = last;
        for &p in &input {
            let cross = |a: (f64, f64), b: (f64, f64)| {
                let (ca, cb) = if axis == 0 { (a.0, b.0) } else { (a.1, b.1) };
                let t = (e - ca) / (cb - ca);
                (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
            };
            match (inside(&p, e), inside(&prev, e)) {
                (true, true) => out.push(p),
                (true, false) => {
                    out.push(cross(prev, p));
                    out.push(p);
                }
                (false, true) => out.push(cross(prev, p)),
                (false, false) => {}
            }
            prev = p;
        }
    }
    out
}

// ------------------------------------------------------------- elements --

/// A six-armed star marker (three `draw_line`s), the paper's edge points.
struct Star<C> {
    at: C,
    size: i32,
    style: ShapeStyle,
}

impl<'a, C: 'a> PointCollection<'a, C> for &'a Star<C> {
    type Point = &'a C;
    type IntoIter = std::iter::Once<&'a C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Star<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut points: I,
        backend: &mut DB,
        _: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        if let Some((x, y)) = points.next() {
            let s = self.size;
            let (dx, dy) = (s / 2, (s * 7 + 4) / 8);
            backend.draw_line((x - s, y), (x + s, y), &self.style)?;
            backend.draw_line((x - dx, y - dy), (x + dx, y + dy), &self.style)?;
            backend.draw_line((x - dx, y + dy), (x + dx, y - dy), &self.style)?;
        }
        Ok(())
    }
}

fn diamond(size: i32) -> Vec<(i32, i32)> {
    vec![(0, -size), (size, 0), (0, size), (-size, 0)]
}

fn sensor_triangle(size: i32) -> Vec<(i32, i32)> {
    // Pointing up the page: forward.
    vec![
        (0, -size),
        (size * 3 / 4, size / 2),
        (-size * 3 / 4, size / 2),
    ]
}

fn draw_err<E: fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("cannot draw the figure: {e}")
}

fn text_style(size: f64, colour: RGBColor, style: FontStyle) -> TextStyle<'static> {
    (FONT, size)
        .into_font()
        .style(style)
        .color(&colour)
        .pos(Pos::new(HPos::Left, VPos::Center))
}

/// A legend column on `area`: one row per entry, a sample drawn by the
/// closure at the row's sample centre, then the text.
struct Legend<'a, DB: DrawingBackend> {
    area: &'a DrawingArea<DB, Shift>,
    y: i32,
}

impl<DB: DrawingBackend> Legend<'_, DB>
where
    DB::ErrorType: 'static,
{
    const ROW: i32 = 30;
    const SAMPLE_X: i32 = 28;
    const TEXT_X: i32 = 56;

    fn heading(&mut self, text: &str) -> Result<()> {
        self.area
            .draw(&Text::new(
                text.to_string(),
                (12, self.y),
                text_style(19.0, BLACK, FontStyle::Bold),
            ))
            .map_err(draw_err)?;
        self.y += Self::ROW;
        Ok(())
    }

    fn note(&mut self, text: &str) -> Result<()> {
        self.area
            .draw(&Text::new(
                text.to_string(),
                (12, self.y),
                text_style(15.0, RGBColor(0x40, 0x40, 0x40), FontStyle::Normal),
            ))
            .map_err(draw_err)?;
        self.y += Self::ROW - 8;
        Ok(())
    }

    fn entry<F>(&mut self, text: &str, sample: F) -> Result<()>
    where
        F: FnOnce(&DrawingArea<DB, Shift>, (i32, i32)) -> Result<()>,
    {
        sample(self.area, (Self::SAMPLE_X, self.y))?;
        self.area
            .draw(&Text::new(
                text.to_string(),
                (Self::TEXT_X, self.y),
                text_style(17.0, BLACK, FontStyle::Normal),
            ))
            .map_err(draw_err)?;
        self.y += Self::ROW;
        Ok(())
    }
}

fn title<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, line1: &str, line2: &str) -> Result<()>
where
    DB::ErrorType: 'static,
{
    area.draw(&Text::new(
        line1.to_string(),
        (20, 24),
        text_style(24.0, BLACK, FontStyle::Bold),
    ))
    .map_err(draw_err)?;
    area.draw(&Text::new(
        line2.to_string(),
        (20, 56),
        text_style(17.0, RGBColor(0x30, 0x30, 0x30), FontStyle::Normal),
    ))
    .map_err(draw_err)?;
    Ok(())
}

fn fmt_metres(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

// ----------------------------------------------------------- scan figure --

fn scan_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(16).x_label_area_size(54).y_label_area_size(70);
    b
}

/// Draw the scan figure on `root` (any backend, [`SCAN_SIZE`] recommended).
pub fn draw_scan<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fp: &FramePlot,
    ellipse_scale: Option<f64>,
) -> Result<ScanDrawn>
where
    DB::ErrorType: 'static,
{
    ensure_font()?;
    let rec = &fp.record;
    root.fill(&WHITE).map_err(draw_err)?;
    let (w, _) = root.dim_in_pixel();
    let (title_area, body) = root.split_vertically(TITLE_HEIGHT);
    let (chart_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);

    // Chart coordinates: horizontal u = −y (left of the sensor is left on
    // the page), vertical v = x (forward is up).
    let to_uv = |(x, y): (f64, f64)| (-y, x);
    let raw: Vec<(f64, f64)> = fp.raw_points().into_iter().map(to_uv).collect();
    let smoothed: Vec<(f64, f64)> = fp.smoothed_points().into_iter().map(to_uv).collect();
    let mut extent: Vec<(f64, f64)> = raw.clone();
    extent.extend(&smoothed);
    extent.push((0.0, 0.0));
    for l in &rec.lines {
        for e in l.endpoints {
            extent.push(to_uv((f64::from(e[0]), f64::from(e[1]))));
        }
    }
    let fold = |f: fn(&(f64, f64)) -> f64| {
        extent
            .iter()
            .map(f)
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let (mut u_lim, mut v_lim) = (fold(|p| p.0), fold(|p| p.1));
    let pad = 0.04 * (u_lim.1 - u_lim.0).max(v_lim.1 - v_lim.0).max(0.5);
    u_lim = (u_lim.0 - pad, u_lim.1 + pad);
    v_lim = (v_lim.0 - pad, v_lim.1 + pad);

    // Build once to learn the plotting area's size, then with equal scale.
    let probe = scan_builder(&chart_area)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(draw_err)?;
    let plot_px = probe.plotting_area().dim_in_pixel();
    drop(probe);
    let (u_range, v_range, mpp) = equal_scale(u_lim, v_lim, plot_px);
    let mut chart = scan_builder(&chart_area)
        .build_cartesian_2d(u_range.0..u_range.1, v_range.0..v_range.1)
        .map_err(draw_err)?;
    let neg = |u: &f64| fmt_metres(-*u);
    let plain = |v: &f64| fmt_metres(*v);
    chart
        .configure_mesh()
        .x_desc("y (m), positive to the left")
        .y_desc("x (m), forward")
        .x_label_formatter(&neg)
        .y_label_formatter(&plain)
        .x_labels(14)
        .y_labels(10)
        .bold_line_style(GRID_BOLD)
        .light_line_style(GRID)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(draw_err)?;

    let in_view = |(u, v): (f64, f64)| {
        (u_range.0..=u_range.1).contains(&u) && (v_range.0..=v_range.1).contains(&v)
    };

    // Raw, then smoothed points.
    chart
        .draw_series(raw.iter().map(|&p| Circle::new(p, 2, RAW.filled())))
        .map_err(draw_err)?;
    chart
        .draw_series(
            smoothed
                .iter()
                .map(|&p| Circle::new(p, 1, SMOOTHED.filled())),
        )
        .map_err(draw_err)?;

    // Fitted lines over the points, translucent so that the scatter shows.
    for (i, l) in rec.lines.iter().enumerate() {
        let colour = LINE_COLOURS[i % LINE_COLOURS.len()];
        let a = to_uv((f64::from(l.endpoints[0][0]), f64::from(l.endpoints[0][1])));
        let b = to_uv((f64::from(l.endpoints[1][0]), f64::from(l.endpoints[1][1])));
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![a, b],
                colour.mix(0.75).stroke_width(4),
            )))
            .map_err(draw_err)?;
    }

    // Edge points on the smoothed scan (where D was computed).
    let edges: Vec<(f64, f64)> = rec
        .edges
        .iter()
        .filter_map(|&j| {
            let j = usize::from(j);
            rec.smoothed
                .get(j)
                .copied()
                .flatten()
                .or(rec.ranges.get(j).copied().flatten())
                .map(|r| to_uv(fp.point(j, r)))
        })
        .collect();
    chart
        .draw_series(edges.iter().map(|&p| Star {
            at: p,
            size: 5,
            style: EDGE.stroke_width(2),
        }))
        .map_err(draw_err)?;

    // Corners and their ellipses. Each class gets its own enlargement (the
    // ill-conditioned ones are long along the lines and would fill the view).
    let view_px = |m: f64| m / mpp;
    let class_scale = |well: bool| {
        ellipse_scale.unwrap_or_else(|| {
            let mut majors: Vec<f64> = rec
                .corners
                .iter()
                .filter(|c| c.well_conditioned == well)
                .filter_map(|c| semi_major(c.cov))
                .collect();
            majors.sort_by(f64::total_cmp);
            majors
                .get(majors.len() / 2)
                .map_or(1.0, |&m| nice_scale(view_px(m), 12.0))
        })
    };
    let (scale_well, scale_ill) = (class_scale(true), class_scale(false));
    let mut drawn = ScanDrawn {
        lines: rec.lines.len(),
        edges: edges.len(),
        ellipse_scale_well: scale_well,
        ellipse_scale_ill: scale_ill,
        metres_per_pixel: mpp,
        ..ScanDrawn::default()
    };
    for c in &rec.corners {
        let p = to_uv((f64::from(c.x), f64::from(c.y)));
        if !in_view(p) {
            drawn.corners_out_of_view += 1;
            continue;
        }
        drawn.corners += 1;
        let scale = if c.well_conditioned {
            scale_well
        } else {
            scale_ill
        };
        let colour = if c.well_conditioned {
            WELL_CONDITIONED
        } else {
            ILL_CONDITIONED
        };
        if let Some(e) = ellipse(f64::from(c.x), f64::from(c.y), c.cov, scale) {
            let e: Vec<(f64, f64)> = e.into_iter().map(to_uv).collect();
            let clipped = clip_polygon(&e, u_range, v_range);
            if clipped.len() >= 3 {
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        clipped.clone(),
                        colour.mix(0.15).filled(),
                    )))
                    .map_err(draw_err)?;
                let mut outline = clipped;
                outline.push(outline[0]);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        outline,
                        colour.stroke_width(2),
                    )))
                    .map_err(draw_err)?;
            }
        }
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(p) + Polygon::new(diamond(7), colour.filled()),
            ))
            .map_err(draw_err)?;
    }

    // The sensor.
    chart
        .draw_series(std::iter::once(
            EmptyElement::at((0.0, 0.0)) + Polygon::new(sensor_triangle(11), BLACK.filled()),
        ))
        .map_err(draw_err)?;

    // Title.
    let wc = rec.corners.iter().filter(|c| c.well_conditioned).count();
    let line1 = format!(
        "Frame {} — {} lines, {} corners ({} well-conditioned), {} edge points, {} segments",
        rec.frame,
        rec.lines.len(),
        rec.corners.len(),
        wc,
        rec.edges.len(),
        rec.segments.len()
    );
    let line2 = format!("{} · {}", fp.source, fp.params_text());
    title(&title_area, &line1, &line2)?;

    // Legend.
    let mut lg = Legend {
        area: &legend_area,
        y: 40,
    };
    lg.heading("Legend")?;
    lg.entry(
        &format!("raw points ({} valid beams)", rec.stats.valid_beams),
        |a, c| a.draw(&Circle::new(c, 3, RAW.filled())).map_err(draw_err),
    )?;
    lg.entry(
        &format!("smoothed points (pass {})", fp.params.iterations),
        |a, c| {
            a.draw(&Circle::new(c, 2, SMOOTHED.filled()))
                .map_err(draw_err)
        },
    )?;
    lg.entry(&format!("edge points ({})", rec.edges.len()), |a, c| {
        a.draw(&Star {
            at: c,
            size: 5,
            style: EDGE.stroke_width(2),
        })
        .map_err(draw_err)
    })?;
    lg.entry(
        &format!("fitted lines ({})", rec.lines.len()),
        |a, (x, y)| {
            for (k, colour) in LINE_COLOURS.iter().take(3).enumerate() {
                let x0 = x - 18 + 12 * k as i32;
                a.draw(&Rectangle::new(
                    [(x0, y - 2), (x0 + 11, y + 2)],
                    colour.filled(),
                ))
                .map_err(draw_err)?;
            }
            Ok(())
        },
    )?;
    lg.entry(&format!("corner, well-conditioned ({wc})"), |a, c| {
        a.draw(&(EmptyElement::at(c) + Polygon::new(diamond(7), WELL_CONDITIONED.filled())))
            .map_err(draw_err)
    })?;
    lg.entry(
        &format!(
            "corner, ill-conditioned < {}° ({})",
            fp.params.min_corner_angle_deg,
            rec.corners.len() - wc
        ),
        |a, c| {
            a.draw(&(EmptyElement::at(c) + Polygon::new(diamond(7), ILL_CONDITIONED.filled())))
                .map_err(draw_err)
        },
    )?;
    let times = |k: f64| {
        if k == 1.0 {
            "true size".to_string()
        } else {
            format!("×{k}")
        }
    };
    lg.entry(&format!("2σ ellipse, {}", times(scale_well)), |a, c| {
        a.draw(&Circle::new(c, 9, WELL_CONDITIONED.stroke_width(2)))
            .map_err(draw_err)
    })?;
    lg.entry(&format!("2σ ellipse, {}", times(scale_ill)), |a, c| {
        a.draw(&Circle::new(c, 9, ILL_CONDITIONED.stroke_width(2)))
            .map_err(draw_err)
    })?;
    lg.entry("sensor (origin), facing up", |a, c| {
        a.draw(&(EmptyElement::at(c) + Polygon::new(sensor_triangle(11), BLACK.filled())))
            .map_err(draw_err)
    })?;
    lg.y += 10;
    lg.heading("View")?;
    lg.note("x forward is up, y left is left;")?;
    lg.note(&format!(
        "equal scale: 1 m = {:.1} px on both axes",
        1.0 / mpp
    ))?;
    for (k, what) in [(scale_well, "well"), (scale_ill, "ill")] {
        if k != 1.0 {
            lg.note(&format!("{what}-conditioned ellipses ×{k} (enlarged)"))?;
        }
    }
    if drawn.corners_out_of_view > 0 {
        lg.note(&format!(
            "{} corner(s) outside the view, not drawn",
            drawn.corners_out_of_view
        ))?;
    }
    lg.y += 10;
    lg.heading("Dropped by the pipeline")?;
    let s = &rec.stats;
    lg.note(&format!(
        "short segments {}, χ² rejects {}",
        s.short_segments, s.rejected_chi2
    ))?;
    lg.note(&format!(
        "short lines {}, degenerate fits {}",
        s.rejected_short, s.degenerate_fits
    ))?;
    lg.note(&format!(
        "merges {}, invalid windows {}",
        s.merges, s.invalid_windows
    ))?;
    root.present().map_err(draw_err)?;
    Ok(drawn)
}

// ---------------------------------------------------- mahalanobis figure --

/// Contiguous runs of finite, positive-or-zero `D`, as `(first window, values)`.
fn finite_runs(d: &[f32]) -> Vec<(usize, Vec<f64>)> {
    let mut runs: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut open = false;
    for (i, &v) in d.iter().enumerate() {
        if v.is_finite() {
            if open {
                if let Some(r) = runs.last_mut() {
                    r.1.push(f64::from(v));
                }
            } else {
                runs.push((i, vec![f64::from(v)]));
                open = true;
            }
        } else {
            open = false;
        }
    }
    runs
}

/// Draw the `D` figure on `root` (any backend, [`MAHALANOBIS_SIZE`] recommended).
pub fn draw_mahalanobis<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fp: &FramePlot,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    ensure_font()?;
    let rec = &fp.record;
    let tau = f64::from(fp.params.tau);
    root.fill(&WHITE).map_err(draw_err)?;
    let (w, _) = root.dim_in_pixel();
    let (title_area, body) = root.split_vertically(TITLE_HEIGHT);
    let (chart_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);

    let finite: Vec<f64> = fp
        .passes
        .iter()
        .flat_map(|p| p.d.iter())
        .filter(|d| d.is_finite())
        .map(|&d| f64::from(d))
        .collect();
    let min_pos = finite
        .iter()
        .copied()
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let max = finite.iter().copied().fold(tau, f64::max);
    let lo_exp = if min_pos.is_finite() {
        min_pos.log10().floor().max(-12.0)
    } else {
        (tau.log10() - 3.0).floor()
    };
    let lo = 10f64.powf(lo_exp);
    let hi = 10f64.powf(max.log10().ceil().max(lo_exp + 1.0));
    let windows = rec.n.saturating_sub(2);
    let x_max = rec.n.saturating_sub(1) as f64;

    let mut chart = ChartBuilder::on(&chart_area)
        .margin(16)
        .x_label_area_size(54)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..x_max, (lo..hi).log_scale())
        .map_err(draw_err)?;
    let beam = |v: &f64| format!("{v:.0}");
    let power = |v: &f64| {
        let e = v.log10();
        if (e - e.round()).abs() < 1e-6 {
            format!("1e{}", e.round() as i64)
        } else {
            format!("{v:.1e}")
        }
    };
    chart
        .configure_mesh()
        .x_desc("beam index (centre of the window of 3 beams)")
        .y_desc("D (log scale)")
        .x_label_formatter(&beam)
        .y_label_formatter(&power)
        .x_labels(16)
        .bold_line_style(GRID_BOLD)
        .light_line_style(GRID)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(draw_err)?;

    // Windows with an invalid beam: shaded bands.
    let invalid_beam_window: Vec<bool> = (0..windows)
        .map(|i| rec.ranges[i..i + 3].iter().any(Option::is_none))
        .collect();
    let mut i = 0;
    let mut invalid_count = 0;
    while i < windows {
        if invalid_beam_window[i] {
            let start = i;
            while i < windows && invalid_beam_window[i] {
                i += 1;
            }
            invalid_count += i - start;
            let (a, b) = (start as f64 + 0.5, i as f64 + 0.5);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(a, lo), (b, hi)],
                    BAND.filled(),
                )))
                .map_err(draw_err)?;
        } else {
            i += 1;
        }
    }

    // One curve per selected pass; invalid windows break it.
    // The last pass first and thick, earlier ones thin on top of it.
    for (k, p) in fp.passes.iter().enumerate().rev() {
        let colour = PASS_COLOURS[k % PASS_COLOURS.len()];
        let width = if k + 1 == fp.passes.len() { 3 } else { 1 };
        for (first, values) in finite_runs(&p.d) {
            let pts: Vec<(f64, f64)> = values
                .iter()
                .enumerate()
                .map(|(o, &d)| ((first + o + 1) as f64, d.max(lo)))
                .collect();
            if pts.len() == 1 {
                chart
                    .draw_series(std::iter::once(Circle::new(pts[0], 2, colour.filled())))
                    .map_err(draw_err)?;
            } else {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        pts,
                        colour.stroke_width(width),
                    )))
                    .map_err(draw_err)?;
            }
        }
    }

    // τ.
    chart
        .draw_series(std::iter::once(DashedPathElement::new(
            vec![(0.0, tau), (x_max, tau)],
            12,
            7,
            TAU.stroke_width(2),
        )))
        .map_err(draw_err)?;

    let passes: Vec<String> = fp.passes.iter().map(|p| p.pass.to_string()).collect();
    let line1 = format!(
        "Frame {} — Mahalanobis distance D per window after pass {} (log scale), τ = {}",
        rec.frame,
        passes.join(" and "),
        fp.params.tau
    );
    let line2 = format!("{} · {}", fp.source, fp.params_text());
    title(&title_area, &line1, &line2)?;

    let mut lg = Legend {
        area: &legend_area,
        y: 40,
    };
    lg.heading("Legend")?;
    for (k, p) in fp.passes.iter().enumerate() {
        let colour = PASS_COLOURS[k % PASS_COLOURS.len()];
        let breaks =
            p.d.iter()
                .filter(|d| d.is_finite() && f64::from(**d) >= tau)
                .count();
        lg.entry(
            &format!("after pass {} ({breaks} windows ≥ τ)", p.pass),
            |a, (x, y)| {
                a.draw(&Rectangle::new(
                    [(x - 16, y - 2), (x + 16, y + 2)],
                    colour.filled(),
                ))
                .map_err(draw_err)
            },
        )?;
    }
    lg.entry(
        &format!("τ = {} (segmentation gate)", fp.params.tau),
        |a, (x, y)| {
            for k in 0..3 {
                let x0 = x - 18 + 13 * k;
                a.draw(&Rectangle::new(
                    [(x0, y - 1), (x0 + 8, y + 1)],
                    TAU.filled(),
                ))
                .map_err(draw_err)?;
            }
            Ok(())
        },
    )?;
    lg.entry(
        &format!("window with an invalid beam ({invalid_count})"),
        |a, (x, y)| {
            a.draw(&Rectangle::new(
                [(x - 16, y - 9), (x + 16, y + 9)],
                BAND.filled(),
            ))
            .map_err(draw_err)
        },
    )?;
    lg.y += 10;
    lg.heading("Reading it")?;
    lg.note("A window breaks where D ≥ τ;")?;
    lg.note("segments are the runs below τ.")?;
    lg.note("Invalid windows are left out.")?;
    if min_pos.is_finite() && finite.iter().any(|&d| d < lo) {
        lg.note(&format!("D = 0 is drawn at {}", power(&lo)))?;
    }
    root.present().map_err(draw_err)?;
    Ok(())
}

// ------------------------------------------------------------------ run --

/// Where each figure goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outputs {
    /// Format of all files.
    pub format: Format,
    /// The scan figure's file, if drawn.
    pub scan: Option<PathBuf>,
    /// The `D` figure's file, if drawn.
    pub mahalanobis: Option<PathBuf>,
}

/// Decide the files: `output` is a directory unless it ends in `.svg` or
/// `.png`; a file gets the first figure, a second goes beside it as
/// `STEM-mahalanobis.EXT`.
pub fn outputs(
    output: &Path,
    format: Option<Format>,
    figure: Figure,
    frame: usize,
) -> Result<Outputs> {
    let ext = output
        .extension()
        .and_then(OsStr::to_str)
        .map(str::to_ascii_lowercase);
    let file_format = match ext.as_deref() {
        Some("svg") => Some(Format::Svg),
        Some("png") => Some(Format::Png),
        _ => None,
    };
    let want_scan = figure != Figure::Mahalanobis;
    let want_d = figure != Figure::Scan;
    if let Some(ff) = file_format {
        if let Some(f) = format {
            ensure!(
                f == ff,
                "--output {} is a .{} file but --format is {}",
                output.display(),
                ff.extension(),
                f.extension()
            );
        }
        let stem = output
            .file_stem()
            .and_then(OsStr::to_str)
            .ok_or_else(|| anyhow!("bad output file name {}", output.display()))?;
        let beside = output.with_file_name(format!("{stem}-mahalanobis.{}", ff.extension()));
        let (scan, d) = match (want_scan, want_d) {
            (true, true) => (Some(output.to_path_buf()), Some(beside)),
            (true, false) => (Some(output.to_path_buf()), None),
            _ => (None, Some(output.to_path_buf())),
        };
        return Ok(Outputs {
            format: ff,
            scan,
            mahalanobis: d,
        });
    }
    let f = format.unwrap_or(Format::Svg);
    let name = |what: &str| output.join(format!("frame-{frame}-{what}.{}", f.extension()));
    Ok(Outputs {
        format: f,
        scan: want_scan.then(|| name("scan")),
        mahalanobis: want_d.then(|| name("mahalanobis")),
    })
}

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

/// `host-bridge plot`.
pub fn run(args: &PlotArgs) -> Result<()> {
    let params = args.params.to_params()?;
    let passes = match &args.passes {
        Some(list) => list.0.clone(),
        None => {
            let mut v = vec![1, params.iterations];
            v.dedup();
            v
        }
    };
    if let Some(&p) = passes.iter().find(|&&p| p > params.iterations) {
        bail!(
            "--passes {}: pass {p} is beyond the {} passes run (raise --iterations)",
            args.passes
                .as_ref()
                .map_or_else(String::new, ToString::to_string),
            params.iterations
        );
    }
    if let Some(s) = args.ellipse_scale {
        ensure!(
            s.is_finite() && s > 0.0,
            "--ellipse-scale must be a positive number"
        );
    }
    let outs = outputs(&args.output, args.format, args.figure, args.frame)?;
    let k = args.frame;

    let (source, input) = match &args.log {
        Some(path) => {
            let unit = match args.unit {
                UnitArg::Auto => UnitMode::Auto,
                UnitArg::Cm => UnitMode::Centimetre,
                UnitArg::Mm => UnitMode::Millimetre,
            };
            let log = carmen::read_log(path, unit)?;
            let total = log.scans.len();
            let name = path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            let source = format!("{name} ({} ranges)", log.unit);
            let scan = log.scans.into_iter().find(|s| s.index == k).ok_or_else(|| {
                anyhow!(
                    "{}: --frame {k} is out of range: the log has {total} FLASER frames (0..{total})",
                    path.display()
                )
            })?;
            (
                source,
                InputFrame {
                    index: scan.index,
                    frame: scan.frame,
                    pose: Some(scan.meta.pose),
                },
            )
        }
        None => {
            let sc = &args.scene;
            ensure!(
                k < sc.count,
                "--frame {k} is out of range: the synthetic scene has {} frames (0..{}; more with --count)",
                sc.count,
                sc.count
            );
            let frames = synthetic::frames(sc)?;
            let input = frames
                .into_iter()
                .nth(k)
                .ok_or_else(|| anyhow!("--frame {k} is out of range"))?;
            let kind = sc
                .scene
                .to_possible_value()
                .map_or_else(String::new, |v| v.get_name().to_string());
            (
                format!(
                    "synthetic {kind} (seed {}, noise {} m, dropout {})",
                    sc.seed, sc.noise_sigma, sc.dropout
                ),
                input,
            )
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_lists() {
        assert_eq!("1,30".parse(), Ok(PassList(vec![1, 30])));
        assert_eq!(" 30, 1 ,5".parse(), Ok(PassList(vec![1, 5, 30])));
        assert_eq!("7,7".parse(), Ok(PassList(vec![7])));
        for bad in ["", "0", "1,,2", "a", "1;30", "-1", "70000"] {
            assert!(bad.parse::<PassList>().is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn equal_scale_is_equal() {
        let ((u0, u1), (v0, v1), mpp) = equal_scale((-10.0, 10.0), (0.0, 5.0), (1000, 700));
        assert!(((u1 - u0) / 1000.0 - mpp).abs() < 1e-12);
        assert!(((v1 - v0) / 700.0 - mpp).abs() < 1e-12);
        assert!(u0 <= -10.0 && u1 >= 10.0 && v0 <= 0.0 && v1 >= 5.0);
        assert!((mpp - 0.02).abs() < 1e-12);
    }

    #[test]
    fn ellipse_axes() {
        // σx = 0.1, σy = 0.02, rotated 30°.
        let t = 30f64.to_radians();
        let (c, s) = (t.cos(), t.sin());
        let (l1, l2) = (0.01, 0.0004);
        let cov = [
            [(l1 * c * c + l2 * s * s) as f32, ((l1 - l2) * c * s) as f32],
            [((l1 - l2) * c * s) as f32, (l1 * s * s + l2 * c * c) as f32],
        ];
        let e = ellipse(1.0, 2.0, cov, 1.0).unwrap();
        assert_eq!(e.len(), ELLIPSE_VERTICES);
        let far = e
            .iter()
            .map(|&(x, y)| ((x - 1.0).hypot(y - 2.0), (y - 2.0).atan2(x - 1.0)))
            .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        assert!((far.0 - 0.2).abs() < 1e-6, "{far:?}");
        let dir = far.1.rem_euclid(std::f64::consts::PI);
        assert!((dir - t).abs() < 1e-3, "{dir}");
        let near = e
            .iter()
            .map(|&(x, y)| (x - 1.0).hypot(y - 2.0))
            .fold(f64::INFINITY, f64::min);
        assert!((near - 0.04).abs() < 1e-3, "{near}");
        assert!(ellipse(0.0, 0.0, [[f32::NAN, 0.0], [0.0, 1.0]], 1.0).is_none());
    }

    #[test]
    fn scales_and_clipping() {
        assert_eq!(nice_scale(20.0, 12.0), 1.0);
        assert_eq!(nice_scale(0.5, 12.0), 50.0);
        assert_eq!(nice_scale(0.1, 12.0), 200.0);
        let square = [(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)];
        let c = clip_polygon(&square, (-1.0, 1.0), (0.0, 1.0));
        assert!(c
            .iter()
            .all(|p| (-1.0..=1.0).contains(&p.0) && (0.0..=1.0).contains(&p.1)));
        assert_eq!(c.len(), 4);
        assert!(clip_polygon(&square, (5.0, 6.0), (5.0, 6.0)).is_empty());
    }

    #[test]
    fn output_names() {
        let o = outputs(Path::new("plots"), None, Figure::All, 3).unwrap();
        assert_eq!(o.format, Format::Svg);
        assert_eq!(o.scan, Some(PathBuf::from("plots/frame-3-scan.svg")));
        assert_eq!(
            o.mahalanobis,
            Some(PathBuf::from("plots/frame-3-mahalanobis.svg"))
        );
        let o = outputs(Path::new("a/b.PNG"), None, Figure::All, 3).unwrap();
        assert_eq!(o.format, Format::Png);
        assert_eq!(o.scan, Some(PathBuf::from("a/b.PNG")));
        assert_eq!(o.mahalanobis, Some(PathBuf::from("a/b-mahalanobis.png")));
        let o = outputs(Path::new("d.svg"), None, Figure::Mahalanobis, 0).unwrap();
        assert_eq!(
            (o.scan, o.mahalanobis),
            (None, Some(PathBuf::from("d.svg")))
        );
        assert!(outputs(Path::new("d.svg"), Some(Format::Png), Figure::All, 0).is_err());
    }

    #[test]
    fn runs_skip_invalid() {
        let d = [
            1.0,
            2.0,
            f32::INFINITY,
            3.0,
            f32::INFINITY,
            f32::INFINITY,
            4.0,
            5.0,
        ];
        let r = finite_runs(&d);
        assert_eq!(
            r,
            vec![(0, vec![1.0, 2.0]), (3, vec![3.0]), (6, vec![4.0, 5.0])]
        );
    }
}
