//! One LMS 2xx scan as a fixed-size frame of ranges (ALGORITHM.md §1).
//!
//! Ranges are metres in `f32`; every beam carries a [`Beam`] status that keeps
//! the reason a reading is invalid. Nothing is allocated: a frame holds
//! [`MAX_BEAMS`] slots and uses the first `len()` of them.

use core::fmt;

/// Largest number of beams in one frame: 100°/0.25° gives 401 values.
pub const MAX_BEAMS: usize = 401;
/// Smallest frame the pipeline accepts (one window needs three beams).
pub const MIN_BEAMS: usize = 3;

/// Why a beam carries no distance (PROTOCOL.md §3, ALGORITHM.md §1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Invalid {
    /// Error code 8191 (13-bit mode): not valid / no echo.
    NoEcho,
    /// Error code 8190: dazzling.
    Dazzle,
    /// Error code 8189: operation overflow.
    Overflow,
    /// Error code 8187: signal-to-noise ratio too low.
    LowSignal,
    /// Error code 8186: channel-1 read error.
    ChannelError,
    /// Error code 8183: above the maximum range.
    AboveMax,
    /// Any other value at or above the first error code; the offset below the
    /// mode's all-ones value (0 = not valid; a decoded word gives 0..=8). One
    /// byte, so that a [`Beam`] is two (a frame's statuses: 802 B, not 1604).
    OtherCode(u8),
    /// The reading was 0 (no distance).
    Zero,
    /// The reading was not a finite, positive number (host-side input only).
    NotFinite,
}

impl Invalid {
    /// Classify an error code given as its offset below the all-ones value
    /// of the range field (8191 − value for the 13-bit mode). Error codes
    /// are offsets 0..=8; an offset above 255 (no error code) is kept as
    /// `OtherCode(255)`.
    pub const fn from_code_offset(offset: u16) -> Self {
        match offset {
            0 => Invalid::NoEcho,
            1 => Invalid::Dazzle,
            2 => Invalid::Overflow,
            4 => Invalid::LowSignal,
            5 => Invalid::ChannelError,
            8 => Invalid::AboveMax,
            other if other > u8::MAX as u16 => Invalid::OtherCode(u8::MAX),
            other => Invalid::OtherCode(other as u8),
        }
    }
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Invalid::NoEcho => f.write_str("no echo / not valid"),
            Invalid::Dazzle => f.write_str("dazzling"),
            Invalid::Overflow => f.write_str("operation overflow"),
            Invalid::LowSignal => f.write_str("signal-to-noise ratio too low"),
            Invalid::ChannelError => f.write_str("channel read error"),
            Invalid::AboveMax => f.write_str("above the maximum range"),
            Invalid::OtherCode(o) => write!(f, "error code (all-ones minus {o})"),
            Invalid::Zero => f.write_str("zero range"),
            Invalid::NotFinite => f.write_str("not a finite positive range"),
        }
    }
}

/// The status of one beam.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Beam {
    /// The range is a distance and takes part in windows.
    Valid,
    /// The range slot holds no distance; the beam is never modified.
    Invalid(Invalid),
}

impl Beam {
    /// `true` for [`Beam::Valid`].
    #[inline]
    pub const fn is_valid(self) -> bool {
        matches!(self, Beam::Valid)
    }
}

/// A field of view and an angular resolution, as the LMS 2xx's telegrams
/// name a variant ([`Variant::from_fov_res`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FovRes {
    /// Field of view (°).
    pub fov_deg: u16,
    /// Angular resolution (1/100 °).
    pub res_centideg: u16,
}

/// The five LMS 2xx scan variants (field of view / angular resolution).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Variant {
    /// 180° at 1°: 181 beams.
    Fov180Res100,
    /// 180° at 0.5°: 361 beams (the main case).
    Fov180Res50,
    /// 100° at 1°: 101 beams.
    Fov100Res100,
    /// 100° at 0.5°: 201 beams.
    Fov100Res50,
    /// 100° at 0.25°: 401 beams.
    Fov100Res25,
}

impl Variant {
    /// All variants, in the order of the table in ALGORITHM.md §1.
    pub const ALL: [Variant; 5] = [
        Variant::Fov180Res100,
        Variant::Fov180Res50,
        Variant::Fov100Res100,
        Variant::Fov100Res50,
        Variant::Fov100Res25,
    ];

