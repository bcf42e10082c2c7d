//! Parameters of the pipeline with the defaults of ALGORITHM.md, and their
//! validation; every parameter by name ([`FIELDS`], [`Params::set`]) and
//! the named presets ([`PRESETS`]).

use core::fmt;

mod data;
mod table;
pub use data::{max_range_of, sigma_for_step, DataProfile, DataSurvey, RangeMode};
pub use table::{field, preset, Field, Preset, Range, Value, FIELDS, HOST_ONLY, PRESETS};

/// All tunable parameters. Start from a preset ([`Params::DEFAULT`],
/// [`Params::V3_1`], [`Params::V3_0`], [`Params::V2`], [`Params::PAPER`]) and change fields with the `const`
/// setters, e.g. `Params::DEFAULT.with_iterations(5).with_tau(9.0)`;
/// [`Params::validate`] refuses nonsense and gives the [`ValidParams`] the
/// pipeline runs with. Each field's name, unit, range and meaning are
/// declared once, in [`FIELDS`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct Params {
    /// Range noise standard deviation `sigma` (m). Default 0.005 (LMS 2xx, mm mode).
    pub sigma: f32,
    /// Process noise `q` (m²), the second scale parameter. Default 0.
    pub q: f32,
    /// Number of smoothing passes, the first scale parameter. Default 5, at least 1.
    pub iterations: u16,
    /// χ² gate on `D` for segmentation (§6). Default 12.
    pub tau: f32,
    /// Smallest segment kept, in points (§6). Default 5, at least 3.
    pub min_points: u16,
    /// Largest accepted line quality `chi2` (§7). Default 4.
    pub max_chi2: f32,
    /// Shortest accepted line, endpoint to endpoint (m). Default 0.1.
    pub min_length: f32,
    /// Fit each line to all points of its segment, including a corner point
    /// shared with the neighbouring segment (§7.5). Default `false`
    /// (ALGORITHM.md v2): the shared point is left out of both fits: it lies
    /// on neither line exactly, and including it makes the corner covariance
    /// over-confident (measured corner NEES 2.73 with it, 1.90 without, on
    /// 400 draws of a 90° corner at σ = 5 mm; ideal 2). `true` is v1.
    pub fit_shared_points: bool,
    /// Merge consecutive agreeing lines (§7.6). Default on.
    pub merge: bool,
    /// Most valid beams allowed between two lines that may merge. Default 3.
    pub merge_gap_beams: u16,
    /// χ² (2 dof) gate for merging. Default 9.21 (99 %).
    pub merge_gate: f32,
    /// Largest distance between facing endpoints of two lines that are
    /// intersected into a corner (m). Default 0.2.
    pub corner_gap: f32,
    /// Smallest angle between lines for a well-conditioned corner (degrees,
    /// 0..=90). Default 30.
    pub min_corner_angle_deg: f32,
    /// Split before reject (ALGORITHM.md v2 §7.4): how many levels a
    /// segment that is not one straight line may be split at its farthest
    /// point before the §7 gates ([`crate::pipeline::split`]). Default 8
    /// (TruePos 0.66 → 0.97 at σ = 20 mm); 0 is v1. At most
    /// [`MAX_SPLIT_DEPTH`].
    pub split_depth: u8,
    /// Largest true range (m, ALGORITHM.md v2 §1): a beam at or beyond it is
    /// invalid (counted in `Stats::beyond_max_range`), so fill values of
    /// recorded logs never become walls. Default 81.83 m, the largest true
    /// range of any LMS 2xx unit and mode (cm); [`DataProfile::params`] gives
    /// the value of a unit and range mode ([`max_range_of`]). `+inf` turns
    /// the limit off (v1).
    pub max_range: f32,
    /// Merge consecutive lines that are nearly collinear and touch (facing
    /// endpoints closer than `corner_gap`, normals less than
    /// `min_corner_angle_deg` apart) when the refit of their union passes
    /// `max_chi2`, even where the §7.6 gates keep them apart (beyond
    /// ALGORITHM.md: otherwise an ill-conditioned "corner" is reported
    /// between two pieces of one wall). Default on; off in v1.
    pub merge_collinear: bool,
    /// Largest standard deviation of a line's α (degrees): a line less
    /// certain than this is dropped and counted (`Stats::rejected_wide`;
    /// beyond ALGORITHM.md). `+inf` keeps every line (v1).
    pub max_alpha_sd_deg: f32,
    /// Grazing-incidence observation noise `ρ` (dimensionless, ALGORITHM.md
    /// §10 proposal, docs/ALGORITHM.md Appendix A): each window's
    /// `R = sigma_w²·I` with `sigma_w² = sigma² + ρ²·min(h², (t·γ·b)²)`,
    /// `h = (c − a)/2` the range step per beam of the window (`= b·γ·tan β`
    /// at incidence `β`), `t = tan` [`GRAZING_MAX_INCIDENCE_DEG`]. `0` is
    /// the independent range noise of §3 (v1, v2).
    ///
    /// Only with feature `section10` (host crates; not the firmware):
    /// otherwise a non-default value fails validation
    /// ([`ParamError::NotInBuild`]).
    pub grazing_noise: f32,
    /// Same-turn windows (ALGORITHM.md §10 (a),
    /// docs/DESIGN.md, windows and split before reject): in the modes that
    /// interleave mirror turns (0.5°: two, 0.25°: four), window `i` is the
    /// beams `i, i+k, i+2k` of one turn (`k` turns, the filter's angle
    /// `k·γ`), so the offset between turns (platform motion in 13.3 ms) is
    /// no break; a run of windows covers every beam of its windows up to
    /// its neighbours ([`crate::pipeline::segmentation::Segmenter`]).
    /// Default on; `false` is §2–6 (v1, v2); 1° modes are the same either
    /// way.
    pub same_turn_windows: bool,
    /// Range noise of the line fits and their tests (m; §7, split, merge;
    /// ALGORITHM.md §10 proposal): the raw ranges of both mirror turns
    /// scatter more about one line than one turn's about its own (the
    /// offset between turns), while `sigma` stays the noise `D` sees.
    /// `0` uses `sigma` (v1, v2).
    ///
    /// Only with feature `section10` (host crates; not the firmware):
    /// otherwise a non-default value fails validation
    /// ([`ParamError::NotInBuild`]).
    pub fit_sigma: f32,
    /// Per-turn extraction (ALGORITHM.md §10 proposal (d),
    /// docs/ALGORITHM.md Appendix A): in the modes that interleave
    /// mirror turns (0.5°: two, 0.25°: four), each turn's beams run through
    /// §2–8 as a scan of their own (bearing step `k·γ`), and the turns'
    /// lines of one wall are fused into one (information-weighted; pairs
    /// whose beam ranges meet and agree within [`TURN_FUSE_ALPHA_DEG`] and
    /// [`TURN_FUSE_R`]). Corners (§8) are formed on the fused lines. `false`
    /// runs the whole scan at once (v1, v2); 1° modes are the same either way.
    ///
    /// Only with feature `section10` (host crates; not the firmware):
    /// otherwise `true` fails validation ([`ParamError::NotInBuild`]).
    pub per_turn: bool,
    /// Merge across rejected segments (ALGORITHM.md §10 (e),
    /// docs/ALGORITHM.md §7.6): two consecutive accepted
    /// lines merge whatever lies between them when the refit of their union
    /// (the beams between included) passes `max_chi2` and each line's own
    /// beams fit the union line within `max_chi2` too (from each line's own
    /// fit, `crate::pipeline::merge`). A wall that grazing
    /// stair-steps cut into a long line and short pieces is one line again.
    /// Default on; `false` is §7.6 as written (v1, v2).
    pub bridge_merge: bool,
    /// Beam-footprint term κ of the range noise (rad; ALGORITHM.md §10 (f),
    /// docs/ALGORITHM.md §7.2): a beam at range `d` meeting
    /// a surface at incidence `θ` has `σ_j² = σ² + (κ·d·tan θ)²` (the sensor
    /// model fitted to the shared logs: κ = 0.7–4.7 mrad). The fits of §7
    /// (and the straightness test of split before reject, and §7.6) weight
    /// each beam by `σ²/σ_j²` at the line's incidence, so the covariance and
    /// χ² follow the same model; the windows of §3 are unchanged (their
    /// grazing term is `grazing_noise`, `ρ = κ/γ`). Default
    /// [`DEFAULT_FOOTPRINT`] (3 mrad, measured best of 2–5 mrad); `0` is §7
    /// as written (v1, v2).
    pub footprint: f32,
    /// Fewest consecutive lines taken for an arc — a pillar, a curved wall,
    /// cut into a polyline — and dropped (`Stats::rejected_arc`; beyond
    /// ALGORITHM.md, `crate::pipeline::arcs`): each line's
    /// facing end within `corner_gap` of the next one's, each turning the
    /// same way as the last by `arc_min_turn_deg`..=`arc_max_turn_deg`. A
    /// polyline on a curve is no wall and its "corners" are none. Default 3
    /// (on the realistic synthetic scenes FalsePos 0.160 → 0.144 at 10 mm,
    /// 0.133 → 0.124 at 20 mm, TruePos and the real logs unchanged; two
    /// lines alone cannot be told from an obtuse corner); 0 keeps every
    /// line (v1, v2).
    pub arc_chain: u8,
    /// Smallest turn between consecutive lines of an arc (degrees): a
    /// gentler bend is one wall's roughness. Default 5.
    pub arc_min_turn_deg: f32,
    /// Largest turn between consecutive lines of an arc (degrees): a
    /// sharper one is a corner. Default 40.
    pub arc_max_turn_deg: f32,
    /// Work bound of split before reject per frame, in beams: the sum of
    /// the beams of the pieces it tests (each test is up to a weighted fit
    /// over the piece). A piece that would take the sum past it is not
    /// tested: it goes to §7 whole, which fits it once and applies the χ²
    /// gate, as v1 does. Bounds the MCU's instructions per scan whatever
    /// the data (docs/DESIGN.md, windows and split before reject). Default 542 (one
    /// and a half 361-beam scans); 0 is no bound.
    pub split_budget: u16,
    /// Anchor gate of the merges (χ²₂; beyond ALGORITHM.md,
    /// docs/ALGORITHM.md §7.6): §7.6 and §10 (e) merge two
    /// lines only if the union line stays within this Mahalanobis distance
    /// of the larger line's own parameters, under that line's covariance
    /// scaled by its own χ² per point where that is above 1
    /// (`crate::pipeline::merge`). A long line does not take in a short
    /// piece at a bend that moves its α by many of its own σ (on the
    /// realistic synthetic scenes σΔα/CRB 1.43 → 1.15 at 10 mm, 2.21 → 1.25
    /// at 20 mm). Default [`DEFAULT_MERGE_ANCHOR_GATE`] (χ²₂ at 99.9 %);
    /// `+inf` is no test.
    pub merge_anchor_gate: f32,
    /// The fits' χ² allows an offset between the interleaved mirror turns
    /// (ALGORITHM.md §10.4, docs/ALGORITHM.md §7.3): in the
    /// 0.5° (0.25°) modes the platform moves between the turns 13.3 ms
    /// apart, and a wall's beams lie on two (four) parallel point sets a few
    /// mm to cm apart. Each turn's weighted mean residual is taken out of
    /// `Σe²` before §7.4's χ² gate, the straightness test of split before
    /// reject and the merges' refits, with `turns − 1` fewer degrees of
    /// freedom ([`crate::pipeline::line_fit::residual_dof`]); the line and
    /// its covariance are the fit of all beams, as before. 1° modes are the
    /// same either way. Default on; `false` is §7 as written.
    pub turn_offsets: bool,
    /// Nested-model test of the merges (an F threshold; beyond ALGORITHM.md,
    /// docs/ALGORITHM.md Appendix A): two lines are
    /// merged only if one line explains their beams not significantly worse
    /// than the two, `F = ((S₁ − S₂)/2) / (S₂/(m − 4)) ≤ merge_f_test`, with
    /// `S₁` the union's weighted residual sum, `S₂` the two lines' own, `m`
    /// their points (`crate::pipeline::merge`). Symmetric in the two lines,
    /// where the anchor gate guards the larger only. 0 is no test (the
    /// default).
    pub merge_f_test: f32,
    /// Two lines alone can be a curve too (beyond ALGORITHM.md,
    /// docs/ALGORITHM.md §7.8): a pair of
    /// consecutive lines linked as in an arc chain (`arc_chain`, whose
    /// `0` turns this off too) is dropped with its lines counted in
    /// `Stats::rejected_arc` when a circle through their beams explains
    /// them within the noise and better than the two lines do by χ²₁'s 95 %
    /// quantile (`crate::pipeline::arcs`); a corner between two straight
    /// walls does not pass. Default on; `false`: pairs are kept.
    pub arc_pairs: bool,
    /// The merges refit the two lines' own beams (beyond ALGORITHM.md v2,
    /// docs/ALGORITHM.md §7.6): where the gates of §7.6 vouch for a pair (at
    /// most `merge_gap_beams` usable beams between them, parameter distance
    /// below `merge_gate`), the union line is fitted to the usable beams of
    /// both lines with the beams between them left out — the beams where
    /// `D` crossed τ and broke the segment, a corner beam the fits leave
    /// out — and the gaps a merged line holds stay out of its later refits
    /// (up to [`crate::pipeline::line_fit::MAX_HOLES`]). The union's χ², the
    /// parts' χ² and the anchor gate are those of that fit. Default on
    /// (settled real truth FalsePos 0.133 → 0.112, walls fragmented 63 → 37
    /// of 459, synthetic figures within 0.001); `false`: the union is
    /// fitted to every usable beam from the first line's first to the
    /// second's last (preset `v3.0`).
    pub merge_own_beams: bool,
    /// Each line takes the noise model its beams are likelier under
    /// (beyond ALGORITHM.md v2, docs/ALGORITHM.md §7.9): after the arcs,
    /// a line fitted with the footprint term (`footprint` > 0) is refitted
    /// with every beam at σ, and the refit replaces it where
    /// `S_plain ≤ S + Λ` — the residual sums (χ²·dof) of the two fits, `Λ =
    /// Σ ln(1 + (κ·d·tan θ/σ)²)` the log of the footprint model's variances
    /// over σ² — a likelihood ratio between the two noise models. A sensor
    /// without a footprint (plain Gaussian noise) then gets the efficient
    /// fit; a real LMS, whose grazing beams scatter, keeps the weighted one.
    /// The decisions (segments, merges, gates) are those of the weighted
    /// fits. Default on (plain Gaussian 10 mm σΔα/CRB 1.37 → 1.14, real
    /// and realistic figures within 0.001–0.01); `false`: every line keeps
    /// the footprint weights (preset `v3.2`).
    pub footprint_choice: bool,
}

