//! The scan figure: the frame in the sensor frame (x forward drawn up, y
//! left drawn left, equal scale) with its features.

use anyhow::Result;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::frame::{FramePlot, ScanDrawn};
use super::geometry::{clip_polygon, ellipse, equal_scale, nice_scale, semi_major};
use super::style::*;
use crate::extract::StatsRecord;

fn scan_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(16).x_label_area_size(54).y_label_area_size(70);
    b
}

/// The chart: u = −y across (left of the sensor is left on the page),
/// v = x up (forward is up), in metres.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A point of the sensor frame `(x, y)` in chart coordinates `(u, v)`.
fn to_uv((x, y): (f64, f64)) -> (f64, f64) {
    (-y, x)
}

/// The part of the plane shown, at the same scale on both axes.
#[derive(Clone, Copy)]
struct View {
    u_range: (f64, f64),
    v_range: (f64, f64),
    /// Metres per pixel.
    mpp: f64,
}

impl View {
    fn contains(&self, (u, v): (f64, f64)) -> bool {
        (self.u_range.0..=self.u_range.1).contains(&u)
            && (self.v_range.0..=self.v_range.1).contains(&v)
    }
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
    let (title_area, chart_area, legend_area) = layout(root)?;
    let rec = &fp.record;
    let raw: Vec<(f64, f64)> = fp.raw_points().into_iter().map(to_uv).collect();
    let smoothed: Vec<(f64, f64)> = fp.smoothed_points().into_iter().map(to_uv).collect();
    let (u_lim, v_lim) = limits(fp, &raw, &smoothed);
    let (mut chart, view) = scan_chart(&chart_area, u_lim, v_lim)?;
    draw_points_and_lines(&mut chart, fp, &raw, &smoothed)?;
    let edges = edge_points(fp);
    chart
        .draw_series(edges.iter().map(|&p| Star::edge(p)))
        .map_err(draw_err)?;
    let (scale_well, scale_ill) = ellipse_scales(fp, ellipse_scale, view.mpp);
    let mut drawn = ScanDrawn {
        lines: rec.lines.len(),
        edges: edges.len(),
        ellipse_scale_well: scale_well,
        ellipse_scale_ill: scale_ill,
        metres_per_pixel: view.mpp,
        ..ScanDrawn::default()
    };
    draw_corners(&mut chart, fp, view, &mut drawn)?;
    // The sensor.
    chart
        .draw_series(std::iter::once(
            EmptyElement::at((0.0, 0.0)) + Polygon::new(sensor_triangle(11), BLACK.filled()),
        ))
        .map_err(draw_err)?;
    scan_title(&title_area, fp)?;
    scan_legend(&legend_area, fp, &drawn)?;
    root.present().map_err(draw_err)?;
    Ok(drawn)
}

