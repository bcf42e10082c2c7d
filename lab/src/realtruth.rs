//! Real scans against the map-derived truth of [`crate::maptruth`]: per
//! log and method, TruePos, FalsePos, lines on no map wall, coverage, the
//! errors Δα and Δr, repeatability and fragmentation.
//!
//! # Matching
//! A line and a true piece are a candidate pair if at least half of the
//! line's beam range `first..=last` lies in the piece's, `|Δα| < 3°` and
//! `|Δr| < 0.1 m` ([`GATE_ALPHA_DEG`], [`GATE_R`]; Δr at the foot of the
//! normal, or with [`crate::maptruth::TruthConfig::range_gate_at_middle`]
//! at the line's middle); pairs are taken
//! one-to-one, greedily by `(Δα/3°)² + (Δr/0.1 m)²`.
//!
//! # Figures
//! * **TruePos** = matched counted pieces / counted pieces (≥ 10 beams on
//!   the wall); also over the counted pieces of 1 m or more.
//! * **FalsePos** = lines matched to no piece (counted or not) / lines;
//!   with the truth's `neutral_and_unexplained` rules
//!   ([`crate::maptruth::TruthConfig::settled`]), false / (false + true)
//!   lines, unexplained and neutral lines apart ([`classify_lines`]).
//! * **Unexplained**: unmatched lines with at least half of their beams on
//!   no map wall or invalid, as a share of the lines.
//! * **On no wall**: lines with fewer than half of the valid beams of
//!   their range on a map wall, as a share of the lines (clutter, glass,
//!   walls under 0.5 m: things the map does not hold); *FalsePos on walls*
//!   is FalsePos among the other lines.
//! * **Coverage** = on-wall beams of counted pieces inside their matched
//!   line's range / on-wall beams of counted pieces.
//! * **σΔα, σΔr**: sample standard deviations over matched counted pieces
//!   (the truth's own error is the oracle's figure).
//! * **Repeatability**: of the walls matched in a frame and counted in the
//!   next evaluated frame, the share matched there too.
//! * **Fragmented**: counted pieces with two or more candidate lines (a
//!   wall reported as several lines), as a share of counted pieces; and the
//!   walls (with at least [`MIN_SIGHTINGS`] counted sightings) fragmented in
//!   more than 5 % of their sightings.
//!
//! # Methods
//! `no flags` is what `host-bridge extract LOG` does without options
//! ([`no_flag_params`]: the defaults with σ and `max_range` from the data).
//! The rows below it turn groups of the defaults' decisions off, each on
//! top of the one before ([`crate::ablation`]): `v3.0`, the merges
//! refitting every beam between the lines ([`Params::V3_0`]); pairs of
//! lines on a curve kept; then no anchor gate on the merges and no turn offsets in the fits'
//! χ²; then windows of consecutive beams and no work bound on split before
//! reject (the same figures as with every line of an arc kept too: no line
//! of these logs is dropped as an arc); `v2` is [`Params::V2`] (no
//! footprint weights, no bridge merge either); `paper` is
//! [`Params::PAPER`], ALGORITHM.md v1. `σ by unit` is 10 mm for cm logs
//! and 5 mm for mm logs ([`crate::real::sigma_for`]); the oracle is a
//! total-least-squares fit to each counted piece's own on-wall hits — what
//! an extractor that knew the walls would report, so its TruePos is the
//! ceiling of this truth and its σ the truth's own error.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use host_bridge::carmen::{self, Scan, Unit, UnitMode};
use host_bridge::options::UnitArg;
use lms_core::{Extractor, Line, Params};

use crate::ablation;
use crate::baselines::{self, run_core, Extraction, Tables};
use crate::maptruth::{
    build_map, frame_truth, frame_truth_registered, register_log, FrameTruth, Map, TruthConfig,
};
use crate::metrics::{mean, std_dev};
use crate::report::f;

/// Matching gate on |Δα| (degrees).
pub const GATE_ALPHA_DEG: f64 = 3.0;
/// Matching gate on |Δr| (m).
pub const GATE_R: f64 = 0.1;
/// Smallest fraction of a line's beam range inside the piece's.
pub const GATE_OVERLAP: f64 = 0.5;
/// Counted sightings a wall needs to enter the per-wall fragmentation figure.
pub const MIN_SIGHTINGS: usize = 5;
/// Share of a wall's sightings it may be fragmented in (the goal).
pub const FRAGMENT_GOAL: f64 = 0.05;

/// The parameters `host-bridge extract LOG` uses without options: the
/// defaults for the log's data ([`host_bridge::defaults::for_log`]).
pub fn no_flag_params(path: &Path) -> Result<Params> {
    let args = host_bridge::options::ParamArgs::default();
    match host_bridge::defaults::for_log(path, UnitArg::Auto, &args)? {
        Some((params, _)) => Ok(params),
        None => anyhow::bail!("{}: not a CARMEN log", path.display()),
    }
}

/// A log read for scoring against its map truth.
pub struct LogWithMap {
    /// The log.
    pub log: carmen::CarmenLog,
    /// What `host-bridge extract LOG` uses on it ([`no_flag_params`]).
    pub no_flags: Params,
    /// The truth's settings over the log's ranges ([`TruthConfig::for_data`]).
    pub cfg: TruthConfig,
    /// Its map (steps 1–2 of [`crate::maptruth`]; with
    /// [`TruthConfig::register_rounds`], rebuilt from the registered poses).
    pub map: Map,
    /// Per frame, the laser pose registered to `map` (empty: the SLAM poses).
    pub poses: Vec<[f64; 3]>,
}

impl LogWithMap {
    /// The truth of frame `k` of the log: at its registered pose where
    /// there is one ([`frame_truth_registered`]), else [`frame_truth`].
    pub fn truth(&self, k: usize) -> FrameTruth {
        let scan = &self.log.scans[k];
        match self.poses.get(k) {
            Some(&pose) => frame_truth_registered(scan, &self.map, pose, &self.cfg),
            None => frame_truth(scan, &self.map, &self.cfg),
        }
    }
}

/// Read the log at `path`, its no-flag parameters, and build its map with
/// `cfg` limited to the ranges the extraction uses.
pub fn load_with_map(path: &Path, cfg: &TruthConfig) -> Result<LogWithMap> {
    let log = carmen::read_log(path, UnitMode::Auto)?;
    let no_flags = no_flag_params(path)?;
    let cfg = cfg.for_data(no_flags.max_range);
    let map = build_map(&log.scans, &cfg);
    let (map, poses) = if cfg.register_rounds > 0 {
        register_log(&log.scans, map, &cfg)
    } else {
        (map, Vec::new())
    };
    Ok(LogWithMap {
        log,
        no_flags,
        cfg,
        map,
        poses,
    })
}