    /// Field of view in degrees (100 or 180).
    pub const fn fov_deg(self) -> u16 {
        match self {
            Variant::Fov180Res100 | Variant::Fov180Res50 => 180,
            _ => 100,
        }
    }

    /// Angular resolution in 1/100 degree (25, 50 or 100).
    pub const fn resolution_centideg(self) -> u16 {
        match self {
            Variant::Fov180Res100 | Variant::Fov100Res100 => 100,
            Variant::Fov180Res50 | Variant::Fov100Res50 => 50,
            Variant::Fov100Res25 => 25,
        }
    }

    /// Number of values per scan.
    pub const fn beams(self) -> usize {
        (self.fov_deg() as usize * 100) / self.resolution_centideg() as usize + 1
    }

    /// The variant with this field of view and resolution, if the LMS 2xx
    /// has it.
    pub const fn from_fov_res(fov_res: FovRes) -> Option<Self> {
        match (fov_res.fov_deg, fov_res.res_centideg) {
            (180, 100) => Some(Variant::Fov180Res100),
            (180, 50) => Some(Variant::Fov180Res50),
            (100, 100) => Some(Variant::Fov100Res100),
            (100, 50) => Some(Variant::Fov100Res50),
            (100, 25) => Some(Variant::Fov100Res25),
            _ => None,
        }
    }

    /// The variant that sends `n` values per scan.
    pub const fn from_beams(n: usize) -> Option<Self> {
        match n {
            181 => Some(Variant::Fov180Res100),
            361 => Some(Variant::Fov180Res50),
            101 => Some(Variant::Fov100Res100),
            201 => Some(Variant::Fov100Res50),
            401 => Some(Variant::Fov100Res25),
            _ => None,
        }
    }

    /// Bearing geometry in the sensor frame (x forward, y left).
    pub fn geometry(self) -> Geometry {
        let res_rad = self.resolution_centideg() as f32 * (core::f32::consts::PI / 18000.0);
        let first = -(self.fov_deg() as f32 / 2.0) * (core::f32::consts::PI / 180.0);
        Geometry {
            first_bearing: first,
            step: res_rad,
        }
    }
}

/// Bearings of a frame: `phi_j = first_bearing + j * step` (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Geometry {
    /// Bearing of beam 0 in radians (−π/2 for a 180° scan: beam 0 points right).
    pub first_bearing: f32,
    /// Angle between consecutive beams in radians (`gamma`).
    pub step: f32,
}

impl Geometry {
    /// Bearing of beam `j` in radians.
    #[inline]
    pub fn bearing(&self, j: usize) -> f32 {
        self.first_bearing + j as f32 * self.step
    }
}

