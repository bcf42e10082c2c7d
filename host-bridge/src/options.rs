//! Command-line options shared by the subcommands: pipeline parameters,
//! frame selections and range units.
//!
//! Parameters come from, lowest precedence first: a preset (`--preset`,
//! else the defaults; with a log, σ and `max_range` from its data), a
//! parameter file (`--params`, [`param_file`]), each `--set NAME=VALUE`,
//! and the everyday flags (`--sigma`, `--iterations`, `--q`, `--tau`,
//! `--max-range`). Every one is a field of [`Params`] by its name
//! ([`lms_core::params::FIELDS`]); [`Params::validate`] checks the result.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use anyhow::{anyhow, bail, Result};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, ValueEnum};
use lms_core::params::{self as core_params, Preset, PRESETS};
use lms_core::{Params, Unit};

pub mod param_file;

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

/// `--topic NAME`: the topic of a ROS 2 bag input (`extract`, `plot`,
/// `verify --replay`, `simulate --replay`).
#[derive(Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct TopicArg {
    /// Topic of a ROS 2 bag input (an MCAP file or a rosbag2 folder) whose sensor_msgs/msg/LaserScan messages are read [default: the bag's only LaserScan topic]
    #[arg(long, value_name = "NAME", requires = "log")]
    pub topic: Option<String>,
}

impl TopicArg {
    /// The topic, if given.
    pub fn name(&self) -> Option<&str> {
        self.topic.as_deref()
    }
}

/// One `--set NAME=VALUE`: a parameter (a field of [`Params`]) and its
/// value as text, read as the field's type when given.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// The parameter ([`lms_core::params::FIELDS`]).
    pub name: &'static str,
    /// Its value as given.
    pub value: String,
}

impl FromStr for Setting {
    type Err = String;

    fn from_str(s: &str) -> Result<Setting, String> {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| format!("`{s}`: give NAME=VALUE, e.g. split_depth=0"))?;
        let name = parameter(name.trim())?;
        let mut check = Params::DEFAULT;
        check.set(name, value).map_err(|e| e.to_string())?;
        Ok(Setting {
            name,
            value: value.trim().to_string(),
        })
    }
}

/// The parameter named `name`, or a message naming it (and the name meant,
/// for a flag's spelling such as `split-depth`).
pub fn parameter(name: &str) -> Result<&'static str, String> {
    if let Some(f) = core_params::field(name) {
        return Ok(f.name);
    }
    let hint = match core_params::field(&name.trim_start_matches('-').replace('-', "_")) {
        Some(f) => format!("; did you mean {}?", f.name),
        None => String::new(),
    };
    Err(format!(
        "no parameter `{name}`{hint} (`host-bridge params` lists every one)"
    ))
}

/// The preset named `name`, or a message listing them.
pub fn preset(name: &str) -> Result<&'static Preset, String> {
    core_params::preset(name).ok_or_else(|| {
        let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
        format!("no preset `{name}`: give one of {}", names.join(", "))
    })
}

/// `--preset`'s values, with their one-line summaries for `--help`.
pub fn preset_parser() -> impl TypedValueParser<Value = String> {
    PossibleValuesParser::new(
        PRESETS
            .iter()
            .map(|p| PossibleValue::new(p.name).help(p.summary)),
    )
}

/// Where `--sigma`'s default comes from with a log.
const PER_LOG_SIGMA: &str = "a log's quantisation step (0.01 for cm logs, 0.005 for mm), else";

/// Where `--max-range`'s default comes from with a log.
const PER_LOG_MAX_RANGE: &str = "a log's unit and range mode, else";

/// The help of the flag of the parameter `name`: its meaning, unit and
/// range from [`core_params::FIELDS`], and its default in
/// [`Params::DEFAULT`], after `per_log` (where a log's data sets it) if
/// given.
fn param_help(name: &str, per_log: Option<&str>) -> String {
    let Some(field) = core_params::field(name) else {
        return format!("the parameter {name}");
    };
    let unit = field
        .shown_unit()
        .map_or(String::new(), |unit| format!("{unit}; "));
    let default = Params::DEFAULT
        .get(name)
        .map(|v| v.to_string())
        .unwrap_or_default();
    let default = per_log.map_or(default.clone(), |p| format!("{p} {default}"));
    format!(
        "{} ({unit}{}) [default: {default}]",
        field.meaning, field.range
    )
}

