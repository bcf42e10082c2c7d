//! Command-line options shared by the subcommands: pipeline parameters,
//! frame selections and range units.

use std::fmt;
use std::str::FromStr;

use anyhow::{anyhow, Result};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, ValueEnum};
use lms_core::{Params, Unit};

use crate::carmen::UnitMode;

/// Range unit on the command line: `--unit` of `extract` and `plot` (the
/// unit of a log's error codes, `auto` by default) and `--units` of `scan`
/// (the sensor's units: `mm` or `cm` only, see [`UnitArg::sensor_parser`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum UnitArg {
    /// mm if at least 1/4 of the ranges show three decimals, cm if none (ambiguous in between: cm, with a warning).
    Auto,
    /// Centimetres (ranges up to 81.82 m).
    Cm,
    /// Millimetres (ranges up to 8.182 m).
    Mm,
}

impl UnitArg {
    /// How `carmen` reads a log in this unit.
    pub fn carmen_mode(self) -> UnitMode {
        match self {
            UnitArg::Auto => UnitMode::Auto,
            UnitArg::Cm => UnitMode::Centimetre,
            UnitArg::Mm => UnitMode::Millimetre,
        }
    }

    /// The core's unit; `None` for `auto`.
    pub fn unit(self) -> Option<Unit> {
        match self {
            UnitArg::Auto => None,
            UnitArg::Cm => Some(Unit::Centimetre),
            UnitArg::Mm => Some(Unit::Millimetre),
        }
    }

    /// A value parser taking only the units a sensor can be set to, `mm`
    /// and `cm` (for `scan --units`).
    pub fn sensor_parser() -> impl TypedValueParser<Value = UnitArg> {
        PossibleValuesParser::new([
            PossibleValue::new("mm").help("Millimetres (ranges up to 8.182 m)"),
            PossibleValue::new("cm").help("Centimetres (ranges up to 81.82 m)"),
        ])
        .map(|s| if s == "cm" { UnitArg::Cm } else { UnitArg::Mm })
    }
}

