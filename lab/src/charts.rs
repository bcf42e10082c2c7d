//! Line charts for the report: one SVG with one or more panels side by
//! side, drawn with `plotters` (text laid out with the font of
//! [`host_bridge::plot::ensure_font`]).

use std::path::Path;

use anyhow::{anyhow, Context, Result};
use plotters::prelude::*;
use plotters::series::DashedLineSeries;

/// Series colours, cycling (the plot module's line colours).
pub const COLOURS: [RGBColor; 8] = host_bridge::plot::LINE_COLOURS;

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points `(x, y)`; non-finite ones are left out.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub colour: RGBColor,
    /// Dashed, without markers (reference values).
    pub dashed: bool,
}

impl Series {
    /// A solid curve with markers.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, colour: RGBColor) -> Self {
        Series {
            name: name.into(),
            points,
            colour,
            dashed: false,
        }
    }

    /// A dashed reference curve.
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>, colour: RGBColor) -> Self {
        Series {
            dashed: true,
            ..Series::new(name, points, colour)
        }
    }
}

/// One panel.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// Caption.
    pub title: String,
    /// x axis description.
    pub x_label: String,
    /// y axis description.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
    /// y range; from the data if `None`.
    pub y_range: Option<(f64, f64)>,
    /// Labels of categorical x positions 0, 1, … (else numeric).
    pub x_categories: Option<Vec<String>>,
    /// Where the legend goes (`None`: no legend).
    pub legend: Option<Legend>,
}

impl Panel {
    /// A panel of `series` with its caption and axis descriptions, the y
    /// range from the data and no legend.
    pub fn new(title: &str, x_label: &str, y_label: &str, series: Vec<Series>) -> Self {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
            ..Panel::default()
        }
    }

    /// With the y range `lo..hi`.
    pub fn y_range(self, lo: f64, hi: f64) -> Self {
        Panel {
            y_range: Some((lo, hi)),
            ..self
        }
    }

    /// With the legend in `corner`.
    pub fn legend(self, corner: Legend) -> Self {
        Panel {
            legend: Some(corner),
            ..self
        }
    }

    /// With categorical x positions labelled `labels`.
    pub fn categories(self, labels: &[String]) -> Self {
        Panel {
            x_categories: Some(labels.to_vec()),
            ..self
        }
    }
}

/// Corner of a panel for its legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// Upper right.
    UpperRight,
    /// Lower right.
    LowerRight,
    /// Upper left.
    UpperLeft,
    /// Lower left.
    LowerLeft,
}

fn draw_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("cannot draw the chart: {e}")
}

/// Size of one panel (px).
pub const PANEL_SIZE: (u32, u32) = (620, 440);

/// Draw `panels` in a grid of `columns` under `title` into the SVG file `path`.
pub fn figure(path: &Path, title: &str, panels: &[Panel], columns: usize) -> Result<()> {
    host_bridge::plot::ensure_font()?;
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let size = (
        PANEL_SIZE.0 * columns as u32,
        PANEL_SIZE.1 * rows as u32 + 40,
    );
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (top, body) = root.split_vertically(40);
        top.draw(&Text::new(
            title.to_string(),
            (16, 10),
            ("sans-serif", 20).into_font().style(FontStyle::Bold),
        ))
        .map_err(draw_err)?;
        let areas = body.split_evenly((rows, columns));
        for (area, panel) in areas.iter().zip(panels) {
            draw_panel(area, panel)?;
        }
        root.present().map_err(draw_err)?;
    }
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &Panel,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let finite = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite();
    let all: Vec<(f64, f64)> = p
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(finite)
        .collect();
    let (mut x0, mut x1) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &(x, _)| {
            (a.0.min(x), a.1.max(x))
        });
    if !(x0.is_finite() && x1.is_finite()) {
        (x0, x1) = (0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let (y0, y1) = p.y_range.unwrap_or_else(|| {
        let (lo, hi) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &(_, y)| {
                (a.0.min(y), a.1.max(y))
            });
        if !(lo.is_finite() && hi.is_finite()) {
            (0.0, 1.0)
        } else {
            let pad = 0.08 * (hi - lo).max(1e-9);
            (lo - pad, hi + pad)
        }
    });
    let pad_x = if p.x_categories.is_some() { 0.3 } else { 0.0 };
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0 - pad_x..x1 + pad_x, y0..y1)
        .map_err(draw_err)?;
    let cats = p.x_categories.clone();
    let fmt_x = move |x: &f64| match &cats {
        Some(c) => {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < c.len() {
                c[i as usize].clone()
            } else {
                String::new()
            }
        }
        None => {
            if (x - x.round()).abs() < 1e-9 {
                format!("{}", x.round())
            } else {
                let t = format!("{x:.2}");
                t.trim_end_matches('0').trim_end_matches('.').to_string()
            }
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .x_label_formatter(&fmt_x)
        .label_style(("sans-serif", 13))
        .light_line_style(WHITE);
    if let Some(c) = &p.x_categories {
        mesh.x_labels(c.len() * 2 + 1);
    }
    mesh.draw().map_err(draw_err)?;
    for s in &p.series {
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(finite).collect();
        if pts.is_empty() {
            continue;
        }
        let colour = s.colour;
        if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(
                    pts.clone(),
                    8,
                    5,
                    colour.stroke_width(2),
                ))
                .map_err(draw_err)?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 8, y)], colour.stroke_width(2))
                });
        } else {
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(draw_err)?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(3))
                });
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(draw_err)?;
        }
    }
    if let Some(at) = p.legend {
        let position = match at {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        };
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 12))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(0xAA, 0xAA, 0xAA))
            .position(position)
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}