/// `preset` (a set of [`crate::ablation`], say) on the data of `data`: its σ
/// and range limit, the only fields in which the per-data defaults
/// ([`no_flag_params`]) and the synthetic scenes' σ₀ differ from
/// [`Params::DEFAULT`].
pub fn on_data(preset: Params, data: Params) -> Params {
    preset.with_sigma(data.sigma).with_max_range(data.max_range)
}

/// Which parameters a method starts from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Base {
    /// As without flags ([`no_flag_params`]: the defaults, per data).
    NoFlags,
    /// ALGORITHM.md v1's defaults ([`Params::PAPER`]: σ = 5 mm, no split
    /// before reject, shared corner points, no range limit).
    Paper,
}

/// How a method picks σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SigmaChoice {
    /// The base's σ.
    Base,
    /// [`crate::real::sigma_for`] of the log's unit (10 mm cm, 5 mm mm).
    ByUnit,
    /// A fixed σ (m).
    Fixed(f64),
}

/// What a method runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RealKind {
    /// The core.
    Core,
    /// Split-and-merge with threshold `k·σ`.
    SplitMerge(f32),
    /// The least-squares fit to each true piece's own beams.
    Oracle,
}

/// One method of the real-scan evaluation.
#[derive(Clone, Copy, Debug)]
pub struct RealMethod {
    /// Name in the tables.
    pub name: &'static str,
    /// What it runs.
    pub kind: RealKind,
    /// The parameters it starts from.
    pub base: Base,
    /// σ.
    pub sigma: SigmaChoice,
    /// Changes after σ (identity for most methods).
    pub adjust: fn(Params) -> Params,
}

impl RealMethod {
    /// The core at the no-flag parameters on the data, changed by `adjust`.
    pub fn no_flags_with(name: &'static str, adjust: fn(Params) -> Params) -> Self {
        RealMethod {
            name,
            kind: RealKind::Core,
            base: Base::NoFlags,
            sigma: SigmaChoice::Base,
            adjust,
        }
    }

    /// The parameters on a log in `unit` whose no-flag parameters are `no_flags`.
    pub fn params(&self, unit: Unit, no_flags: &Params) -> Params {
        let base = match self.base {
            Base::NoFlags => *no_flags,
            Base::Paper => Params::PAPER,
        };
        let sigma = match self.sigma {
            SigmaChoice::Base => base.sigma,
            SigmaChoice::ByUnit => crate::real::sigma_for(unit) as f32,
            SigmaChoice::Fixed(s) => s as f32,
        };
        (self.adjust)(base.with_sigma(sigma))
    }
}

/// Name of the no-flags method.
pub const NO_FLAGS: &str = "defaults, no flags (per data)";
/// Name of the defaults with pairs of lines on a curve kept
/// ([`crate::ablation::ARC_PAIRS_KEPT`]).
pub const ARC_PAIRS_KEPT: &str = ablation::ARC_PAIRS_KEPT_NAME;
/// Name of [`ARC_PAIRS_KEPT`] with no anchor gate on the merges and no
/// turn offsets in the fits' χ² ([`crate::ablation::NO_ANCHOR_NO_OFFSETS`]).
pub const NO_ANCHOR_NO_OFFSETS: &str = ablation::NO_ANCHOR_NO_OFFSETS_NAME;
/// Name of [`NO_ANCHOR_NO_OFFSETS`] with windows of consecutive beams over
/// both turns and no work bound on split before reject
/// ([`crate::ablation::CONSECUTIVE_WINDOWS`]). On the real logs every line
/// of an arc kept too ([`crate::ablation::ARC_CHAINS_KEPT`]) gives the same
/// figures: no line of them is dropped as an arc.
pub const CONSECUTIVE_WINDOWS: &str = ablation::CONSECUTIVE_WINDOWS_NAME;
/// Name of ALGORITHM.md v3.2's defaults on the data ([`Params::V3_2`]:
/// every line keeps its footprint-weighted fit).
pub const V3_2_NO_FLAGS: &str = "v3.2 (--preset v3.2, σ per data)";
/// Name of ALGORITHM.md v3.1's defaults on the data ([`Params::V3_1`]: 30
/// smoothing passes, τ = 9).
pub const V3_1_NO_FLAGS: &str = "v3.1 (--preset v3.1, σ per data)";
/// Name of ALGORITHM.md v3.0's defaults on the data ([`Params::V3_0`]:
/// the merges refit every beam between the lines).
pub const V3_0_NO_FLAGS: &str = "v3.0 (--preset v3.0, σ per data)";
/// Name of ALGORITHM.md v2's defaults on the data ([`Params::V2`]: no
/// footprint weights, no merge across rejected segments either).
pub const V2_NO_FLAGS: &str = "v2 (--preset v2, σ per data)";
/// Name of ALGORITHM.md v1's defaults ([`Params::PAPER`]).
pub const PAPER_NO_FLAGS: &str = "paper (--preset paper, σ 5 mm)";
/// Name of per-turn extraction (`Params::per_turn`) at the no-flag parameters.
pub const PER_TURN: &str = "defaults, per_turn=true";
/// Name of the split-and-merge baseline.
pub const SPLIT_MERGE: &str = "split-and-merge (4σ), σ by unit";
/// Name of the oracle.
pub const ORACLE: &str = "oracle (LS fit to the true beams)";

/// The methods of the real-scan tables.
pub fn methods() -> Vec<RealMethod> {
    let m = |name, kind, base, sigma| RealMethod {
        name,
        kind,
        base,
        sigma,
        adjust: |p| p,
    };
    // The defaults per data with changes (docs/DESIGN.md).
    let g = RealMethod::no_flags_with;
    use Base::{NoFlags, Paper};
    use RealKind::*;
    use SigmaChoice::{ByUnit, Fixed};
    let own = SigmaChoice::Base;
    vec![
        m(NO_FLAGS, Core, NoFlags, own),
        g(V3_2_NO_FLAGS, |p| on_data(Params::V3_2, p)),
        g(V3_1_NO_FLAGS, |p| on_data(Params::V3_1, p)),
        g(V3_0_NO_FLAGS, |p| on_data(Params::V3_0, p)),
        g(ARC_PAIRS_KEPT, |p| on_data(ablation::ARC_PAIRS_KEPT, p)),
        g(NO_ANCHOR_NO_OFFSETS, |p| {
            on_data(ablation::NO_ANCHOR_NO_OFFSETS, p)
        }),
        g(CONSECUTIVE_WINDOWS, |p| {
            on_data(ablation::CONSECUTIVE_WINDOWS, p)
        }),
        g(V2_NO_FLAGS, |p| on_data(Params::V2, p)),
        m(PAPER_NO_FLAGS, Core, Paper, own),
        m("paper, σ by unit (10 mm cm, 5 mm mm)", Core, Paper, ByUnit),
        m("defaults, σ by unit", Core, NoFlags, ByUnit),
        m("defaults, σ = 20 mm", Core, NoFlags, Fixed(0.02)),
        m("defaults, σ = 30 mm", Core, NoFlags, Fixed(0.03)),
        m(SPLIT_MERGE, SplitMerge(4.0), NoFlags, ByUnit),
        g("defaults, grazing_noise=0.5", |p| p.with_grazing_noise(0.5)),
        g("defaults, fit_sigma=1.5σ", |p| {
            p.with_fit_sigma(1.5 * p.sigma)
        }),
        g("defaults, fit_sigma=2σ", |p| {
            p.with_fit_sigma(2.0 * p.sigma)
        }),
        g("defaults, merge_f_test=20", |p| p.with_merge_f_test(20.0)),
        g(PER_TURN, |p| p.with_per_turn(true)),
        g("v2, per_turn=true", |p| {
            (on_data(Params::V2, p)).with_per_turn(true)
        }),
        m(ORACLE, Oracle, NoFlags, own),
    ]
}