/// Pipeline parameters on the command line; unset ones keep the
/// [`Params::default`] of ALGORITHM.md.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct ParamArgs {
    /// Smoothing passes, the first scale parameter (1..=1000) [default: 30]
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u16).range(1..=i64::from(lms_core::params::MAX_ITERATIONS)))]
    pub iterations: Option<u16>,
    /// Process noise q (m²), the second scale parameter [default: 0]
    #[arg(long, value_name = "Q", allow_negative_numbers = true)]
    pub q: Option<f32>,
    /// Range noise standard deviation sigma (m) [default: 0.005]
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub sigma: Option<f32>,
    /// Segmentation gate tau on D [default: 9]
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    pub tau: Option<f32>,
    /// Smallest segment kept, in points (at least 3) [default: 5]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(3..))]
    pub min_points: Option<u16>,
    /// Largest accepted line chi2 [default: 4]
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub max_chi2: Option<f32>,
    /// Do not merge consecutive agreeing lines (ALGORITHM.md §7.6)
    #[arg(long)]
    pub no_merge: bool,
    /// Leave a corner point shared by two segments out of both line fits
    /// (the default of ALGORITHM.md v2; kept for old command lines)
    #[arg(long, conflicts_with = "shared_points")]
    pub no_shared_points: bool,
    /// Fit a corner point shared by two segments into both lines
    /// (ALGORITHM.md v1)
    #[arg(long)]
    pub shared_points: bool,
    /// Split before reject: levels a segment that is not one straight line
    /// may be split before the chi2 gate; 0 is ALGORITHM.md v1 [default: 8]
    #[arg(long, value_name = "LEVELS",
          value_parser = clap::value_parser!(u8).range(..=i64::from(lms_core::params::MAX_SPLIT_DEPTH)))]
    pub split_depth: Option<u8>,
    /// Largest true range (m): beams at or beyond it are invalid (fill
    /// values); inf for no limit [default: the data's unit and range mode,
    /// 81.83 m for cm data]
    #[arg(long, value_name = "M")]
    pub max_range: Option<f32>,
    /// Per-turn extraction in the interleaved 0.5° and 0.25° modes: each
    /// mirror turn a scan of its own, the turns' lines of one wall fused
    /// (ALGORITHM.md §10 proposal (d), docs/ALGORITHM-v3-section10.md; host
    /// only, the firmware leaves it out)
    #[arg(long)]
    pub per_turn: bool,
    /// Beam-footprint term κ of the range noise (rad): the line fits weight
    /// a beam at range d and incidence θ by σ²/(σ² + (κ·d·tan θ)²);
    /// 0 fits every beam at σ, as ALGORITHM.md v2 (ALGORITHM.md §10 (f),
    /// docs/ALGORITHM-v3-section10.md) [default: 0.003]
    #[arg(long, value_name = "RAD")]
    pub footprint: Option<f32>,
    /// Merge consecutive lines only across invalid beams (or at most three
    /// valid ones), as ALGORITHM.md v2 §7.6, not across
    /// rejected segments (ALGORITHM.md §10 (e)); with --footprint 0,
    /// --merge-anchor-gate inf, --no-same-turn-windows, --split-budget 0 and
    /// --arc-chain 0 the defaults up to stop 20 (`Params::V2`)
    #[arg(long)]
    pub no_bridge_merge: bool,
    /// Windows of consecutive beams over both mirror turns in the
    /// interleaved 0.5° and 0.25° modes, as ALGORITHM.md v2 §2–6, instead
    /// of windows of one turn (ALGORITHM.md §10 (a),
    /// docs/ALGORITHM-v3-section10.md §10.9); with --split-budget 0 and
    /// --merge-anchor-gate inf the defaults of stop 22, and --arc-chain 0
    /// too those of stop 21
    #[arg(long)]
    pub no_same_turn_windows: bool,
    /// Fewest consecutive touching lines, turning the same way by
    /// --arc-turn-deg each, that are taken for an arc (a pillar, a curved
    /// wall) and dropped; 0 keeps every line, as ALGORITHM.md v2 [default: 3]
    #[arg(long, value_name = "N", value_parser = arc_chain_parser)]
    pub arc_chain: Option<u8>,
    /// Turn between consecutive lines of an arc, smallest and largest
    /// (degrees) [default: 5,40]
    #[arg(long, value_name = "MIN,MAX", value_parser = arc_turns_parser)]
    pub arc_turn_deg: Option<(f32, f32)>,
    /// Work bound of split before reject per frame, in beams tested (a
    /// piece past it goes to the chi2 gate whole, as v1); 0 for no bound,
    /// as up to stop 22 [default: 542]
    #[arg(long, value_name = "BEAMS")]
    pub split_budget: Option<u16>,
    /// Anchor gate of the merges (chi-square, 2 dof): two lines merge only
    /// if the union line stays within it of the larger line's own
    /// parameters; inf for no test, as up to stop 23 [default: 13.8155]
    #[arg(long, value_name = "CHI2", value_parser = anchor_gate_parser)]
    pub merge_anchor_gate: Option<f32>,
    /// Fit χ² without the offsets between the interleaved mirror turns of
    /// the 0.5° and 0.25° modes (ALGORITHM.md §7 as written); with
    /// --merge-anchor-gate inf the defaults of stop 23
    #[arg(long)]
    pub no_turn_offsets: bool,
    /// Keep a pair of touching lines that a circle explains better (two
    /// chords of a curved wall or pillar are dropped by default); with
    /// the defaults otherwise, those of stop 24
    #[arg(long)]
    pub no_arc_pairs: bool,
    /// Nested-model test of the merges (an F threshold, e.g. 20): two lines
    /// merge only if one line fits their beams not significantly worse than
    /// the two; 0 for no test [default: 0]. Host builds only (ALGORITHM.md
    /// §10 option): the co-processor paths refuse it
    #[arg(long, value_name = "F", value_parser = f_test_parser)]
    pub merge_f_test: Option<f32>,
}

/// `--merge-f-test`: finite and >= 0.
fn f_test_parser(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(f) if f.is_finite() && f >= 0.0 => Ok(f),
        _ => Err("give an F threshold >= 0 (e.g. 20), or 0 for no test".into()),
    }
}

/// `--merge-anchor-gate`: > 0, or `inf`.
fn anchor_gate_parser(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(g) if g > 0.0 => Ok(g),
        _ => Err("give a chi-square gate > 0 (e.g. 13.8), or inf for no test".into()),
    }
}

/// `--arc-chain`: 0 or at least 2.
fn arc_chain_parser(s: &str) -> std::result::Result<u8, String> {
    match s.parse::<u8>() {
        Ok(n) if n != 1 => Ok(n),
        Ok(_) => Err("1 would drop every line: give 0 (off) or at least 2".into()),
        Err(e) => Err(format!("{e}: give a count, 0 (off) or 2 to 255")),
    }
}