/// The parameters that have a flag of their own (`--sigma`, …), in
/// [`core_params::FIELDS`] order: those of [`ParamArgs`]'s options named as
/// a parameter.
pub fn flagged_parameters() -> Vec<&'static core_params::Field> {
    use clap::Args as _;
    let command = ParamArgs::augment_args(clap::Command::new("parameters"));
    core_params::FIELDS
        .iter()
        .filter(|f| command.get_arguments().any(|a| a.get_id() == f.name))
        .collect()
}

/// Pipeline parameters: a preset, a parameter file, `--set NAME=VALUE`,
/// and the everyday flags, each overriding the one before.
///
/// Every parameter is a field of `Params` set by its name: `host-bridge
/// params` lists them with their values, units and meanings, and
/// `host-bridge params --preset NAME` a preset's. Without `--preset` the
/// defaults apply; with a log, σ and max_range come from its data (its
/// quantisation step and range mode) unless set, under a preset too.
/// `Params::validate` checks the result and names a parameter out of range.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct ParamArgs {
    /// Smoothing passes (`--iterations`; help from the table)
    #[arg(long, value_name = "N", help_heading = "Parameters", help = param_help("iterations", None),
          value_parser = clap::value_parser!(u16).range(1..=i64::from(lms_core::params::MAX_ITERATIONS)))]
    pub iterations: Option<u16>,
    /// Process noise (`--q`; help from the table)
    #[arg(
        long,
        value_name = "Q",
        allow_negative_numbers = true,
        help_heading = "Parameters",
        help = param_help("q", None)
    )]
    pub q: Option<f32>,
    /// Range noise (`--sigma`; help from the table)
    #[arg(
        long,
        value_name = "S",
        allow_negative_numbers = true,
        help_heading = "Parameters",
        help = param_help("sigma", Some(PER_LOG_SIGMA))
    )]
    pub sigma: Option<f32>,
    /// Segmentation gate (`--tau`; help from the table)
    #[arg(
        long,
        value_name = "T",
        allow_negative_numbers = true,
        help_heading = "Parameters",
        help = param_help("tau", None)
    )]
    pub tau: Option<f32>,
    /// Largest true range (`--max-range`; help from the table)
    #[arg(
        long,
        value_name = "M",
        help_heading = "Parameters",
        help = param_help("max_range", Some(PER_LOG_MAX_RANGE))
    )]
    pub max_range: Option<f32>,
    /// Start from a named set of parameters [default: default]
    ///
    /// Later wins: the preset, then --params, then each --set, then the
    /// flags above. With a log, sigma and max_range come from its data
    /// (quantisation step, range mode) unless set, under a preset too.
    /// `host-bridge params --preset NAME` lists a preset's values.
    #[arg(long, value_name = "NAME", value_parser = preset_parser(), help_heading = "Parameters")]
    pub preset: Option<String>,
    /// Set a parameter by name, e.g. --set split_depth=0 (repeatable)
    ///
    /// NAME is a field of the parameters (`host-bridge params` lists every
    /// one); VALUE a number (inf for infinity), a whole number or
    /// true/false. Overrides the preset and --params; the everyday flags
    /// above override it.
    #[arg(long = "set", value_name = "NAME=VALUE", help_heading = "Parameters")]
    pub set: Vec<Setting>,
    /// Read parameters from a TOML file of NAME = VALUE lines
    ///
    /// A flat table: each key a parameter as for --set, and an optional
    /// `preset = "NAME"` (--preset overrides it). E.g.
    /// `split_depth = 0` and `merge_anchor_gate = inf` on lines of their own.
    #[arg(long = "params", value_name = "FILE", help_heading = "Parameters")]
    pub params_file: Option<PathBuf>,
}

impl ParamArgs {
    /// Refuse what the co-processor cannot run (for `verify` and
    /// `coprocessor`): a value other than the default of a
    /// [`lms_core::params::HOST_ONLY`] parameter, however it was set (the
    /// firmware leaves them out, and its `D0` echo could not tell a client).
    pub fn ensure_coprocessor_runs_them(&self) -> Result<()> {
        let p = self.resolve(None)?;
        for name in core_params::HOST_ONLY {
            if p.get(name) != Params::DEFAULT.get(name) {
                bail!(
                    "{name}: the co-processor does not run it (an ALGORITHM.md §10 option the \
                     firmware leaves out, and its D0 echo could not tell a client): use it \
                     with extract or plot"
                );
            }
        }
        Ok(())
    }

    /// The parameters, checked with [`Params::validate`].
    pub fn to_params(&self) -> Result<Params> {
        self.checked(self.resolve(None)?)
    }