/// Accumulated figures of one method on one log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RealTally {
    /// Frames.
    pub frames: usize,
    /// Counted pieces.
    pub pieces: usize,
    /// Counted pieces matched.
    pub matched: usize,
    /// Counted pieces of 1 m or more.
    pub pieces_1m: usize,
    /// Of those, matched.
    pub matched_1m: usize,
    /// Lines.
    pub lines: usize,
    /// Lines matched to a piece.
    pub lines_matched: usize,
    /// Lines on no map wall.
    pub lines_no_wall: usize,
    /// Of those, matched to no piece.
    pub lines_no_wall_false: usize,
    /// Unmatched lines with half their range on a piece (fragments, off lines).
    pub lines_on_piece: usize,
    /// Counted pieces of 0.5 m to 1 m.
    pub pieces_mid: usize,
    /// Of those, matched.
    pub matched_mid: usize,
    /// Counted pieces under 0.5 m.
    pub pieces_short: usize,
    /// Of those, matched.
    pub matched_short: usize,
    /// True lines: matched to a counted piece (with the truth's
    /// `neutral_and_unexplained` rules; else every matched line).
    pub lines_true: usize,
    /// False lines (with those rules: unmatched, neither unexplained nor
    /// neutral; else every unmatched line).
    pub lines_false: usize,
    /// Of the false lines, fragments: at least half of their beams on one
    /// counted piece they do not match (those rules only).
    pub lines_fragment: usize,
    /// Of those, on a piece another line matches (a wall reported twice).
    pub lines_fragment_dup: usize,
    /// Unmatched lines with at least half of their beams on no map wall or
    /// invalid.
    pub lines_unexplained: usize,
    /// Neutral lines (those rules only): matched to an uncounted piece, or
    /// unmatched with at least half of their beams on uncounted pieces or
    /// ambiguous.
    pub lines_neutral: usize,
    /// Counted pieces with two or more candidate lines.
    pub fragmented: usize,
    /// On-wall beams of counted pieces.
    pub wall_beams: usize,
    /// Of those, inside the matched line.
    pub covered_beams: usize,
    /// Δα of matched counted pieces (rad).
    pub d_alpha: Vec<f64>,
    /// Δr of matched counted pieces (m).
    pub d_r: Vec<f64>,
    /// Walls matched in a frame and counted in the next.
    pub repeat_chances: usize,
    /// Of those, matched in the next too.
    pub repeated: usize,
    /// Per wall: (counted sightings, fragmented sightings).
    pub per_wall: HashMap<usize, (usize, usize)>,
    /// Time per frame (ms).
    pub ms: Vec<f64>,
}

/// The figures of a [`RealTally`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RealSummary {
    /// TruePos.
    pub true_pos: f64,
    /// TruePos on pieces ≥ 1 m.
    pub true_pos_1m: f64,
    /// TruePos on pieces of 0.5 m to 1 m.
    pub true_pos_mid: f64,
    /// TruePos on pieces under 0.5 m.
    pub true_pos_short: f64,
    /// FalsePos: false / (false + true) lines.
    pub false_pos: f64,
    /// Unexplained lines / lines.
    pub unexplained: f64,
    /// Neutral lines / lines.
    pub neutral: f64,
    /// Fragments among the false lines.
    pub fragments: f64,
    /// Of the fragments, those on a piece another line matches.
    pub fragments_dup: f64,
    /// Lines on no map wall / lines.
    pub no_wall: f64,
    /// FalsePos among the lines on a map wall (clutter the map lacks left out).
    pub false_pos_on_walls: f64,
    /// Coverage.
    pub coverage: f64,
    /// σΔα (degrees).
    pub sd_alpha_deg: f64,
    /// σΔr (mm).
    pub sd_r_mm: f64,
    /// Repeatability.
    pub repeatability: f64,
    /// Fragmented sightings / counted pieces.
    pub fragmented: f64,
    /// Walls fragmented in > 5 % of their sightings / walls with enough sightings.
    pub walls_fragmented: (usize, usize),
    /// Lines per frame.
    pub lines_per_frame: f64,
    /// Mean ms per frame.
    pub ms: f64,
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

impl RealTally {
    /// Add `o`.
    pub fn merge(&mut self, o: &RealTally) {
        self.frames += o.frames;
        self.pieces += o.pieces;
        self.matched += o.matched;
        self.pieces_1m += o.pieces_1m;
        self.matched_1m += o.matched_1m;
        self.lines += o.lines;
        self.lines_matched += o.lines_matched;
        self.lines_no_wall += o.lines_no_wall;
        self.lines_no_wall_false += o.lines_no_wall_false;
        self.lines_on_piece += o.lines_on_piece;
        self.pieces_mid += o.pieces_mid;
        self.matched_mid += o.matched_mid;
        self.pieces_short += o.pieces_short;
        self.matched_short += o.matched_short;
        self.lines_true += o.lines_true;
        self.lines_false += o.lines_false;
        self.lines_unexplained += o.lines_unexplained;
        self.lines_fragment += o.lines_fragment;
        self.lines_fragment_dup += o.lines_fragment_dup;
        self.lines_neutral += o.lines_neutral;
        self.fragmented += o.fragmented;
        self.wall_beams += o.wall_beams;
        self.covered_beams += o.covered_beams;
        self.d_alpha.extend(&o.d_alpha);
        self.d_r.extend(&o.d_r);
        self.repeat_chances += o.repeat_chances;
        self.repeated += o.repeated;
        // Wall ids are per log: pooled logs keep distinct keys.
        let base = self.per_wall.keys().max().map_or(0, |k| k + 1);
        for (k, v) in &o.per_wall {
            self.per_wall.insert(base + k, *v);
        }
        self.ms.extend(&o.ms);
    }