/// The chart's limits `(u, v)`: every point, line end and the sensor, with
/// a margin.
fn limits(fp: &FramePlot, raw: &[(f64, f64)], smoothed: &[(f64, f64)]) -> ((f64, f64), (f64, f64)) {
    let mut extent: Vec<(f64, f64)> = raw.to_vec();
    extent.extend(smoothed);
    extent.push((0.0, 0.0));
    for l in &fp.record.lines {
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
    let (u_lim, v_lim) = (fold(|p| p.0), fold(|p| p.1));
    let pad = 0.04 * (u_lim.1 - u_lim.0).max(v_lim.1 - v_lim.0).max(0.5);
    (
        (u_lim.0 - pad, u_lim.1 + pad),
        (v_lim.0 - pad, v_lim.1 + pad),
    )
}

/// The chart with its axes, at equal scale over at least the limits.
fn scan_chart<'a, DB: DrawingBackend>(
    chart_area: &'a DrawingArea<DB, Shift>,
    u_lim: (f64, f64),
    v_lim: (f64, f64),
) -> Result<(Chart<'a, DB>, View)>
where
    DB::ErrorType: 'static,
{
    // Build once to learn the plotting area's size, then with equal scale.
    let probe = scan_builder(chart_area)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(draw_err)?;
    let plot_px = probe.plotting_area().dim_in_pixel();
    drop(probe);
    let (u_range, v_range, mpp) = equal_scale(u_lim, v_lim, plot_px);
    let mut chart = scan_builder(chart_area)
        .build_cartesian_2d(u_range.0..u_range.1, v_range.0..v_range.1)
        .map_err(draw_err)?;
    let neg = |u: &f64| fmt_metres(-*u);
    let plain = |v: &f64| fmt_metres(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_desc("y (m), positive to the left")
        .y_desc("x (m), forward")
        .x_label_formatter(&neg)
        .y_label_formatter(&plain)
        .x_labels(14)
        .y_labels(10);
    draw_mesh(&mut mesh)?;
    let view = View {
        u_range,
        v_range,
        mpp,
    };
    Ok((chart, view))
}

/// Raw, then smoothed points; the fitted lines over them, translucent so
/// that the scatter shows.
fn draw_points_and_lines<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    fp: &FramePlot,
    raw: &[(f64, f64)],
    smoothed: &[(f64, f64)],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
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
    for (i, l) in fp.record.lines.iter().enumerate() {
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
    Ok(())
}

/// Edge points on the smoothed scan (where D was computed), in chart
/// coordinates.
fn edge_points(fp: &FramePlot) -> Vec<(f64, f64)> {
    let rec = &fp.record;
    rec.edges
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
        .collect()
}

/// The enlargement of the 2σ ellipses, (well-, ill-conditioned): the one
/// given, or per class one that makes the median ellipse visible (the
/// ill-conditioned ones are long along the lines and would fill the view).
fn ellipse_scales(fp: &FramePlot, given: Option<f64>, mpp: f64) -> (f64, f64) {
    let class_scale = |well: bool| {
        given.unwrap_or_else(|| {
            let mut majors: Vec<f64> = fp
                .record
                .corners
                .iter()
                .filter(|c| c.well_conditioned == well)
                .filter_map(|c| semi_major(c.cov))
                .collect();
            majors.sort_by(f64::total_cmp);
            majors
                .get(majors.len() / 2)
                .map_or(1.0, |&m| nice_scale(m / mpp, 12.0))
        })
    };
    (class_scale(true), class_scale(false))
}

/// Corners in the view with their ellipses (clipped to the view); counts
/// them in `drawn`.
fn draw_corners<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    fp: &FramePlot,
    view: View,
    drawn: &mut ScanDrawn,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let rec = &fp.record;
    let (u_range, v_range) = (view.u_range, view.v_range);
    let (scale_well, scale_ill) = (drawn.ellipse_scale_well, drawn.ellipse_scale_ill);
    for c in &rec.corners {
        let p = to_uv((f64::from(c.x), f64::from(c.y)));
        if !view.contains(p) {
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

    Ok(())
}

/// The two title lines: counts, then source and parameters.
fn scan_title<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, fp: &FramePlot) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let rec = &fp.record;
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
    title(area, &line1, &line2)
}

/// The legend: a sample of every marker, then the view and what the
/// pipeline dropped.
fn scan_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fp: &FramePlot,
    drawn: &ScanDrawn,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mut lg = Legend { area, y: 40 };
    legend_markers(&mut lg, fp, drawn)?;
    legend_notes(&mut lg, &fp.record.stats, drawn)
}

/// The legend's marker samples.
fn legend_markers<DB: DrawingBackend>(
    lg: &mut Legend<'_, DB>,
    fp: &FramePlot,
    drawn: &ScanDrawn,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let rec = &fp.record;
    let wc = rec.corners.iter().filter(|c| c.well_conditioned).count();
    let (scale_well, scale_ill) = (drawn.ellipse_scale_well, drawn.ellipse_scale_ill);
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
        a.draw(&Star::edge(c)).map_err(draw_err)
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
    Ok(())
}

/// The legend's notes: the view, then what the pipeline dropped.
fn legend_notes<DB: DrawingBackend>(
    lg: &mut Legend<'_, DB>,
    stats: &StatsRecord,
    drawn: &ScanDrawn,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mpp = drawn.metres_per_pixel;
    lg.y += 10;
    lg.heading("View")?;
    lg.note("x forward is up, y left is left;")?;
    lg.note(&format!(
        "equal scale: 1 m = {:.1} px on both axes",
        1.0 / mpp
    ))?;
    let scales = [
        (drawn.ellipse_scale_well, "well"),
        (drawn.ellipse_scale_ill, "ill"),
    ];
    for (k, what) in scales {
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
    let s = stats;
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
    Ok(())
}