/// Pairing gate of [`Params::per_turn`] on |Δα| between two turns' lines
/// (degrees): the evaluation's matching gate, under which the turns' lines
/// of one wall differ by the platform's motion in 13.3 ms.
pub const TURN_FUSE_ALPHA_DEG: f32 = 3.0;

/// Pairing gate of [`Params::per_turn`] on |Δr| (m); see
/// [`TURN_FUSE_ALPHA_DEG`].
pub const TURN_FUSE_R: f32 = 0.1;

/// The default [`Params::footprint`] (rad): the best of 2, 3, 4 and 5 mrad
/// on the real logs' map truth and the realistic synthetic scenes
/// (`cargo run --release -p lms-lab --example footprint_sweep`).
pub const DEFAULT_FOOTPRINT: f32 = 0.003;

/// The default [`Params::merge_anchor_gate`]: the 99.9 % quantile of χ²
/// with two degrees of freedom, as split before reject's straightness test
/// takes 99.9 % (measured against 4.61–13.8 and per part:
/// `cargo run --release -p lms-lab --example merge_anchor_sweep`).
pub const DEFAULT_MERGE_ANCHOR_GATE: f32 = 13.815_51;

/// Largest incidence (degrees) the grazing term of
/// [`Params::grazing_noise`] follows; a window whose outer ranges differ
/// more (a jump edge) gets the term of this incidence.
pub const GRAZING_MAX_INCIDENCE_DEG: f32 = 80.0;