    /// The figures.
    pub fn summary(&self) -> RealSummary {
        let walls: Vec<&(usize, usize)> = self
            .per_wall
            .values()
            .filter(|(n, _)| *n >= MIN_SIGHTINGS)
            .collect();
        let bad = walls
            .iter()
            .filter(|(n, f)| *f as f64 > FRAGMENT_GOAL * *n as f64)
            .count();
        RealSummary {
            true_pos: ratio(self.matched, self.pieces),
            true_pos_1m: ratio(self.matched_1m, self.pieces_1m),
            true_pos_mid: ratio(self.matched_mid, self.pieces_mid),
            true_pos_short: ratio(self.matched_short, self.pieces_short),
            false_pos: ratio(self.lines_false, self.lines_false + self.lines_true),
            unexplained: ratio(self.lines_unexplained, self.lines),
            neutral: ratio(self.lines_neutral, self.lines),
            fragments: ratio(self.lines_fragment, self.lines_false),
            fragments_dup: ratio(self.lines_fragment_dup, self.lines_fragment),
            no_wall: ratio(self.lines_no_wall, self.lines),
            // A matched line may be "on no wall" too (its piece's beams are
            // mostly off the map line): count only unmatched ones here.
            false_pos_on_walls: ratio(
                self.lines - self.lines_matched - self.lines_no_wall_false,
                self.lines - self.lines_no_wall,
            ),
            coverage: ratio(self.covered_beams, self.wall_beams),
            sd_alpha_deg: std_dev(&self.d_alpha).to_degrees(),
            sd_r_mm: std_dev(&self.d_r) * 1e3,
            repeatability: ratio(self.repeated, self.repeat_chances),
            fragmented: ratio(self.fragmented, self.pieces),
            walls_fragmented: (bad, walls.len()),
            lines_per_frame: ratio(self.lines, self.frames),
            ms: mean(&self.ms),
        }
    }
}

/// A line as the scoring sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScoredLine {
    /// Normal direction (rad).
    pub alpha: f64,
    /// Distance (m).
    pub r: f64,
    /// First beam.
    pub first: usize,
    /// Last beam (inclusive).
    pub last: usize,
    /// Middle of the line in the sensor frame (m): the mean of its
    /// endpoints (where a Δr measured at the line is taken,
    /// [`gate_offsets`]).
    pub middle: [f64; 2],
}

impl From<&Line> for ScoredLine {
    fn from(l: &Line) -> Self {
        let [p, q] = l.endpoints;
        ScoredLine {
            alpha: f64::from(l.alpha),
            r: f64::from(l.r),
            first: usize::from(l.first),
            last: usize::from(l.last),
            middle: [
                (f64::from(p[0]) + f64::from(q[0])) / 2.0,
                (f64::from(p[1]) + f64::from(q[1])) / 2.0,
            ],
        }
    }
}

/// Fraction of `first..=last` inside `pf..=pl`.
pub fn overlap(first: usize, last: usize, pf: usize, pl: usize) -> f64 {
    beams_inside(first, last, pf, pl) as f64 / (last - first + 1) as f64
}

/// How many beams of `first..=last` lie inside `pf..=pl`.
fn beams_inside(first: usize, last: usize, pf: usize, pl: usize) -> usize {
    let lo = first.max(pf);
    let hi = last.min(pl);
    if hi < lo {
        0
    } else {
        hi - lo + 1
    }
}

/// The share of `l`'s beam range inside piece `p`'s, [`overlap`]; with
/// the truth's [`crate::maptruth::TruthConfig::overlap_without_ambiguous`],
/// of its range less its ambiguous beams outside the piece.
pub fn overlap_in(truth: &FrameTruth, l: &ScoredLine, p: &crate::maptruth::Piece) -> f64 {
    if !truth.overlap_without_ambiguous || truth.ambiguous.is_empty() {
        return overlap(l.first, l.last, p.first, p.last);
    }
    let neutral = (l.first..=l.last)
        .filter(|&j| (j < p.first || j > p.last) && truth.ambiguous.get(j) == Some(&true))
        .count();
    beams_inside(l.first, l.last, p.first, p.last) as f64 / (l.last - l.first + 1 - neutral) as f64
}

/// `(Δα, Δr)` of a line against a piece of `truth`, if they are a
/// candidate pair: overlap ([`overlap_in`]) and both gates.
pub fn candidate(
    truth: &FrameTruth,
    l: &ScoredLine,
    p: &crate::maptruth::Piece,
) -> Option<(f64, f64)> {
    if overlap_in(truth, l, p) < GATE_OVERLAP {
        return None;
    }
    let offsets = gate_offsets(l, p.reference(), p.gate_at_middle);
    within_gates(offsets).then_some(offsets)
}

/// `(Δα, Δr)` of `l` against the line `reference = (α, r)`: Δα wrapped,
/// Δr signed, `l.r − r` at the foot of the normal (the default gate) or,
/// `at_middle`, the distance of `l.middle` from the reference line,
/// `middle·n − r`, where the line is
/// ([`crate::maptruth::TruthConfig::range_gate_at_middle`]). The two agree
/// for parallel lines.
pub fn gate_offsets(l: &ScoredLine, reference: (f64, f64), at_middle: bool) -> (f64, f64) {
    let (alpha, r) = reference;
    let da = lms_scene::wrap_angle(l.alpha - alpha);
    let dr = if at_middle {
        l.middle[0] * alpha.cos() + l.middle[1] * alpha.sin() - r
    } else {
        l.r - r
    };
    (da, dr)
}

/// Whether `(Δα, Δr)` passes the matching gates, `|Δα| <`
/// [`GATE_ALPHA_DEG`] and `|Δr| <` [`GATE_R`].
pub fn within_gates((da, dr): (f64, f64)) -> bool {
    da.abs() < GATE_ALPHA_DEG.to_radians() && dr.abs() < GATE_R
}

/// The walls of matched counted pieces of a frame.
pub type MatchedWalls = HashSet<usize>;

/// Per piece of a frame, the line matched to it with its `(Δα, Δr)`.
pub type PieceMatches = Vec<Option<(usize, f64, f64)>>;