/// `--arc-turn-deg MIN,MAX`, 0 ≤ MIN ≤ MAX ≤ 180.
fn arc_turns_parser(s: &str) -> std::result::Result<(f32, f32), String> {
    let parsed = s
        .split_once(',')
        .and_then(|(a, b)| Some((a.trim().parse::<f32>().ok()?, b.trim().parse::<f32>().ok()?)));
    match parsed {
        Some((lo, hi)) if (0.0..=hi).contains(&lo) && hi <= 180.0 => Ok((lo, hi)),
        _ => Err("give MIN,MAX in degrees with 0 <= MIN <= MAX <= 180, e.g. 5,40".into()),
    }
}

impl ParamArgs {
    /// Refuse what the co-processor cannot run (for `verify` and
    /// `coprocessor`): `--per-turn`, an ALGORITHM.md §10 option the firmware
    /// leaves out and the `D0` echo cannot carry.
    pub fn ensure_coprocessor_runs_them(&self) -> Result<()> {
        anyhow::ensure!(
            !self.per_turn,
            "--per-turn: the co-processor does not run it (an ALGORITHM.md §10 option the \
             firmware leaves out, and its D0 echo could not tell a client): use it with \
             extract or plot"
        );
        anyhow::ensure!(
            self.merge_f_test.is_none_or(|f| f == 0.0),
            "--merge-f-test: the co-processor does not run it (an ALGORITHM.md §10 option the \
             firmware leaves out): use it with extract or plot"
        );
        Ok(())
    }

    /// The parameters, checked with [`Params::validate`].
    pub fn to_params(&self) -> Result<Params> {
        self.to_params_over(Params::default())
    }

    /// The parameters given, the others from `d` (e.g. the defaults for
    /// the data, [`lms_core::DataProfile::params`]), checked with
    /// [`Params::validate`].
    pub fn to_params_over(&self, d: Params) -> Result<Params> {
        let p = Params {
            iterations: self.iterations.unwrap_or(d.iterations),
            q: self.q.unwrap_or(d.q),
            sigma: self.sigma.unwrap_or(d.sigma),
            tau: self.tau.unwrap_or(d.tau),
            min_points: self.min_points.unwrap_or(d.min_points),
            max_chi2: self.max_chi2.unwrap_or(d.max_chi2),
            merge: !self.no_merge,
            fit_shared_points: self.shared_points
                || (!self.no_shared_points && d.fit_shared_points),
            split_depth: self.split_depth.unwrap_or(d.split_depth),
            max_range: self.max_range.unwrap_or(d.max_range),
            per_turn: self.per_turn || d.per_turn,
            footprint: self.footprint.unwrap_or(d.footprint),
            bridge_merge: !self.no_bridge_merge && d.bridge_merge,
            same_turn_windows: !self.no_same_turn_windows && d.same_turn_windows,
            arc_chain: self.arc_chain.unwrap_or(d.arc_chain),
            arc_min_turn_deg: self.arc_turn_deg.map_or(d.arc_min_turn_deg, |t| t.0),
            arc_max_turn_deg: self.arc_turn_deg.map_or(d.arc_max_turn_deg, |t| t.1),
            split_budget: self.split_budget.unwrap_or(d.split_budget),
            merge_anchor_gate: self.merge_anchor_gate.unwrap_or(d.merge_anchor_gate),
            turn_offsets: !self.no_turn_offsets && d.turn_offsets,
            arc_pairs: !self.no_arc_pairs && d.arc_pairs,
            merge_f_test: self.merge_f_test.unwrap_or(d.merge_f_test),
            ..d
        };
        p.validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        if p.sigma > SIGMA_WARN_M {
            crate::input::warn(&format!(
                "--sigma {} m is far above an LMS's range noise (0.005–0.01 m): \
                 every window passes the gate tau, so segments, lines and corners \
                 may be few or none",
                p.sigma
            ));
        }
        Ok(p)
    }
}

/// A `--sigma` above this (m) is warned about: no LMS is that noisy.
pub const SIGMA_WARN_M: f32 = 1.0;

/// Largest duration accepted on the command line (s): about 31 years, far
/// inside what a `Duration` added to an `Instant` can hold.
pub const MAX_SECONDS: f64 = 1e9;

/// A duration in seconds on the command line: a finite number in
/// `0..=MAX_SECONDS` (a value parser: checked when the arguments are read,
/// so no duration can overflow later).
pub fn seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if !(v.is_finite() && (0.0..=MAX_SECONDS).contains(&v)) {
        return Err(format!(
            "`{s}` seconds is outside 0..={MAX_SECONDS:e} (0 s to about 31 years)"
        ));
    }
    Ok(v)
}