impl Default for Params {
    fn default() -> Self {
        Params::DEFAULT
    }
}

impl Params {
    /// The range noise of the line fits (m): `fit_sigma`, or `sigma` if 0
    /// (always `sigma` without feature `section10`, where validation keeps
    /// `fit_sigma` at 0).
    #[inline]
    pub const fn line_sigma(&self) -> f32 {
        if cfg!(feature = "section10") && self.fit_sigma > 0.0 {
            self.fit_sigma
        } else {
            self.sigma
        }
    }

    /// The defaults, usable in `const` contexts (preset `default`):
    /// ALGORITHM.md v2 with the project's measured additions
    /// (`merge_collinear`, `max_alpha_sd_deg`, `bridge_merge` and
    /// `footprint` (§10 (e) and (f)), `arc_chain`, `same_turn_windows`,
    /// `split_budget`, `merge_anchor_gate`, `turn_offsets`, `arc_pairs` and
    /// `merge_own_beams`), and the scale the MCU keeps up with: 5 passes
    /// with the segmentation gate τ = 12.
    pub const DEFAULT: Params = Params {
        sigma: 0.005,
        q: 0.0,
        iterations: 5,
        tau: 12.0,
        min_points: 5,
        max_chi2: 4.0,
        min_length: 0.1,
        fit_shared_points: false,
        merge: true,
        merge_gap_beams: 3,
        merge_gate: 9.21,
        corner_gap: 0.2,
        min_corner_angle_deg: 30.0,
        split_depth: 8,
        max_range: max_range_of(crate::Unit::Centimetre, RangeMode::Bits13),
        merge_collinear: true,
        max_alpha_sd_deg: 5.0 / 3.0,
        grazing_noise: 0.0,
        same_turn_windows: true,
        fit_sigma: 0.0,
        per_turn: false,
        bridge_merge: true,
        footprint: DEFAULT_FOOTPRINT,
        arc_chain: 3,
        arc_min_turn_deg: 5.0,
        arc_max_turn_deg: 40.0,
        split_budget: 542,
        merge_anchor_gate: DEFAULT_MERGE_ANCHOR_GATE,
        turn_offsets: true,
        merge_f_test: 0.0,
        arc_pairs: true,
        merge_own_beams: true,
        footprint_choice: true,
    };