    /// The parameters for data whose own defaults are `data` (e.g.
    /// [`lms_core::DataProfile::params`]): without a preset `data`, with one
    /// the preset with σ and `max_range` of `data`; then the file, the
    /// settings and the flags. Checked with [`Params::validate`].
    pub fn to_params_over(&self, data: Params) -> Result<Params> {
        self.checked(self.resolve(Some(data))?)
    }

    /// The preset, the file, the settings and the flags over the base
    /// (`data`, see [`ParamArgs::to_params_over`]), not validated.
    fn resolve(&self, data: Option<Params>) -> Result<Params> {
        let file = match &self.params_file {
            Some(path) => param_file::ParamFile::read(path)?,
            None => param_file::ParamFile::default(),
        };
        let chosen = match &self.preset {
            Some(name) => Some(preset(name).map_err(|e| anyhow!("--preset: {e}"))?),
            None => file.preset,
        };
        let mut p = match (chosen, data) {
            (None, Some(d)) => d,
            (None, None) => Params::DEFAULT,
            (Some(pre), None) => pre.params,
            (Some(pre), Some(d)) => pre.params.with_sigma(d.sigma).with_max_range(d.max_range),
        };
        file.apply(&mut p)?;
        for s in &self.set {
            p.set(s.name, &s.value)
                .map_err(|e| anyhow!("--set {}={}: {}", s.name, s.value, e))?;
        }
        p.iterations = self.iterations.unwrap_or(p.iterations);
        p.q = self.q.unwrap_or(p.q);
        p.sigma = self.sigma.unwrap_or(p.sigma);
        p.tau = self.tau.unwrap_or(p.tau);
        p.max_range = self.max_range.unwrap_or(p.max_range);
        Ok(p)
    }

    /// `p` validated, with a warning for an implausible σ.
    fn checked(&self, p: Params) -> Result<Params> {
        p.validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        if p.sigma > SIGMA_WARN_M {
            crate::warning::warn(&format!(
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

    #[test]
    fn later_sources_win() {
        let set = |s: &str| s.parse::<Setting>().unwrap();
        let data = Params::DEFAULT.with_sigma(0.01).with_max_range(50.0);
        // No preset: the data's defaults; a preset: its values, σ and
        // max_range from the data.
        assert_eq!(ParamArgs::default().to_params_over(data).unwrap(), data);
        let paper = ParamArgs {
            preset: Some("paper".into()),
            ..ParamArgs::default()
        };
        assert_eq!(paper.to_params().unwrap(), Params::PAPER);
        assert_eq!(
            paper.to_params_over(data).unwrap(),
            Params::PAPER.with_sigma(0.01).with_max_range(50.0)
        );
        // --set over the preset, the flags over --set.
        let args = ParamArgs {
            sigma: Some(0.02),
            set: vec![
                set("sigma=0.03"),
                set("split_depth=2"),
                set("split_depth=3"),
            ],
            ..paper
        };
        let p = args.to_params_over(data).unwrap();
        assert_eq!((p.sigma, p.split_depth, p.max_range), (0.02, 3, 50.0));
    }

    #[test]
    fn settings_are_checked_when_read() {
        assert_eq!(
            "max_range = inf".parse::<Setting>(),
            Ok(Setting {
                name: "max_range",
                value: "inf".into()
            })
        );
        let e = "max_rang=inf".parse::<Setting>().unwrap_err();
        assert!(e.starts_with("no parameter `max_rang`"), "{e}");
        let e = "--split-depth=3".parse::<Setting>().unwrap_err();
        assert!(e.contains("did you mean split_depth?"), "{e}");
        let e = "iterations=many".parse::<Setting>().unwrap_err();
        assert!(e.contains("iterations must be a whole number"), "{e}");
        // Ranges are for validate, which names the parameter.
        let args = ParamArgs {
            set: vec!["min_points=2".parse().unwrap()],
            ..ParamArgs::default()
        };
        let e = args.to_params().unwrap_err().to_string();
        assert!(e.contains("min_points must be at least 3"), "{e}");
    }

    #[test]
    fn the_coprocessor_refuses_host_only_values() {
        for setting in [
            "per_turn=true",
            "merge_f_test=20",
            "grazing_noise=0.5",
            "fit_sigma=0.01",
        ] {
            let args = ParamArgs {
                set: vec![setting.parse().unwrap()],
                ..ParamArgs::default()
            };
            let e = args.ensure_coprocessor_runs_them().unwrap_err().to_string();
            let name = setting.split('=').next().unwrap();
            assert!(e.starts_with(&format!("{name}: the co-processor")), "{e}");
        }
        assert!(ParamArgs::default().ensure_coprocessor_runs_them().is_ok());
    }
}