/// Most frames of a synthetic scene (`--count`): `simulate` and `verify`
/// keep the scene's scans in memory (about 2.5 KB each).
pub const MAX_SCENE_FRAMES: usize = 100_000;

/// `--count` of a synthetic scene: `1..=MAX_SCENE_FRAMES`.
pub fn scene_count(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a count of frames"))?;
    if !(1..=MAX_SCENE_FRAMES).contains(&n) {
        return Err(format!(
            "{n} frames: the scene has 1..={MAX_SCENE_FRAMES} frames"
        ));
    }
    Ok(n)
}

/// A selection of frame indices, `start..end` (end exclusive, open if `None`).
///
/// Syntax: `A..B` (A to B−1), `A..=B`, `A..`, `..B`, or a single index `A`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// First index selected.
    pub start: usize,
    /// One past the last index selected; `None` = to the end.
    pub end: Option<usize>,
}

impl FrameRange {
    /// Every frame.
    pub const ALL: FrameRange = FrameRange {
        start: 0,
        end: None,
    };

    /// `true` if `index` is selected.
    pub fn contains(&self, index: usize) -> bool {
        index >= self.start && self.end.is_none_or(|e| index < e)
    }

    /// `true` if `index` and every later index are past the selection.
    pub fn is_past(&self, index: usize) -> bool {
        self.end.is_some_and(|e| index >= e)
    }

    /// The end clamped to `len` frames.
    pub fn end_within(&self, len: usize) -> usize {
        self.end.map_or(len, |e| e.min(len))
    }
}

impl Default for FrameRange {
    fn default() -> Self {
        FrameRange::ALL
    }
}

impl fmt::Display for FrameRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.end {
            Some(e) => write!(f, "{}..{}", self.start, e),
            None => write!(f, "{}..", self.start),
        }
    }
}

impl FromStr for FrameRange {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad =
            || format!("bad frame range {s:?}: expected A..B (B exclusive), A..=B, A.., ..B or A");
        let index = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
        let s_trim = s.trim();
        let range = if let Some((a, b)) = s_trim.split_once("..=") {
            let start = if a.is_empty() { 0 } else { index(a)? };
            let last = index(b)?;
            FrameRange {
                start,
                end: Some(last.checked_add(1).ok_or_else(bad)?),
            }
        } else if let Some((a, b)) = s_trim.split_once("..") {
            FrameRange {
                start: if a.is_empty() { 0 } else { index(a)? },
                end: if b.is_empty() { None } else { Some(index(b)?) },
            }
        } else {
            let a = index(s_trim)?;
            FrameRange {
                start: a,
                end: Some(a.checked_add(1).ok_or_else(|| {
                    format!(
                        "frame index {a} is too large: the largest is {}",
                        usize::MAX - 1
                    )
                })?),
            }
        };
        if let Some(e) = range.end {
            if e <= range.start {
                return Err(format!(
                    "empty frame range {s:?}: the end must be after the start"
                ));
            }
        }
        Ok(range)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges() {
        let r = |s: &str| s.parse::<FrameRange>();
        assert_eq!(
            r("0..5"),
            Ok(FrameRange {
                start: 0,
                end: Some(5)
            })
        );
        assert_eq!(
            r("2..=4"),
            Ok(FrameRange {
                start: 2,
                end: Some(5)
            })
        );
        assert_eq!(
            r("7.."),
            Ok(FrameRange {
                start: 7,
                end: None
            })
        );
        assert_eq!(
            r("..3"),
            Ok(FrameRange {
                start: 0,
                end: Some(3)
            })
        );
        assert_eq!(
            r("9"),
            Ok(FrameRange {
                start: 9,
                end: Some(10)
            })
        );
        for bad in ["", "a..b", "5..2", "3..3", "1...4", "-1..3", "1..2..3"] {
            assert!(r(bad).is_err(), "{bad:?} accepted");
        }
        let all = FrameRange::ALL;
        assert!(all.contains(0) && all.contains(usize::MAX));
    }

    #[test]
    fn params_validated() {
        let ok = ParamArgs {
            iterations: Some(1),
            q: Some(1.0),
            ..ParamArgs::default()
        };
        let p = ok.to_params().unwrap();
        assert_eq!((p.iterations, p.q, p.sigma), (1, 1.0, 0.005));
        let bad = ParamArgs {
            sigma: Some(-1.0),
            ..ParamArgs::default()
        };
        let e = bad.to_params().unwrap_err().to_string();
        assert!(e.contains("sigma"), "{e}");
        let bad = ParamArgs {
            iterations: Some(0),
            ..ParamArgs::default()
        };
        assert!(bad.to_params().is_err());
    }
}