    /// The defaults with every line keeping the footprint weights (preset
    /// `v3.2`, `footprint_choice = false`): ALGORITHM.md v3.2.
    pub const V3_2: Params = Params {
        footprint_choice: false,
        ..Params::DEFAULT
    };

    /// [`Params::V3_2`] at 30 smoothing passes with the segmentation gate
    /// τ = 9 (preset `v3.1`): ALGORITHM.md v3.1, too slow for the MCU to
    /// keep up with the sensor.
    pub const V3_1: Params = Params {
        iterations: 30,
        tau: 9.0,
        ..Params::V3_2
    };

    /// [`Params::V3_1`] with the merges refitting every usable beam from
    /// the first line's first to the second line's last (preset `v3.0`,
    /// `merge_own_beams = false`): ALGORITHM.md v3.0.
    pub const V3_0: Params = Params {
        merge_own_beams: false,
        ..Params::V3_1
    };

    /// ALGORITHM.md v2 (preset `v2`) with `merge_collinear` and the σ_α
    /// gate: windows of consecutive beams, every beam at `sigma`, §7.6
    /// merging only across `merge_gap_beams`, no arcs dropped, §7's χ² as
    /// written, no anchor gate and no work bound on split before reject.
    pub const V2: Params = Params {
        same_turn_windows: false,
        bridge_merge: false,
        footprint: 0.0,
        arc_chain: 0,
        split_budget: 0,
        merge_anchor_gate: f32::INFINITY,
        turn_offsets: false,
        arc_pairs: false,
        merge_own_beams: false,
        ..Params::V3_1
    };

