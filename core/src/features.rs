//! The features of one frame and what its run dropped: the types every layer
//! shares (the pipeline fills them, the wire layer encodes them as `D0`–`D4`,
//! the device layer sends them). Data only; no algorithm lives here.
//!
//! [`Features`] holds [`Segment`]s, edge points, [`Line`]s and [`Corner`]s in
//! fixed-capacity storage ([`MAX_SEGMENTS`], [`MAX_LINES`], [`MAX_CORNERS`]);
//! everything that is not kept is counted in [`Stats`].

use heapless::Vec;

use crate::frame::MAX_BEAMS;
use crate::maths::Sym2;

/// Most windows in a frame (`MAX_BEAMS − 2`).
pub const MAX_WINDOWS: usize = MAX_BEAMS - 2;
/// Most segments kept per frame.
pub const MAX_SEGMENTS: usize = 64;
/// Most lines kept per frame.
pub const MAX_LINES: usize = 64;
/// Most corners kept per frame.
pub const MAX_CORNERS: usize = 63;

/// What a frame's run dropped, rejected or could not store. Nothing is lost
/// silently: every item that is not in [`Features`] is counted here.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Valid beams in the frame.
    pub valid_beams: u16,
    /// Windows that are invalid (an invalid beam or a prediction behind the sensor).
    pub invalid_windows: u16,
    /// Segments shorter than `min_points`.
    pub short_segments: u16,
    /// Segments beyond [`MAX_SEGMENTS`].
    pub segment_overflow: u16,
    /// Edge points beyond capacity (cannot happen with [`MAX_BEAMS`] slots; counted anyway).
    pub edge_overflow: u16,
    /// Segments whose fit failed (grazing incidence, singular).
    pub degenerate_fits: u16,
    /// Lines rejected for `chi2 > max_chi2`.
    pub rejected_chi2: u16,
    /// Lines rejected for `length < min_length`.
    pub rejected_short: u16,
    /// Pairs of lines merged into one.
    pub merges: u16,
    /// Lines beyond [`MAX_LINES`].
    pub line_overflow: u16,
    /// Close line pairs that are parallel (no finite intersection).
    pub degenerate_corners: u16,
    /// Corners beyond [`MAX_CORNERS`].
    pub corner_overflow: u16,
    /// Split before reject ([`crate::pipeline::split`], off by default): segments
    /// split in two. Not carried by the `D0` telegram.
    pub splits: u16,
    /// Split before reject: halves dropped for fewer than `min_points` beams.
    pub split_short: u16,
    /// Split before reject: pieces dropped because they are still not one
    /// straight line (a circle explains them, or the depth is reached).
    pub split_rejected: u16,
}

/// The features of one frame.
#[derive(Clone, Debug, Default)]
pub struct Features {
    /// Segments that passed `min_points`, in scan order.
    pub segments: Vec<Segment, MAX_SEGMENTS>,
    /// Edge points: middle beams of breaking valid windows, ascending.
    pub edges: Vec<u16, MAX_BEAMS>,
    /// Accepted lines, in scan order.
    pub lines: Vec<Line, MAX_LINES>,
    /// Corners between consecutive lines, in scan order.
    pub corners: Vec<Corner, MAX_CORNERS>,
    /// Counters of everything dropped or rejected.
    pub stats: Stats,
}

/// A run of points `first..=last` (beam indices) explained by one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Segment {
    /// First beam index.
    pub first: u16,
    /// Last beam index (inclusive).
    pub last: u16,
}

impl Segment {
    /// Number of points covered.
    #[inline]
    pub fn points(&self) -> usize {
        (self.last as usize + 1).saturating_sub(self.first as usize)
    }
}

/// A fitted line with its uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Line {
    /// Normal direction α (rad), in (−π, π].
    pub alpha: f32,
    /// Distance from the sensor r (m), ≥ 0.
    pub r: f32,
    /// Covariance of (α, r): `[[αα, αr], [αr, rr]]` in rad², rad·m, m².
    pub cov: Sym2,
    /// First beam index of the fitted segment.
    pub first: u16,
    /// Last beam index of the fitted segment (inclusive).
    pub last: u16,
    /// Number of valid points used in the fit.
    pub points: u16,
    /// Fit quality `Σ e² / (sigma²·(m − 2))`; ≈ 1 for a true line.
    pub chi2: f32,
    /// First and last points projected onto the line, `[[x, y], [x, y]]` (m).
    pub endpoints: [[f32; 2]; 2],
}

impl Line {
    /// Every `f32` of the line in the order of the `D1` record: α, r,
    /// cov αα, αr, rr, chi2, x₀, y₀, x₁, y₁.
    pub fn floats(&self) -> [f32; 10] {
        [
            self.alpha,
            self.r,
            self.cov.a,
            self.cov.b,
            self.cov.c,
            self.chi2,
            self.endpoints[0][0],
            self.endpoints[0][1],
            self.endpoints[1][0],
            self.endpoints[1][1],
        ]
    }

    /// Distance between the endpoints (m).
    pub fn length(&self) -> f32 {
        let dx = self.endpoints[1][0] - self.endpoints[0][0];
        let dy = self.endpoints[1][1] - self.endpoints[0][1];
        libm::sqrtf(dx * dx + dy * dy)
    }
}

/// A corner feature.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Corner {
    /// Position in the sensor frame (m), x forward.
    pub x: f32,
    /// Position in the sensor frame (m), y left.
    pub y: f32,
    /// Covariance of (x, y) in m².
    pub cov: Sym2,
    /// Angle between the two lines, folded into [0°, 90°].
    pub angle_deg: f32,
    /// `angle_deg >= min_corner_angle_deg`.
    pub well_conditioned: bool,
    /// Index of the first line (in the frame's line list).
    pub line_a: u8,
    /// Index of the second line.
    pub line_b: u8,
}
