//! The `D` figure: the Mahalanobis distance per window after the selected
//! passes, on a log axis, with the segmentation gate τ.

use anyhow::Result;
use plotters::coord::combinators::LogCoord;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::frame::FramePlot;
use super::style::*;

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

/// The `D` chart: beam index across, `D` on a log axis.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, LogCoord<f64>>>;

/// The `D` axis: every finite `D`, the smallest positive one, and the axis
/// limits (decades).
struct Scale {
    finite: Vec<f64>,
    min_pos: f64,
    lo: f64,
    hi: f64,
}

impl Scale {
    fn new(fp: &FramePlot, tau: f64) -> Self {
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
        Scale {
            finite,
            min_pos,
            lo,
            hi,
        }
    }
}

/// `10^e` as `1eE`, other values in short scientific notation.
fn power(v: &f64) -> String {
    let e = v.log10();
    if (e - e.round()).abs() < 1e-6 {
        format!("1e{}", e.round() as i64)
    } else {
        format!("{v:.1e}")
    }
}

/// Draw the `D` figure on `root` (any backend, [`MAHALANOBIS_SIZE`] recommended).
pub fn draw_mahalanobis<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fp: &FramePlot,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (title_area, chart_area, legend_area) = layout(root)?;
    let rec = &fp.record;
    let tau = f64::from(fp.params.tau);
    let sc = Scale::new(fp, tau);
    let x_max = rec.n.saturating_sub(1) as f64;
    let mut chart = ChartBuilder::on(&chart_area)
        .margin(16)
        .x_label_area_size(54)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..x_max, (sc.lo..sc.hi).log_scale())
        .map_err(draw_err)?;
    let beam = |v: &f64| format!("{v:.0}");
    let mut mesh = chart.configure_mesh();
    mesh.x_desc("beam index (centre of the window of 3 beams)")
        .y_desc("D (log scale)")
        .x_label_formatter(&beam)
        .y_label_formatter(&power)
        .x_labels(16);
    draw_mesh(&mut mesh)?;
    let invalid_count = shade_invalid_windows(&mut chart, fp, &sc)?;
    draw_passes(&mut chart, fp, sc.lo)?;
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
    d_legend(&legend_area, fp, &sc, invalid_count)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Windows with an invalid beam as shaded bands; returns how many.
fn shade_invalid_windows<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    fp: &FramePlot,
    sc: &Scale,
) -> Result<usize>
where
    DB::ErrorType: 'static,
{
    let rec = &fp.record;
    let (lo, hi) = (sc.lo, sc.hi);
    let windows = rec.n.saturating_sub(2);
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

    Ok(invalid_count)
}

/// One curve per selected pass; invalid windows break it. The last pass
/// first and thick, earlier ones thin on top of it (`D` = 0 drawn at `lo`).
fn draw_passes<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, fp: &FramePlot, lo: f64) -> Result<()>
where
    DB::ErrorType: 'static,
{
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

    Ok(())
}

/// The legend: one entry per pass, τ, the shaded windows, how to read it.
fn d_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fp: &FramePlot,
    sc: &Scale,
    invalid_count: usize,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let tau = f64::from(fp.params.tau);
    let (finite, min_pos, lo) = (&sc.finite, sc.min_pos, sc.lo);
    let mut lg = Legend { area, y: 40 };
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
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