    /// The seed paper's method, ALGORITHM.md v1 (preset `paper`): [`Params::V2`]
    /// without split before reject, with shared corner points in both fits,
    /// no range limit beyond the sensor's error codes, no collinear merge and
    /// no σ_α gate.
    pub const PAPER: Params = Params {
        fit_shared_points: true,
        split_depth: 0,
        max_range: f32::INFINITY,
        merge_collinear: false,
        max_alpha_sd_deg: f32::INFINITY,
        ..Params::V2
    };
}

/// Whether this build of the core has the ALGORITHM.md §10 options
/// (feature `section10`; [`ParamError::NotInBuild`] without it).
pub const SECTION10_BUILT: bool = cfg!(feature = "section10");

/// Largest accepted number of smoothing passes.
pub const MAX_ITERATIONS: u16 = 1000;

/// Largest accepted [`Params::split_depth`].
pub const MAX_SPLIT_DEPTH: u8 = 16;

// The ranges of the declaration ([`FIELDS`]) take these two limits.
const _: () = {
    let d = Params::DEFAULT;
    assert!(d.with_iterations(MAX_ITERATIONS).out_of_range().is_none());
    assert!(d
        .with_iterations(MAX_ITERATIONS + 1)
        .out_of_range()
        .is_some());
    assert!(d.with_split_depth(MAX_SPLIT_DEPTH).out_of_range().is_none());
    assert!(d
        .with_split_depth(MAX_SPLIT_DEPTH + 1)
        .out_of_range()
        .is_some());
};

