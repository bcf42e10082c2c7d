//! The features of one frame and what its run dropped: the types every layer
//! shares (the pipeline fills them, the wire layer encodes them as `D0`–`D4`,
//! the device layer sends them). Data only; no algorithm lives here.
//!
//! [`Features`] holds [`Segment`]s, edge points, [`Line`]s and [`Corner`]s in
//! fixed-capacity storage ([`MAX_SEGMENTS`], [`MAX_LINES`], [`MAX_CORNERS`]);
//! everything that is not kept is counted in [`Stats`].

use core::fmt;

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

/// Declares [`Stats`] and its table of fields [`Stats::FIELDS`] from one list,
/// so that no encoder, report or comparison names the fields again.
macro_rules! declare_stats {
    ($($(#[doc = $doc:literal])+ $field:ident,)+) => {
        /// What a frame's run dropped, rejected or could not store. Nothing is
        /// lost silently: every item that is not in [`Features`] is counted here.
        ///
        /// Every counter is listed, in declaration order, in [`Stats::FIELDS`];
        /// the first [`Stats::D0_FIELDS`] are the words of the `D0` telegram.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[non_exhaustive]
        pub struct Stats {
            $($(#[doc = $doc])+ pub $field: u16,)+
        }

        impl Stats {
            /// Every counter as (name, getter), in declaration order. The names
            /// are the field names (and the JSON keys of `host-bridge extract`).
            pub const FIELDS: [(&'static str, fn(&Stats) -> u16); declare_stats!(@count $($field)+)] =
                [$((stringify!($field), |s: &Stats| s.$field),)+];

            /// Every counter as (name, meaning), in [`Stats::FIELDS`] order:
            /// the meaning is the field's documentation (rustdoc links
            /// included), for generated references.
            pub const MEANINGS: [(&'static str, &'static str); declare_stats!(@count $($field)+)] =
                [$((stringify!($field), concat!($($doc),+).trim_ascii_start()),)+];

            /// All counters zero (`const`, for statics).
            pub const ZERO: Stats = Stats { $($field: 0,)+ };

            /// Add every counter of `o` to this one's (saturating): the
            /// counts of several runs over parts of one frame.
            pub fn saturating_add(&mut self, o: &Stats) {
                $(self.$field = self.$field.saturating_add(o.$field);)+
            }

            /// Counters from `values` in [`Stats::FIELDS`] order; missing
            /// values are 0, extra values are ignored.
            pub fn from_fields(values: &[u16]) -> Stats {
                let mut it = values.iter().copied();
                Stats { $($field: it.next().unwrap_or(0),)+ }
            }
        }
    };
    (@count $($field:ident)+) => { 0 $(+ declare_stats!(@one $field))+ };
    (@one $field:ident) => { 1 };
}

declare_stats! {
    /// Valid beams in the frame.
    valid_beams,
    /// Windows that are invalid (an invalid beam or a prediction behind the sensor).
    invalid_windows,
    /// Segments shorter than `min_points`.
    short_segments,
    /// Segments beyond [`MAX_SEGMENTS`].
    segment_overflow,
    /// Edge points beyond capacity (cannot happen with [`MAX_BEAMS`] slots; counted anyway).
    edge_overflow,
    /// Segments whose fit failed (grazing incidence, singular).
    degenerate_fits,
    /// Lines rejected for `chi2 > max_chi2`.
    rejected_chi2,
    /// Lines rejected for `length < min_length`.
    rejected_short,
    /// Pairs of lines merged into one.
    merges,
    /// Lines beyond [`MAX_LINES`].
    line_overflow,
    /// Close line pairs that are parallel (no finite intersection).
    degenerate_corners,
    /// Corners beyond [`MAX_CORNERS`].
    corner_overflow,
    /// Split before reject ([`crate::pipeline::split`], `Params::split_depth`):
    /// segments split in two. Not carried by the `D0` telegram.
    splits,
    /// Split before reject: halves dropped for fewer than `min_points` beams.
    split_short,
    /// Split before reject: pieces dropped because they are still not one
    /// straight line (a circle explains them, or the depth is reached).
    split_rejected,
    /// Beams with a range at or beyond `Params::max_range` (ALGORITHM.md v2
    /// §1: fill values, another mode's error codes), made invalid. Not in
    /// `valid_beams`; not carried by the `D0` telegram.
    beyond_max_range,
    /// Lines dropped because the standard deviation of their α exceeds
    /// `Params::max_alpha_sd_deg`. Not in `D0`.
    rejected_wide,
    /// Lines dropped as pieces of an arc (a pillar, a curved wall): a chain
    /// of at least `Params::arc_chain` touching lines that turn the same
    /// way ([`crate::pipeline::arcs`]). Not in `D0`.
    rejected_arc,
}

impl Stats {
    /// How many of [`Stats::FIELDS`] (the first) the `D0` telegram carries:
    /// `valid_beams` … `corner_overflow`; the split counters are not sent.
    pub const D0_FIELDS: usize = 12;
}

/// The features of one frame: read them as slices ([`Features::lines`], …).
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct Features {
    /// Segments that passed `min_points`, in scan order.
    pub(crate) segments: Vec<Segment, MAX_SEGMENTS>,
    /// Edge points: middle beams of breaking valid windows, ascending.
    pub(crate) edges: Edges,
    /// Accepted lines, in scan order.
    pub(crate) lines: Vec<Line, MAX_LINES>,
    /// Corners between consecutive lines, in scan order.
    pub(crate) corners: Vec<Corner, MAX_CORNERS>,
    /// Counters of everything dropped or rejected.
    pub(crate) stats: Stats,
}

impl Features {
    /// No features, all counters zero (`const`, for statics).
    pub const EMPTY: Features = Features {
        segments: Vec::new(),
        edges: Edges::EMPTY,
        lines: Vec::new(),
        corners: Vec::new(),
        stats: Stats::ZERO,
    };

    /// Segments that passed `min_points`, in scan order (at most [`MAX_SEGMENTS`]).
    #[inline]
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Edge points (beam indices), ascending (at most [`MAX_BEAMS`]).
    #[inline]
    pub fn edges(&self) -> &Edges {
        &self.edges
    }

    /// Accepted lines, in scan order (at most [`MAX_LINES`]).
    #[inline]
    pub fn lines(&self) -> &[Line] {
        &self.lines
    }

    /// Corners between consecutive lines, in scan order (at most [`MAX_CORNERS`]).
    #[inline]
    pub fn corners(&self) -> &[Corner] {
        &self.corners
    }

    /// Counters of everything dropped or rejected.
    #[inline]
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// The lines, to adjust in place (e.g. into another frame of reference).
    #[inline]
    pub fn lines_mut(&mut self) -> &mut [Line] {
        &mut self.lines
    }

    /// The counters, to set (decoders and tests that build features).
    #[inline]
    pub fn stats_mut(&mut self) -> &mut Stats {
        &mut self.stats
    }

    /// Append a segment; hands it back if [`MAX_SEGMENTS`] are held.
    pub fn push_segment(&mut self, segment: Segment) -> Result<(), Segment> {
        self.segments.push(segment)
    }

    /// Append an edge point; hands it back unless it is below [`MAX_BEAMS`]
    /// and above every edge point held (edge points are ascending).
    pub fn push_edge(&mut self, beam: u16) -> Result<(), u16> {
        self.edges.push(beam)
    }

    /// Append a line; hands it back if [`MAX_LINES`] are held.
    pub fn push_line(&mut self, line: Line) -> Result<(), Line> {
        self.lines.push(line)
    }

    /// Append a corner; hands it back if [`MAX_CORNERS`] are held.
    pub fn push_corner(&mut self, corner: Corner) -> Result<(), Corner> {
        self.corners.push(corner)
    }
}

/// Words of [`Edges`]: one bit per beam of [`MAX_BEAMS`].
const EDGE_WORDS: usize = MAX_BEAMS.div_ceil(32);

/// The edge points of a frame (beam indices below [`MAX_BEAMS`]), a bitset
/// read in ascending order ([`Edges::iter`]): 56 B instead of a list of up
/// to 401 `u16` (806 B).
#[derive(Clone, Copy, PartialEq, Eq, Default)]
pub struct Edges {
    /// Beam `j` is bit `j % 32` of word `j / 32`.
    words: [u32; EDGE_WORDS],
    /// How many bits are set.
    count: u16,
    /// The smallest beam a push accepts (one above the last pushed).
    next: u16,
}

impl Edges {
    /// No edge points (`const`, for statics).
    pub const EMPTY: Edges = Edges {
        words: [0; EDGE_WORDS],
        count: 0,
        next: 0,
    };

    /// How many edge points.
    #[inline]
    pub fn len(&self) -> usize {
        usize::from(self.count)
    }

    /// Whether there are none.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Whether beam `beam` is an edge point.
    pub fn contains(&self, beam: u16) -> bool {
        let j = usize::from(beam);
        self.words
            .get(j / 32)
            .is_some_and(|w| (w >> (j % 32)) & 1 != 0)
    }

    /// The edge points, ascending.
    pub fn iter(&self) -> EdgeIter<'_> {
        EdgeIter {
            words: &self.words,
            word: 0,
            bits: self.words[0],
        }
    }

    /// Remove every edge point.
    pub fn clear(&mut self) {
        // Word by word, only the non-zero ones: a plain fill made the
        // compiler pull in an 8-byte-aligned memclr (174 B of flash) for
        // this one call.
        for w in self.words.iter_mut().filter(|w| **w != 0) {
            *w = 0;
        }
        self.count = 0;
        self.next = 0;
    }

    /// Append edge point `beam`; hands it back unless it is below
    /// [`MAX_BEAMS`] and above every edge point held.
    pub fn push(&mut self, beam: u16) -> Result<(), u16> {
        let j = usize::from(beam);
        match self.words.get_mut(j / 32) {
            Some(w) if beam >= self.next && j < MAX_BEAMS => {
                *w |= 1 << (j % 32);
                self.count += 1; // at most MAX_BEAMS: `next` only grows
                self.next = beam + 1; // beam < MAX_BEAMS, no overflow
                Ok(())
            }
            _ => Err(beam),
        }
    }
}

impl fmt::Debug for Edges {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<'a> IntoIterator for &'a Edges {
    type Item = u16;
    type IntoIter = EdgeIter<'a>;
    fn into_iter(self) -> EdgeIter<'a> {
        self.iter()
    }
}

/// The edge points of an [`Edges`], ascending.
#[derive(Clone, Debug)]
pub struct EdgeIter<'a> {
    words: &'a [u32; EDGE_WORDS],
    word: usize,
    bits: u32,
}

impl Iterator for EdgeIter<'_> {
    type Item = u16;
    fn next(&mut self) -> Option<u16> {
        while self.bits == 0 {
            self.word += 1;
            self.bits = *self.words.get(self.word)?;
        }
        let bit = self.bits.trailing_zeros() as usize;
        self.bits &= self.bits - 1;
        Some((self.word * 32 + bit) as u16)
    }
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

    /// Distance from this line's last endpoint to `next`'s first (m): how
    /// far apart the facing ends of consecutive lines are (§8's corner gap).
    #[inline]
    pub fn gap_to(&self, next: &Line) -> f32 {
        let gap_x = next.endpoints[0][0] - self.endpoints[1][0];
        let gap_y = next.endpoints[0][1] - self.endpoints[1][1];
        libm::sqrtf(gap_x * gap_x + gap_y * gap_y)
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

impl Corner {
    /// Every `f32` of the corner in the order of the `D2` record: x, y,
    /// cov xx, xy, yy, angle.
    pub fn floats(&self) -> [f32; 6] {
        [
            self.x,
            self.y,
            self.cov.a,
            self.cov.b,
            self.cov.c,
            self.angle_deg,
        ]
    }
}

#[cfg(test)]
mod edge_tests {
    use super::*;

    #[test]
    fn edges_are_an_ascending_bitset() {
        let mut e = Edges::EMPTY;
        assert!(e.is_empty() && e.iter().next().is_none());
        for beam in [0u16, 31, 32, 63, 200, 400] {
            assert_eq!(e.push(beam), Ok(()));
        }
        // Not ascending, a repeat, or beyond MAX_BEAMS: handed back, nothing stored.
        assert_eq!(e.push(300), Err(300));
        assert_eq!(e.push(400), Err(400));
        let mut f = Edges::EMPTY;
        assert_eq!(f.push(MAX_BEAMS as u16), Err(MAX_BEAMS as u16));
        assert!(f.is_empty());
        assert_eq!(e.len(), 6);
        assert_eq!(
            e.iter().collect::<std::vec::Vec<_>>(),
            [0, 31, 32, 63, 200, 400]
        );
        assert!(e.contains(63) && !e.contains(64) && !e.contains(1000));
        assert_eq!(format!("{e:?}"), "[0, 31, 32, 63, 200, 400]");
        e.clear();
        assert_eq!(e, Edges::EMPTY);
        assert_eq!(e.push(5), Ok(()));
    }
}

#[cfg(test)]
mod stats_meanings {
    use super::Stats;

    #[test]
    fn every_counter_has_its_meaning() {
        assert_eq!(Stats::MEANINGS.len(), Stats::FIELDS.len());
        for ((name, meaning), (field, _)) in Stats::MEANINGS.iter().zip(Stats::FIELDS.iter()) {
            assert_eq!(name, field);
            assert!(
                !meaning.is_empty() && !meaning.starts_with(' ') && meaning.ends_with('.'),
                "{name}: {meaning:?}"
            );
        }
    }
}