/// The one-to-one matching of lines to pieces: every candidate pair
/// ([`candidate`]) by cost `(Δα/3°)² + (Δr/0.1 m)²`, cheapest first, each
/// line and each piece taken once. Per piece the matched line with its
/// `(Δα, Δr)`, and per piece the number of candidate lines.
pub fn match_pieces(truth: &FrameTruth, lines: &[ScoredLine]) -> (PieceMatches, Vec<usize>) {
    let mut pairs: Vec<(f64, usize, usize, f64, f64)> = Vec::new();
    let mut candidates = vec![0usize; truth.pieces.len()];
    for (i, l) in lines.iter().enumerate() {
        for (k, p) in truth.pieces.iter().enumerate() {
            if let Some((da, dr)) = candidate(truth, l, p) {
                candidates[k] += 1;
                let cost = (da / GATE_ALPHA_DEG.to_radians()).powi(2) + (dr / GATE_R).powi(2);
                pairs.push((cost, i, k, da, dr));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut line_of = vec![None; truth.pieces.len()];
    let mut used = vec![false; lines.len()];
    for &(_, i, k, da, dr) in &pairs {
        if used[i] || line_of[k].is_some() {
            continue;
        }
        used[i] = true;
        line_of[k] = Some((i, da, dr));
    }
    (line_of, candidates)
}

/// Score `lines` of a frame against `truth`, adding to `t`; returns the
/// walls of matched counted pieces and, per line, whether it is matched.
pub fn score_frame(
    truth: &FrameTruth,
    lines: &[ScoredLine],
    valid: &[bool],
    t: &mut RealTally,
) -> (MatchedWalls, Vec<bool>) {
    let (line_of, candidates) = match_pieces(truth, lines);
    let mut used = vec![false; lines.len()];
    for &(i, _, _) in line_of.iter().flatten() {
        used[i] = true;
    }
    t.frames += 1;
    t.lines += lines.len();
    t.lines_matched += used.iter().filter(|&&u| u).count();
    classify_lines(truth, lines, valid, &line_of, t);
    for (i, l) in lines.iter().enumerate() {
        let in_range = (l.first..=l.last.min(valid.len().saturating_sub(1)))
            .filter(|&j| valid[j])
            .collect::<Vec<_>>();
        let on = in_range
            .iter()
            .filter(|&&j| truth.on_wall[j].is_some())
            .count();
        if 2 * on < in_range.len().max(1) {
            t.lines_no_wall += 1;
            t.lines_no_wall_false += usize::from(!used[i]);
        } else if !used[i]
            && truth
                .pieces
                .iter()
                .any(|p| overlap(l.first, l.last, p.first, p.last) >= GATE_OVERLAP)
        {
            t.lines_on_piece += 1;
        }
    }
    let mut walls = MatchedWalls::new();
    for (k, p) in truth.pieces.iter().enumerate() {
        if !p.counted {
            continue;
        }
        t.pieces += 1;
        let long = p.length >= 1.0;
        t.pieces_1m += usize::from(long);
        let (mid, short) = (!long && p.length >= 0.5, p.length < 0.5);
        t.pieces_mid += usize::from(mid);
        t.pieces_short += usize::from(short);
        let beams: Vec<usize> = (p.first..=p.last)
            .filter(|&j| truth.on_wall[j] == Some(p.line))
            .collect();
        t.wall_beams += beams.len();
        let fragmented = candidates[k] >= 2;
        t.fragmented += usize::from(fragmented);
        let e = t.per_wall.entry(p.line).or_default();
        e.0 += 1;
        e.1 += usize::from(fragmented);
        if let Some((i, da, dr)) = line_of[k] {
            t.matched += 1;
            t.matched_1m += usize::from(long);
            t.matched_mid += usize::from(mid);
            t.matched_short += usize::from(short);
            let l = &lines[i];
            t.covered_beams += beams
                .iter()
                .filter(|&&j| (l.first..=l.last).contains(&j))
                .count();
            t.d_alpha.push(da);
            t.d_r.push(dr);
            walls.insert(p.line);
        }
    }
    (walls, used)
}

/// Each line of a frame as true, false, unexplained or neutral, added to
/// `t`; `line_of[k]` is the line matched to piece `k`.
///
/// A line matched to a counted piece is true. An unmatched line with at
/// least half of the beams of its range on no map wall or invalid is
/// unexplained (clutter, people, structure the map holds as no wall).
/// With the truth's `neutral_and_unexplained` rules, a line matched to an
/// uncounted piece is neutral; an unmatched line with at least half of its
/// beams on one counted piece's line is false (a fragment of a true line
/// it does not match); else one with at least half of its beams on
/// uncounted pieces or ambiguous is neutral; else it is false (across walls
/// or corners). Without those rules every matched line is true and every
/// unmatched one false (the unexplained ones among them).
pub fn classify_lines(
    truth: &FrameTruth,
    lines: &[ScoredLine],
    valid: &[bool],
    line_of: &[Option<(usize, f64, f64)>],
    t: &mut RealTally,
) {
    let n = valid.len().min(truth.on_wall.len());
    let mut piece_of = vec![None; lines.len()];
    for (k, m) in line_of.iter().enumerate() {
        if let Some((i, _, _)) = m {
            piece_of[*i] = Some(k);
        }
    }
    // Per beam: the piece it is on (on the piece's line).
    let mut beam_piece = vec![None; n];
    for (k, p) in truth.pieces.iter().enumerate() {
        for (j, b) in beam_piece
            .iter_mut()
            .enumerate()
            .take((p.last + 1).min(n))
            .skip(p.first)
        {
            if truth.on_wall[j] == Some(p.line) {
                *b = Some(k);
            }
        }
    }
    let ambiguous = |j: usize| truth.ambiguous.get(j).copied().unwrap_or(false);
    for (i, l) in lines.iter().enumerate() {
        let range = l.first.min(n)..(l.last + 1).min(n);
        let beams = range.len().max(1);
        let half = |c: usize| 2 * c >= beams;
        if let Some(k) = piece_of[i] {
            if truth.pieces[k].counted || !truth.neutral_and_unexplained {
                t.lines_true += 1;
            } else {
                t.lines_neutral += 1;
            }
            continue;
        }
        let off = range
            .clone()
            .filter(|&j| !valid[j] || (truth.on_wall[j].is_none() && !ambiguous(j)))
            .count();
        if half(off) {
            t.lines_unexplained += 1;
            if !truth.neutral_and_unexplained {
                t.lines_false += 1;
            }
            continue;
        }
        if !truth.neutral_and_unexplained {
            t.lines_false += 1;
            continue;
        }
        let mut on_piece: HashMap<usize, usize> = HashMap::new();
        let mut neutral = 0;
        for j in range {
            match beam_piece[j] {
                Some(k) if valid[j] => {
                    if truth.pieces[k].counted {
                        *on_piece.entry(k).or_default() += 1;
                    } else {
                        neutral += 1;
                    }
                }
                _ if valid[j] && ambiguous(j) => neutral += 1,
                _ => {}
            }
        }
        let fragment = on_piece.iter().find(|(_, &c)| half(c)).map(|(&k, _)| k);
        if fragment.is_none() && half(neutral) {
            t.lines_neutral += 1;
        } else {
            t.lines_false += 1;
            if let Some(k) = fragment {
                t.lines_fragment += 1;
                t.lines_fragment_dup += usize::from(line_of[k].is_some());
            }
        }
    }
}

/// The oracle's lines: a TLS fit to each counted piece's on-wall hits in
/// the sensor frame.
pub fn oracle_lines(truth: &FrameTruth) -> Vec<ScoredLine> {
    truth
        .pieces
        .iter()
        .filter(|p| p.counted)
        .map(|p| ScoredLine {
            alpha: p.own_alpha,
            r: p.own_r,
            first: p.first,
            last: p.last,
            middle: p.own_middle,
        })
        .collect()
}

/// One method's lines on one frame.
#[allow(clippy::too_many_arguments)]
pub fn extract(
    m: &RealMethod,
    unit: Unit,
    no_flags: &Params,
    ex: &mut Extractor,
    scan: &Scan,
    tables: &Tables,
    truth: &FrameTruth,
) -> Vec<ScoredLine> {
    let p = m.params(unit, no_flags);
    let x: Extraction = match m.kind {
        RealKind::Core => run_core(ex, &scan.frame, &p),
        RealKind::SplitMerge(k) => baselines::split_and_merge(&scan.frame, tables, &p, k),
        RealKind::Oracle => return oracle_lines(truth),
    };
    x.lines.iter().map(ScoredLine::from).collect()
}

/// One log's result.
#[derive(Clone, Debug)]
pub struct LogTruth {
    /// File name.
    pub name: String,
    /// Unit.
    pub unit: Unit,
    /// Frames evaluated.
    pub frames: usize,
    /// Beams per scan (of the log's first scan; 181 in the 1° logs).
    pub beams: usize,
    /// Map walls.
    pub walls: usize,
    /// Map lines (collinear walls are one).
    pub lines: usize,
    /// Counted pieces per frame.
    pub pieces_per_frame: f64,
    /// Of the pieces long enough to count, the share the frame verifies
    /// ([`TruthConfig::verify`]; the old oracle's TruePos).
    pub verified_share: f64,
    /// Per method (order of `methods`).
    pub tallies: Vec<RealTally>,
    /// Figure file, if drawn.
    pub figure: Option<String>,
    /// The truth's settings (over the log's ranges).
    pub truth: TruthConfig,
}

/// Evaluate one log: map, truth per frame, every method.
pub fn run_log(
    path: &Path,
    methods: &[RealMethod],
    every: usize,
    cfg: &TruthConfig,
    figures: Option<&Path>,
) -> Result<LogTruth> {
    let loaded = load_with_map(path, cfg)?;
    let LogWithMap {
        log,
        no_flags,
        cfg,
        map,
        ..
    } = &loaded;
    let no_flags = *no_flags;
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let mut ex = Extractor::new();
    let mut tallies = vec![RealTally::default(); methods.len()];
    let mut prev: Vec<Option<(MatchedWalls, HashSet<usize>)>> = vec![None; methods.len()];
    let mut counted_per_frame = Vec::new();
    let (mut long_enough, mut verified) = (0usize, 0usize);
    let scans: Vec<&Scan> = log.scans.iter().step_by(every.max(1)).collect();
    let indices: Vec<usize> = (0..log.scans.len()).step_by(every.max(1)).collect();
    for (scan, &index) in scans.iter().zip(&indices) {
        let truth = loaded.truth(index);
        let counted: HashSet<usize> = truth
            .pieces
            .iter()
            .filter(|p| p.counted)
            .map(|p| p.line)
            .collect();
        counted_per_frame.push(counted.len());
        for p in &truth.pieces {
            if p.beams >= cfg.min_beams && p.length >= cfg.min_piece {
                long_enough += 1;
                verified += usize::from(p.verified);
            }
        }
        let tables = Tables::for_frame(&scan.frame);
        let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
        for (k, m) in methods.iter().enumerate() {
            let started = Instant::now();
            let lines = extract(m, log.unit, &no_flags, &mut ex, scan, &tables, &truth);
            tallies[k].ms.push(started.elapsed().as_secs_f64() * 1e3);
            let (matched, _) = score_frame(&truth, &lines, &valid, &mut tallies[k]);
            if let Some((pm, _)) = &prev[k] {
                for w in pm {
                    if counted.contains(w) {
                        tallies[k].repeat_chances += 1;
                        tallies[k].repeated += usize::from(matched.contains(w));
                    }
                }
            }
            prev[k] = Some((matched, counted.clone()));
        }
    }
    let figure = match figures {
        Some(dir) => Some(crate::realfigures::draw(
            dir,
            &name,
            (log, &no_flags),
            &scans,
            map,
            methods,
            &|k| loaded.truth(indices[k]),
            &counted_per_frame,
        )?),
        None => None,
    };
    Ok(LogTruth {
        name,
        unit: log.unit,
        frames: scans.len(),
        beams: log.scans.first().map_or(0, |s| s.frame.len()),
        walls: map.walls.len(),
        lines: map.walls.last().map_or(0, |w| w.line + 1),
        pieces_per_frame: tallies
            .first()
            .map_or(f64::NAN, |t| ratio(t.pieces, t.frames)),
        verified_share: ratio(verified, long_enough),
        tallies,
        figure,
        truth: *cfg,
    })
}

/// Every CARMEN log of `dir` ([`crate::real::find_logs`]) scored with
/// `methods` on every `every`-th frame, pooled over the logs (one tally
/// per method): what the diagnostic examples print.
pub fn pooled_over_logs(
    dir: &Path,
    methods: &[RealMethod],
    every: usize,
    cfg: &TruthConfig,
) -> Result<Vec<RealTally>> {
    let mut pooled = vec![RealTally::default(); methods.len()];
    for path in crate::real::find_logs(dir)? {
        let r = run_log(&path, methods, every, cfg, None)?;
        for (p, t) in pooled.iter_mut().zip(&r.tallies) {
            p.merge(t);
        }
    }
    Ok(pooled)
}

/// A Markdown table of pooled tallies, one row per method: TruePos (all,
/// ≥ 1 m), FalsePos (all, on no wall, on walls), coverage, fragmented
/// share and walls, lines per frame.
pub fn pooled_table(names: &[&str], pooled: &[RealTally]) -> String {
    let mut md = String::from(
        "| method | TruePos | ≥ 1 m | FalsePos | on no wall | FalsePos on walls | coverage | \
         fragmented | walls > 5 % fragmented | lines / frame |\n\
         |:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for (name, t) in names.iter().zip(pooled) {
        let s = t.summary();
        let _ = writeln!(
            md,
            "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} of {} | {:.2} |",
            s.true_pos,
            s.true_pos_1m,
            s.false_pos,
            s.no_wall,
            s.false_pos_on_walls,
            s.coverage,
            s.fragmented,
            s.walls_fragmented.0,
            s.walls_fragmented.1,
            s.lines_per_frame
        );
    }
    md
}

/// Every log of `logs`.
pub fn run_logs(
    logs: &[PathBuf],
    every: usize,
    cfg: &TruthConfig,
    figures: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<LogTruth>> {
    let methods = methods();
    let mut out = Vec::new();
    for path in logs {
        bar.set_message(format!("map truth, {}", path.display()));
        out.push(run_log(path, &methods, every, cfg, figures)?);
        bar.inc(1);
    }
    Ok(out)
}

/// The Markdown section of the report (heading level `##`): the same text
/// for `lms-lab truth` (real-truth.md) and `lms-lab evaluate` (README.md),
/// with the columns of the truth the logs were scored against.
pub fn markdown(logs: &[LogTruth], every: usize) -> String {
    let mut md = String::new();
    let names: Vec<&str> = methods().iter().map(|m| m.name).collect();
    let frames = if every == 1 {
        "Every frame".to_string()
    } else {
        format!("Every {every}-th frame")
    };
    let settled = logs
        .first()
        .is_some_and(|l| l.truth.neutral_and_unexplained);
    if settled {
        settled_intro(&mut md, &frames);
    } else {
        legacy_intro(&mut md, &frames);
    }
    log_table(&mut md, logs, settled);
    let _ = writeln!(md, "\n### All logs pooled\n");
    table_header(&mut md, "method", settled);
    for (k, n) in names.iter().enumerate() {
        let mut t = RealTally::default();
        for l in logs {
            t.merge(&l.tallies[k]);
        }
        table_row(&mut md, n, &t.summary(), settled);
    }
    settled_tables(&mut md, logs);
    let _ = writeln!(md, "\n### Per log, every method\n");
    table_header(&mut md, "log · method", settled);
    for l in logs {
        for (k, n) in names.iter().enumerate() {
            table_row(
                &mut md,
                &format!("{} · {n}", l.name),
                &l.tallies[k].summary(),
                settled,
            );
        }
    }
    let figs: Vec<&LogTruth> = logs.iter().filter(|l| l.figure.is_some()).collect();
    if !figs.is_empty() {
        let _ = writeln!(
            md,
            "\n**Truth and extraction** (one frame per log, the first whose number of counted \
             pieces is the log's median; left: the map's walls and the pose; then the frame \
             with its true pieces in green, matched lines blue, false lines red).\n"
        );
        for l in figs {
            if let Some(file) = &l.figure {
                let _ = writeln!(md, "![{} truth]({file})\n", l.name);
            }
        }
    }
    md
}

/// Per log: frames, map walls, counted pieces per frame and, for the
/// legacy truth, the share of the long-enough pieces the frame verifies
/// (the settled truth verifies nothing: its check is the oracle's row).
fn log_table(md: &mut String, logs: &[LogTruth], settled: bool) {
    if settled {
        let _ = writeln!(
            md,
            "| log | frames | map walls | counted pieces / frame |\n|:---|---:|---:|---:|"
        );
    } else {
        let _ = writeln!(
            md,
            "| log | frames | map walls | counted pieces / frame | verified |\n\
             |:---|---:|---:|---:|---:|"
        );
    }
    for l in logs {
        let verified = if settled {
            String::new()
        } else {
            format!(" {} |", f(l.verified_share, 3))
        };
        let _ = writeln!(
            md,
            "| {} ({}) | {} | {} | {} |{verified}",
            l.name,
            l.unit,
            l.frames,
            l.walls,
            f(l.pieces_per_frame, 1),
        );
    }
}

/// The section's first paragraph for [`TruthConfig::settled`].
fn settled_intro(md: &mut String, frames: &str) {
    let _ = writeln!(
        md,
        "## 5. Real scans against map-derived truth\n\n{frames} of each log, against the \
         settled truth (`TruthConfig::settled`, `lab/src/maptruth.rs`): every frame registered to \
         the walls of the log's accumulated map by robust point-to-line ICP with a weak prior \
         on the SLAM pose, the map rebuilt from the registered poses and every frame registered \
         again; the walls ray-cast into each frame, a beam on a wall if its hit is within 5 cm \
         of the wall's line, on neither of two parallel walls of different lines within 15 cm \
         (ambiguous); each piece's line taken through a pose registered without that wall's \
         own beams (leave-one-wall-out). Pieces with ≥ 10 beams and ≥ 0.3 m are counted; \
         pieces with fewer beams or shorter are neutral. Matching one-to-one, |Δα| < 3°, \
         |Δr| < 0.1 m at the line's middle, ≥ 50 % of the line's beams on the piece \
         (`lab/src/realtruth.rs`). A line matched to a counted piece is true; an unmatched line \
         with ≥ 50 % of its beams on no wall or invalid is *unexplained*; an unmatched line \
         with ≥ 50 % of its beams on one counted piece it does not match is false (a \
         fragment); a line matched to a neutral piece, or unmatched with ≥ 50 % of its beams \
         on neutral pieces or ambiguous, is *neutral*; every other line is false (across \
         walls or corners). In the tables: TruePos = matched / counted pieces, overall and \
         over the pieces ≥ 1 m, 0.5–1 m and < 0.5 m long (the part of the wall the frame \
         sees); FalsePos = false / (false + true) lines; *unexplained* and *neutral* as \
         shares of all lines; coverage = on-wall beams of counted pieces inside their \
         matched line / all of them; σΔα, σΔr over the matched pieces; repeatability = of \
         the walls matched in a frame and counted in the next, the share matched there too; \
         *walls > 5 % fragmented*: walls with ≥ {MIN_SIGHTINGS} counted sightings reported \
         as two or more lines in more than 5 % of them. *No flags* is `host-bridge extract \
         LOG` without options. The oracle is a least-squares fit to each counted piece's own \
         beams: its TruePos is the check of the truth itself, its σ the truth's own error. \
         `--truth legacy` scores against the truth at the SLAM poses with unverified pieces \
         left out and every unmatched line false.\n"
    );
}

/// The section's first paragraph for [`TruthConfig::legacy`].
fn legacy_intro(md: &mut String, frames: &str) {
    let _ = writeln!(
        md,
        "## 5. Real scans against map-derived truth\n\n{frames} of each log; true lines from the \
         log's SLAM map (`lab/src/maptruth.rs`: walls of the accumulated map, ray-cast into \
         each frame; pieces with ≥ 10 beams on a wall, ≥ 0.3 m, whose own hits' fit agrees with \
         the map line within the gates below are counted; an unverified piece is matched \
         against its own fit and not counted). Matching one-to-one, \
         |Δα| < 3°, |Δr| < 0.1 m, ≥ 50 % of the line's beams on the piece \
         (`lab/src/realtruth.rs`). *No flags* is `host-bridge extract LOG` without options. \
         The oracle fits each true piece's own beams: its TruePos is 1 by construction of \
         the verified truth, its σ the truth's own error; *verified* is the share of the \
         long-enough pieces the frame confirms (the unverified truth's ceiling).\n"
    );
}

/// Methods of the per-log summary tables.
const SUMMARY_METHODS: [&str; 3] = [NO_FLAGS, SPLIT_MERGE, ORACLE];

/// Per log and pooled, for the defaults, split-and-merge and the oracle:
/// TruePos overall and by piece length, FalsePos, unexplained and neutral
/// lines, coverage, walls fragmented in > 5 % of their sightings.
fn settled_tables(md: &mut String, logs: &[LogTruth]) {
    let all = methods();
    let _ = writeln!(
        md,
        "\n### Per log: the defaults, split-and-merge and the oracle\n\n\
         TruePos over the counted pieces, and over those ≥ 1 m, 0.5–1 m and < 0.5 m \
         long (the part of the wall the frame sees); FalsePos = false / (false + true) lines; \
         *unexplained* and *neutral* as shares of all lines; *fragments* the share of the \
         false lines that lie on a true piece they do not match, *on a matched piece* the \
         share of those whose piece another line matches (a wall reported twice); *walls fragmented*: walls \
         with ≥ {MIN_SIGHTINGS} counted sightings reported as two or more lines in more than \
         5 % of them.\n"
    );
    let _ = writeln!(
        md,
        "| log | method | TruePos | ≥ 1 m | 0.5–1 m | < 0.5 m | FalsePos | unexplained | \
         neutral | fragments | on a matched piece | coverage | walls fragmented |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let row = |md: &mut String, log: &str, name: &str, t: &RealTally| {
        let s = t.summary();
        let (bad, of) = s.walls_fragmented;
        let _ = writeln!(
            md,
            "| {log} | {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {bad} of {of} ({}) |",
            f(s.true_pos, 3),
            f(s.true_pos_1m, 3),
            f(s.true_pos_mid, 3),
            f(s.true_pos_short, 3),
            f(s.false_pos, 3),
            f(s.unexplained, 3),
            f(s.neutral, 3),
            f(s.fragments, 2),
            f(s.fragments_dup, 2),
            f(s.coverage, 3),
            f(ratio(bad, of), 3),
        );
    };
    let short = |n: &str| n.split(" (").next().unwrap_or(n).to_string();
    for l in logs {
        for m in SUMMARY_METHODS {
            if let Some(k) = all.iter().position(|x| x.name == m) {
                row(md, &l.name, &short(m), &l.tallies[k]);
            }
        }
    }
    for m in SUMMARY_METHODS {
        if let Some(k) = all.iter().position(|x| x.name == m) {
            let mut t = RealTally::default();
            for l in logs {
                t.merge(&l.tallies[k]);
            }
            row(md, "**all logs**", &short(m), &t);
        }
    }
}

/// The header of the tables of every method: with the settled truth, TruePos
/// by piece length and FalsePos = false / (false + true) beside the
/// unexplained and neutral lines; with the legacy truth, FalsePos = unmatched
/// / all lines beside the lines on no map wall.
fn table_header(md: &mut String, first: &str, settled: bool) {
    if settled {
        let _ = writeln!(
            md,
            "| {first} | TruePos | ≥ 1 m | 0.5–1 m | < 0.5 m | FalsePos | unexplained | neutral | \
             coverage | σΔα (°) | σΔr (mm) | repeatability | walls > 5 % fragmented | \
             lines / frame | ms / frame |\n\
             |:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
    } else {
        let _ = writeln!(
            md,
            "| {first} | TruePos | TruePos ≥ 1 m | FalsePos | on no wall | FalsePos on walls | \
             coverage | σΔα (°) | σΔr (mm) | repeatability | fragmented | walls > 5 % fragmented | \
             lines / frame | ms / frame |\n\
             |:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
    }
}

/// A row of [`table_header`]'s table.
fn table_row(md: &mut String, name: &str, s: &RealSummary, settled: bool) {
    let detection = if settled {
        [
            s.true_pos,
            s.true_pos_1m,
            s.true_pos_mid,
            s.true_pos_short,
            s.false_pos,
            s.unexplained,
            s.neutral,
            s.coverage,
        ]
        .map(|x| f(x, 3))
        .join(" | ")
    } else {
        [
            s.true_pos,
            s.true_pos_1m,
            s.false_pos,
            s.no_wall,
            s.false_pos_on_walls,
            s.coverage,
        ]
        .map(|x| f(x, 3))
        .join(" | ")
    };
    let fragmented = if settled {
        String::new()
    } else {
        format!("{} | ", f(s.fragmented, 3))
    };
    let _ = writeln!(
        md,
        "| {name} | {detection} | {} | {} | {} | {fragmented}{} of {} | {} | {} |",
        f(s.sd_alpha_deg, 2),
        f(s.sd_r_mm, 1),
        f(s.repeatability, 3),
        s.walls_fragmented.0,
        s.walls_fragmented.1,
        f(s.lines_per_frame, 2),
        f(s.ms, 3),
    );
}

/// `lms-lab truth`: sections 5–7 of the report alone, into `DIR/real-truth.md`.
pub fn run_standalone(args: &crate::TruthArgs) -> Result<PathBuf> {
    anyhow::ensure!(args.every > 0, "--every must be at least 1");
    let logs = crate::real::find_logs(&args.data)?;
    let output = args.output.as_path();
    std::fs::create_dir_all(output)
        .with_context(|| format!("cannot create {}", output.display()))?;
    let figures = (!args.no_plots && crate::report::fonts_available()).then_some(output);
    let bar = crate::progress(logs.len() as u64);
    let truth = run_logs(&logs, args.every, &args.truth.config(), figures, &bar)?;
    let fits = crate::sensorfit::run(&logs, crate::SENSOR_FIT_SCANS)?;
    let realistic = if args.synthetic_scans > 0 {
        crate::realistic::run(args.synthetic_scans, 1, &bar)?
    } else {
        Vec::new()
    };
    bar.finish_and_clear();
    let sections = crate::RealSections {
        truth,
        fits,
        realistic,
        realistic_scans: args.synthetic_scans,
    };
    let path = output.join("real-truth.md");
    std::fs::write(&path, sections.markdown(args.every))
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}
