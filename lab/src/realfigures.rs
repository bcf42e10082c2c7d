//! The figure of [`crate::realtruth`]: per log, the map's walls with the
//! pose of one frame, and that frame's true pieces and extracted lines for
//! three methods (matched lines blue, false red).

use std::path::Path;

use anyhow::{anyhow, Context, Result};
use host_bridge::carmen::{CarmenLog, Scan};
use lms_core::Extractor;
use plotters::prelude::*;

use crate::baselines::Tables;
use crate::maptruth::{FrameTruth, Map};
use crate::realtruth::{extract, score_frame, RealMethod, RealTally, ScoredLine};

const TRUTH: RGBColor = RGBColor(0x33, 0xA0, 0x2C);
const MATCHED: RGBColor = RGBColor(0x1F, 0x78, 0xB4);
const FALSE: RGBColor = RGBColor(0xE3, 0x1A, 0x1C);
const POINTS: RGBColor = RGBColor(0x99, 0x99, 0x99);
/// Methods drawn, by name: the defaults, ALGORITHM.md v1, split-and-merge.
const DRAWN: [&str; 3] = [
    crate::realtruth::NO_FLAGS,
    crate::realtruth::PAPER_NO_FLAGS,
    crate::realtruth::SPLIT_MERGE,
];

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("cannot draw the truth figure: {e}")
}

/// Segment of `l` between the rays of beams `first` and `last` (sensor frame).
fn segment(l: &ScoredLine, scan: &Scan) -> Option<[(f64, f64); 2]> {
    let g = scan.frame.geometry();
    let end = |j: usize| {
        let phi = f64::from(g.bearing(j));
        let c = (phi - l.alpha).cos();
        (c > 0.02).then(|| {
            let d = (l.r / c).min(60.0);
            (d * phi.cos(), d * phi.sin())
        })
    };
    Some([end(l.first)?, end(l.last)?])
}

/// Draw the figure of `log` into `dir`; returns the file name.
#[allow(clippy::too_many_arguments)]
pub fn draw(
    dir: &Path,
    name: &str,
    (log, no_flags): (&CarmenLog, &lms_core::Params),
    scans: &[&Scan],
    map: &Map,
    methods: &[RealMethod],
    truth_of: &dyn Fn(usize) -> FrameTruth,
    counted_per_frame: &[usize],
) -> Result<String> {
    host_bridge::plot::ensure_font()?;
    let mut sorted = counted_per_frame.to_vec();
    sorted.sort_unstable();
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0);
    let k = counted_per_frame
        .iter()
        .position(|&c| c == median)
        .unwrap_or(0);
    let Some(scan) = scans.get(k) else {
        return Err(anyhow!("{name}: no frame to draw"));
    };
    let truth = truth_of(k);
    let stem = name.trim_end_matches(".gz").trim_end_matches(".log");
    let file = format!("truth-{stem}-{}.svg", scan.index);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (1600, 440)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let areas = root.split_evenly((1, 4));
        draw_map(&areas[0], name, map, scan)?;
        let mut ex = Extractor::new();
        let tables = Tables::for_frame(&scan.frame);
        for (area, &m) in areas[1..].iter().zip(&DRAWN) {
            let Some(method) = methods.iter().find(|x| x.name == m) else {
                continue;
            };
            let lines = extract(method, log.unit, no_flags, &mut ex, scan, &tables, &truth);
            draw_frame(area, method.name, scan, &truth, &lines)?;
        }
        root.present().map_err(err)?;
    }
    let path = dir.join(&file);
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(file)
}

fn draw_map<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    name: &str,
    map: &Map,
    scan: &Scan,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for w in &map.walls {
        for p in [w.a, w.b] {
            (x0, x1, y0, y1) = (x0.min(p[0]), x1.max(p[0]), y0.min(p[1]), y1.max(p[1]));
        }
    }
    if x1 <= x0 || y1 <= y0 {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    let side = (x1 - x0).max(y1 - y0);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{name}: {} map walls", map.walls.len()),
            ("sans-serif", 15),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(
            cx - 0.5 * side..cx + 0.5 * side,
            cy - 0.5 * side..cy + 0.5 * side,
        )
        .map_err(err)?;
    chart.configure_mesh().disable_mesh().draw().map_err(err)?;
    chart
        .draw_series(map.walls.iter().map(|w| {
            PathElement::new(
                vec![(w.a[0], w.a[1]), (w.b[0], w.b[1])],
                BLACK.stroke_width(1),
            )
        }))
        .map_err(err)?;
    let [x, y, th] = scan.meta.pose;
    chart
        .draw_series([
            Circle::new((x, y), 4, FALSE.filled()),
            Circle::new(
                (x + 0.03 * side * th.cos(), y + 0.03 * side * th.sin()),
                2,
                FALSE.filled(),
            ),
        ])
        .map_err(err)?;
    Ok(())
}

fn draw_frame<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    scan: &Scan,
    truth: &FrameTruth,
    lines: &[ScoredLine],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let g = scan.frame.geometry();
    let r = scan.frame.ranges();
    let pts: Vec<(f64, f64)> = (0..scan.frame.len())
        .filter(|&j| scan.frame.beams()[j].is_valid() && r[j] < 40.0)
        .map(|j| {
            let (d, phi) = (f64::from(r[j]), f64::from(g.bearing(j)));
            (d * phi.cos(), d * phi.sin())
        })
        .collect();
    // Zoomed to the nearer 90 % of the points (a few far hits would make
    // every line a dot).
    let mut far: Vec<f64> = pts.iter().map(|p| p.0.abs().max(p.1.abs())).collect();
    far.sort_by(f64::total_cmp);
    let reach = far
        .get(far.len() * 9 / 10)
        .map_or(1.0, |r| 1.1 * r)
        .clamp(1.0, 40.0);
    // Which lines match: score this frame alone.
    let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
    let mut t = RealTally::default();
    let (_, matched) = score_frame(truth, lines, &valid, &mut t);
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!(
                "frame {}: {title} ({} of {} lines matched)",
                scan.index, t.lines_matched, t.lines
            ),
            ("sans-serif", 13),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(-reach..reach, -reach..reach)
        .map_err(err)?;
    chart.configure_mesh().disable_mesh().draw().map_err(err)?;
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 1, POINTS.filled())))
        .map_err(err)?;
    let true_lines = truth
        .pieces
        .iter()
        .filter(|p| p.counted)
        .map(|p| ScoredLine {
            alpha: p.alpha,
            r: p.r,
            first: p.first,
            last: p.last,
            middle: p.own_middle,
        });
    chart
        .draw_series(true_lines.filter_map(|l| {
            segment(&l, scan).map(|s| PathElement::new(s.to_vec(), TRUTH.stroke_width(6)))
        }))
        .map_err(err)?;
    chart
        .draw_series(lines.iter().enumerate().filter_map(|(i, l)| {
            let c = if matched[i] { MATCHED } else { FALSE };
            segment(l, scan).map(|s| PathElement::new(s.to_vec(), c.stroke_width(2)))
        }))
        .map_err(err)?;
    Ok(())
}