/// A parameter that makes no sense; names the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ParamError {
    /// A field outside its own range ([`Field::range`] of [`FIELDS`]).
    OutOfRange {
        /// The field of [`Params`].
        name: &'static str,
        /// The values it takes, e.g. "finite and > 0".
        range: &'static str,
    },
    /// `arc_chain` must be 0 or ≥ 2, and `0 ≤ arc_min_turn_deg ≤
    /// arc_max_turn_deg ≤ 180`.
    Arc,
    /// An ALGORITHM.md §10 option (one of [`HOST_ONLY`], named by
    /// `option`) has a non-default value, but this build of the core leaves
    /// the §10 options out (feature `section10` off, as in the firmware).
    NotInBuild {
        /// The field of [`Params`].
        option: &'static str,
    },
    /// No parameter of that name ([`Params::set`]; the names are those of
    /// [`FIELDS`]).
    UnknownName,
    /// A value that does not read as the parameter's type ([`Params::set`]).
    BadValue {
        /// The field of [`Params`].
        name: &'static str,
        /// What it takes, e.g. "true or false".
        expected: &'static str,
    },
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::OutOfRange { name, range } => {
                write!(f, "{name} must be {range}")?;
                match field(name).and_then(Field::shown_unit) {
                    Some(unit) => write!(f, " ({unit})"),
                    None => Ok(()),
                }
            }
            ParamError::BadValue { name, expected } => write!(f, "{name} must be {expected}"),
            ParamError::NotInBuild { option } => write!(
                f,
                "{option} is an ALGORITHM.md §10 option that this build leaves out \
                 (lms-core without feature `section10`, as in the firmware): leave it at its default"
            ),
            ParamError::Arc => f.write_str(
                "arc_chain must be 0 (off) or at least 2, and 0 <= arc_min_turn_deg <= \
                 arc_max_turn_deg <= 180 (degrees)",
            ),
            ParamError::UnknownName => f.write_str("no parameter of that name"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ParamError {}

/// Parameters that passed [`Params::validate`]: the only kind the pipeline
/// takes, so it never checks them again. Read the fields through `Deref`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValidParams(Params);

impl ValidParams {
    /// The defaults of ALGORITHM.md (valid by construction), `const`.
    pub const DEFAULT: ValidParams = ValidParams(Params::DEFAULT);

    /// Every field zero — not valid, never given to the pipeline: the
    /// placeholder of a co-processor not configured yet, so that a `static`
    /// of it is all zero bytes (`.bss`, no flash image).
    pub(crate) const UNSET: ValidParams = ValidParams(Params {
        sigma: 0.0,
        q: 0.0,
        iterations: 0,
        tau: 0.0,
        min_points: 0,
        max_chi2: 0.0,
        min_length: 0.0,
        fit_shared_points: false,
        merge: false,
        merge_gap_beams: 0,
        merge_gate: 0.0,
        corner_gap: 0.0,
        min_corner_angle_deg: 0.0,
        split_depth: 0,
        max_range: 0.0,
        merge_collinear: false,
        max_alpha_sd_deg: 0.0,
        grazing_noise: 0.0,
        same_turn_windows: false,
        fit_sigma: 0.0,
        per_turn: false,
        bridge_merge: false,
        footprint: 0.0,
        arc_chain: 0,
        arc_min_turn_deg: 0.0,
        arc_max_turn_deg: 0.0,
        split_budget: 0,
        merge_anchor_gate: 0.0,
        turn_offsets: false,
        merge_f_test: 0.0,
        arc_pairs: false,
        merge_own_beams: false,
        footprint_choice: false,
    });

    /// The parameters.
    #[inline]
    pub const fn get(&self) -> &Params {
        &self.0
    }
}

impl Default for ValidParams {
    fn default() -> Self {
        ValidParams::DEFAULT
    }
}

impl core::ops::Deref for ValidParams {
    type Target = Params;
    #[inline]
    fn deref(&self) -> &Params {
        &self.0
    }
}

impl TryFrom<Params> for ValidParams {
    type Error = ParamError;
    fn try_from(params: Params) -> Result<Self, ParamError> {
        params.validate()
    }
}

impl From<ValidParams> for Params {
    fn from(valid: ValidParams) -> Params {
        valid.0
    }
}

impl Params {
    /// Check every field; the first nonsense found is returned, else the
    /// parameters as [`ValidParams`].
    pub const fn validate(&self) -> Result<ValidParams, ParamError> {
        if let Some((name, range)) = self.out_of_range() {
            return Err(ParamError::OutOfRange { name, range });
        }
        let turns_ok = self.arc_min_turn_deg >= 0.0
            && self.arc_min_turn_deg <= self.arc_max_turn_deg
            && self.arc_max_turn_deg <= 180.0;
        if self.arc_chain == 1 || !turns_ok {
            return Err(ParamError::Arc);
        }
        if let Some(option) = self.option_not_in_build() {
            return Err(ParamError::NotInBuild { option });
        }
        Ok(ValidParams(*self))
    }

    /// The ALGORITHM.md §10 option set to a non-default value that this
    /// build leaves out (feature `section10` off), if any: never a silent
    /// difference. It checks exactly the parameters of [`HOST_ONLY`].
    const fn option_not_in_build(&self) -> Option<&'static str> {
        if cfg!(feature = "section10") {
            None
        } else {
            self.host_only_changed()
        }
    }
}