/// Why a frame could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// More than [`MAX_BEAMS`] or fewer than [`MIN_BEAMS`] beams.
    BeamCount {
        /// The number of beams offered.
        got: usize,
    },
    /// The bearing step is not finite and positive, or the first bearing is not finite.
    BadGeometry,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::BeamCount { got } => {
                write!(f, "a frame has {MIN_BEAMS}..={MAX_BEAMS} beams, got {got}")
            }
            FrameError::BadGeometry => {
                f.write_str("bearing step must be finite and positive, first bearing finite")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// One scan: up to [`MAX_BEAMS`] ranges in metres with a status per beam.
#[derive(Clone, Debug)]
pub struct Frame {
    geometry: Geometry,
    len: usize,
    ranges: [f32; MAX_BEAMS],
    beams: [Beam; MAX_BEAMS],
}

impl Frame {
    /// An empty frame of `len` beams, all [`Invalid::NoEcho`] until set.
    pub fn new(geometry: Geometry, len: usize) -> Result<Self, FrameError> {
        if !(MIN_BEAMS..=MAX_BEAMS).contains(&len) {
            return Err(FrameError::BeamCount { got: len });
        }
        if !(geometry.step.is_finite() && geometry.step > 0.0 && geometry.first_bearing.is_finite())
        {
            return Err(FrameError::BadGeometry);
        }
        Ok(Frame {
            geometry,
            len,
            ranges: [0.0; MAX_BEAMS],
            beams: [Beam::Invalid(Invalid::NoEcho); MAX_BEAMS],
        })
    }

    /// A placeholder frame (3 invalid beams, 1 rad apart) to be filled in
    /// place later with [`Frame::reset`]; `const`, for a `static`.
    pub const fn empty() -> Self {
        Frame {
            geometry: Geometry {
                first_bearing: 0.0,
                step: 1.0,
            },
            len: MIN_BEAMS,
            ranges: [0.0; MAX_BEAMS],
            beams: [Beam::Invalid(Invalid::NoEcho); MAX_BEAMS],
        }
    }

    /// Every byte zero — not a valid frame (no beams, no geometry) until
    /// [`Frame::reset`] or a decoder fills it: for an all-zero `static`.
    pub(crate) const fn zeroed() -> Self {
        Frame {
            geometry: Geometry {
                first_bearing: 0.0,
                step: 0.0,
            },
            len: 0,
            ranges: [0.0; MAX_BEAMS],
            beams: [Beam::Invalid(Invalid::NoEcho); MAX_BEAMS],
        }
    }

    /// Make this frame an all-invalid frame of `variant`, in place (no
    /// 3 KiB temporary on the stack).
    pub fn reset(&mut self, variant: Variant) {
        self.geometry = variant.geometry();
        self.len = variant.beams();
        self.ranges.fill(0.0);
        self.beams.fill(Beam::Invalid(Invalid::NoEcho));
    }

    /// A frame of the given LMS variant, all beams invalid until set.
    pub fn for_variant(variant: Variant) -> Self {
        // Variants always have a valid beam count and geometry.
        match Frame::new(variant.geometry(), variant.beams()) {
            Ok(f) => f,
            Err(_) => Frame {
                geometry: variant.geometry(),
                len: MIN_BEAMS,
                ranges: [0.0; MAX_BEAMS],
                beams: [Beam::Invalid(Invalid::NoEcho); MAX_BEAMS],
            },
        }
    }

    /// A frame from ranges in metres: values that are not finite or not
    /// positive become invalid ([`Invalid::Zero`] / [`Invalid::NotFinite`]).
    pub fn from_metres(geometry: Geometry, ranges: &[f32]) -> Result<Self, FrameError> {
        let mut f = Frame::new(geometry, ranges.len())?;
        for (j, &r) in ranges.iter().enumerate() {
            f.set_metres(j, r);
        }
        Ok(f)
    }

    /// Set beam `j` from a range in metres (see [`Frame::from_metres`]).
    /// Out-of-range indices are ignored.
    pub fn set_metres(&mut self, j: usize, r: f32) {
        if j >= self.len {
            return;
        }
        if r == 0.0 {
            self.set_invalid(j, Invalid::Zero);
        } else if !(r.is_finite() && r > 0.0) {
            self.set_invalid(j, Invalid::NotFinite);
        } else if let (Some(range), Some(beam)) = (self.ranges.get_mut(j), self.beams.get_mut(j)) {
            *range = r;
            *beam = Beam::Valid;
        }
    }

    /// Mark beam `j` invalid with its reason; the range slot reads 0.
    pub fn set_invalid(&mut self, j: usize, why: Invalid) {
        if j >= self.len {
            return;
        }
        if let (Some(range), Some(beam)) = (self.ranges.get_mut(j), self.beams.get_mut(j)) {
            *range = 0.0;
            *beam = Beam::Invalid(why);
        }
    }

    /// Number of beams.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always `false`: a frame has at least [`MIN_BEAMS`] beams.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The bearing geometry.
    #[inline]
    pub fn geometry(&self) -> Geometry {
        self.geometry
    }

    /// Ranges in metres (0 for invalid beams).
    #[inline]
    pub fn ranges(&self) -> &[f32] {
        self.ranges.get(..self.len).unwrap_or_default()
    }

    /// Status of every beam.
    #[inline]
    pub fn beams(&self) -> &[Beam] {
        self.beams.get(..self.len).unwrap_or_default()
    }

    /// Number of valid beams.
    pub fn valid_count(&self) -> usize {
        self.beams().iter().filter(|b| b.is_valid()).count()
    }
}
