//! The figures' look: colours (public, so that tests can find the elements
//! in the SVG text), sizes, markers, the legend and the title.

use std::fmt;

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendCoord, DrawingErrorKind};

use super::font::{ensure_font, FONT};

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
/// The colours of lines and curves: the "tab10" palette's blue, orange,
/// green, purple, brown, cyan and olive, then a dark blue and a pink.
const PALETTE: [RGBColor; 9] = [
    RGBColor(0x1F, 0x77, 0xB4),
    RGBColor(0xFF, 0x7F, 0x0E),
    RGBColor(0x2C, 0xA0, 0x2C),
    RGBColor(0x94, 0x67, 0xBD),
    RGBColor(0x8C, 0x56, 0x4B),
    RGBColor(0x17, 0xBE, 0xCF),
    RGBColor(0xBC, 0xBD, 0x22),
    RGBColor(0x39, 0x3B, 0x79),
    RGBColor(0xE7, 0x96, 0x9C),
];
/// Fitted lines, one colour each, cycling (no red, green, magenta or grey).
pub const LINE_COLOURS: [RGBColor; 8] = [
    PALETTE[0], PALETTE[1], PALETTE[3], PALETTE[4], PALETTE[5], PALETTE[6], PALETTE[7], PALETTE[8],
];
/// `D` curves, one colour per selected pass, cycling.
pub const PASS_COLOURS: [RGBColor; 6] = [
    PALETTE[0], PALETTE[1], PALETTE[2], PALETTE[3], PALETTE[4], PALETTE[5],
];
/// The τ line of the `D` figure.
pub const TAU: RGBColor = RGBColor(0xE4, 0x1A, 0x1C);
pub(super) const BAND: RGBColor = RGBColor(0xEC, 0xEC, 0xEC);
pub(super) const GRID: RGBColor = RGBColor(0xE6, 0xE6, 0xE6);
pub(super) const GRID_BOLD: RGBColor = RGBColor(0xC8, 0xC8, 0xC8);

/// Vertices of a covariance ellipse.
pub const ELLIPSE_VERTICES: usize = 64;
/// Size of the scan figure (px).
pub const SCAN_SIZE: (u32, u32) = (1600, 940);
/// Size of the `D` figure (px).
pub const MAHALANOBIS_SIZE: (u32, u32) = (1600, 720);
pub(super) const TITLE_HEIGHT: u32 = 76;
pub(super) const LEGEND_WIDTH: u32 = 360;

/// A six-armed star marker (three `draw_line`s), the paper's edge points.
pub(super) struct Star<C> {
    at: C,
    size: i32,
    style: ShapeStyle,
}

impl<C> Star<C> {
    /// The marker of an edge point at `at`.
    pub(super) fn edge(at: C) -> Self {
        Star {
            at,
            size: 5,
            style: EDGE.stroke_width(2),
        }
    }
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

pub(super) fn diamond(size: i32) -> Vec<(i32, i32)> {
    vec![(0, -size), (size, 0), (0, size), (-size, 0)]
}

pub(super) fn sensor_triangle(size: i32) -> Vec<(i32, i32)> {
    // Pointing up the page: forward.
    vec![
        (0, -size),
        (size * 3 / 4, size / 2),
        (-size * 3 / 4, size / 2),
    ]
}

pub(super) fn draw_err<E: fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("cannot draw the figure: {e}")
}

pub(super) fn text_style(size: f64, colour: RGBColor, style: FontStyle) -> TextStyle<'static> {
    (FONT, size)
        .into_font()
        .style(style)
        .color(&colour)
        .pos(Pos::new(HPos::Left, VPos::Center))
}

/// A legend column on `area`: one row per entry, a sample drawn by the
/// closure at the row's sample centre, then the text.
pub(super) struct Legend<'a, DB: DrawingBackend> {
    pub(super) area: &'a DrawingArea<DB, Shift>,
    pub(super) y: i32,
}

impl<DB: DrawingBackend> Legend<'_, DB>
where
    DB::ErrorType: 'static,
{
    const ROW: i32 = 30;
    const SAMPLE_X: i32 = 28;
    const TEXT_X: i32 = 56;

    pub(super) fn heading(&mut self, text: &str) -> Result<()> {
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

    pub(super) fn note(&mut self, text: &str) -> Result<()> {
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

    pub(super) fn entry<F>(&mut self, text: &str, sample: F) -> Result<()>
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

pub(super) fn title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    line1: &str,
    line2: &str,
) -> Result<()>
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

pub(super) fn fmt_metres(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// A figure's areas on a white `root`: (title, chart, legend); loads the
/// font first.
pub(super) type Areas<DB> = (
    DrawingArea<DB, Shift>,
    DrawingArea<DB, Shift>,
    DrawingArea<DB, Shift>,
);

/// Split `root` into the title band, the chart and the legend column.
pub(super) fn layout<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>) -> Result<Areas<DB>>
where
    DB::ErrorType: 'static,
{
    ensure_font()?;
    root.fill(&WHITE).map_err(draw_err)?;
    let (w, _) = root.dim_in_pixel();
    let (title_area, body) = root.split_vertically(TITLE_HEIGHT);
    let (chart_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);
    Ok((title_area, chart_area, legend_area))
}

/// Draw a chart's grid and labels in the house style.
pub(super) fn draw_mesh<X, Y, DB>(
    mesh: &mut plotters::chart::MeshStyle<'_, '_, X, Y, DB>,
) -> Result<()>
where
    X: plotters::coord::ranged1d::Ranged + plotters::coord::ranged1d::ValueFormatter<X::ValueType>,
    Y: plotters::coord::ranged1d::Ranged + plotters::coord::ranged1d::ValueFormatter<Y::ValueType>,
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    mesh.bold_line_style(GRID_BOLD)
        .light_line_style(GRID)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(draw_err)
}
