//! Every parameter by name: [`FIELDS`] gives each field of [`Params`] with
//! its unit, a one-line meaning and its value as text both ways, so that a
//! host sets any parameter the one same way ([`Params::set`]: a command
//! line's `--set NAME=VALUE`, a parameter file) and its reference is
//! generated from here. [`PRESETS`] names the documented sets of values.
//!
//! Nothing here is on the firmware's path (it builds its parameters as a
//! `const`): the table costs no flash unless a build uses it.

use core::fmt;
use core::str::FromStr;

use super::{ParamError, Params};

/// The value of one parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A real number (`inf` where the parameter allows it).
    Real(f32),
    /// A whole number.
    Count(u16),
    /// On or off.
    Flag(bool),
}

impl fmt::Display for Value {
    /// The text [`Params::set`] reads back to the same value: the shortest
    /// decimal of an `f32` that round-trips, `inf`, `true`/`false`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Real(x) => write!(f, "{x}"),
            Value::Count(n) => write!(f, "{n}"),
            Value::Flag(b) => write!(f, "{b}"),
        }
    }
}

impl From<f32> for Value {
    fn from(x: f32) -> Value {
        Value::Real(x)
    }
}

impl From<u16> for Value {
    fn from(n: u16) -> Value {
        Value::Count(n)
    }
}

impl From<u8> for Value {
    fn from(n: u8) -> Value {
        Value::Count(n.into())
    }
}

impl From<bool> for Value {
    fn from(b: bool) -> Value {
        Value::Flag(b)
    }
}

/// A field type a parameter's text is read as.
trait FromText: Sized {
    /// `text` as this type, or [`ParamError::BadValue`] naming `name`.
    fn from_text(name: &'static str, text: &str) -> Result<Self, ParamError>;
}

impl FromText for f32 {
    fn from_text(name: &'static str, text: &str) -> Result<f32, ParamError> {
        match f32::from_str(text.trim()) {
            Ok(x) if !x.is_nan() => Ok(x),
            _ => Err(ParamError::BadValue {
                name,
                expected: "a number (inf for infinity)",
            }),
        }
    }
}

/// A whole number of type `T`, or [`ParamError::BadValue`] naming `name`.
fn whole<T: FromStr>(
    name: &'static str,
    text: &str,
    expected: &'static str,
) -> Result<T, ParamError> {
    T::from_str(text.trim()).map_err(|_| ParamError::BadValue { name, expected })
}

impl FromText for u16 {
    fn from_text(name: &'static str, text: &str) -> Result<u16, ParamError> {
        whole(name, text, "a whole number 0..=65535")
    }
}

impl FromText for u8 {
    fn from_text(name: &'static str, text: &str) -> Result<u8, ParamError> {
        whole(name, text, "a whole number 0..=255")
    }
}

impl FromText for bool {
    fn from_text(name: &'static str, text: &str) -> Result<bool, ParamError> {
        match text.trim() {
            "true" => Ok(true),
            "false" => Ok(false),
            _ => Err(ParamError::BadValue {
                name,
                expected: "true or false",
            }),
        }
    }
}

/// One parameter: a field of [`Params`].
#[derive(Clone, Copy, Debug)]
pub struct Field {
    /// The field's name.
    pub name: &'static str,
    /// Its unit (`bool` for a switch, `-` for a pure number).
    pub unit: &'static str,
    /// What it does, in one line.
    pub meaning: &'static str,
    /// Its value in some parameters.
    pub get: fn(&Params) -> Value,
    /// Set it from text: a number (`inf` for infinity), a whole number, or
    /// `true`/`false`. Not validated: [`Params::validate`] checks the whole.
    pub set: fn(&mut Params, &str) -> Result<(), ParamError>,
}

macro_rules! fields {
    ($($name:ident, $unit:literal, $meaning:literal;)+) => {
        /// Every field of [`Params`], in declaration order.
        pub const FIELDS: &[Field] = &[$(Field {
            name: stringify!($name),
            unit: $unit,
            meaning: $meaning,
            get: |p: &Params| Value::from(p.$name),
            set: |p: &mut Params, text: &str| {
                p.$name = FromText::from_text(stringify!($name), text)?;
                Ok(())
            },
        },)+];
    };
}

fields! {
    sigma, "m", "Range noise standard deviation of the smoothing filter and the segmentation";
    q, "m²", "Process noise of the smoothing filter, the second scale parameter";
    iterations, "passes", "Smoothing passes, the first scale parameter (1..=1000)";
    tau, "-", "Segmentation gate on D: a window above it breaks a segment";
    min_points, "beams", "Smallest segment kept (at least 3)";
    max_chi2, "-", "Largest chi-square of an accepted line";
    min_length, "m", "Shortest accepted line, endpoint to endpoint";
    fit_shared_points, "bool", "Fit a corner beam shared by two segments into both lines";
    merge, "bool", "Merge consecutive lines that agree";
    merge_gap_beams, "beams", "Most valid beams between two lines that may merge";
    merge_gate, "chi2 (2 dof)", "Gate of the merge test";
    corner_gap, "m", "Largest gap between facing endpoints of two lines made a corner";
    min_corner_angle_deg, "deg", "Smallest angle between two lines for a well-conditioned corner (0..=90)";
    split_depth, "levels", "Split before reject: times a segment that is not one line may be split (0 off, at most 16)";
    max_range, "m", "Largest true range: a beam at or beyond it is invalid (inf: no limit)";
    merge_collinear, "bool", "Merge touching, nearly collinear lines whose union fits";
    max_alpha_sd_deg, "deg", "Largest standard deviation of a line's angle; a less certain line is dropped (inf: keep all)";
    grazing_noise, "-", "Grazing-incidence term of the window noise (0 off; host builds only)";
    same_turn_windows, "bool", "Windows of one mirror turn's beams in the interleaved 0.5° and 0.25° modes";
    fit_sigma, "m", "Range noise of the line fits (0: sigma; host builds only)";
    per_turn, "bool", "Extract each mirror turn alone and fuse their lines (interleaved modes; host builds only)";
    bridge_merge, "bool", "Merge two accepted lines across the rejected segments between them when their union fits";
    footprint, "rad", "Beam-footprint term of the fits' range noise, sigma² + (footprint·d·tan θ)² (0 off)";
    arc_chain, "lines", "Fewest touching lines turning the same way that are dropped as an arc (0 off, else at least 2)";
    arc_min_turn_deg, "deg", "Smallest turn between consecutive lines of an arc";
    arc_max_turn_deg, "deg", "Largest turn between consecutive lines of an arc (at most 180)";
    split_budget, "beams", "Work bound of split before reject per frame, in beams tested (0: no bound)";
    merge_anchor_gate, "chi2 (2 dof)", "A merge keeps the union line within this of the larger line's own (inf: no test)";
    turn_offsets, "bool", "Line fits' chi-square allows an offset between interleaved mirror turns";
    merge_f_test, "F", "Nested-model F test of the merges (0 off; host builds only)";
    arc_pairs, "bool", "Drop a pair of touching lines that a circle explains better";
}

/// The parameter named `name` (a field of [`Params`]).
pub fn field(name: &str) -> Option<&'static Field> {
    FIELDS.iter().find(|f| f.name == name)
}

/// A named, documented set of parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    /// Its name (`--preset NAME`).
    pub name: &'static str,
    /// What it is, in one line.
    pub summary: &'static str,
    /// Its parameters.
    pub params: Params,
}

/// The presets: `default` ([`Params::DEFAULT`]), `v2` ([`Params::V2`]) and
/// `paper` ([`Params::PAPER`]).
pub const PRESETS: [Preset; 3] = [
    Preset {
        name: "default",
        summary: "The defaults: ALGORITHM.md v2 with the measured additions of docs/ALGORITHM.md",
        params: Params::DEFAULT,
    },
    Preset {
        name: "v2",
        summary: "ALGORITHM.md v2 as written, with the collinear merge and the line-angle gate",
        params: Params::V2,
    },
    Preset {
        name: "paper",
        summary: "The seed paper's method, ALGORITHM.md v1",
        params: Params::PAPER,
    },
];

/// The preset named `name`.
pub fn preset(name: &str) -> Option<&'static Preset> {
    let all: &'static [Preset] = &PRESETS;
    all.iter().find(|p| p.name == name)
}

impl Params {
    /// Set the parameter `name` (a field's name, [`FIELDS`]) from text: a
    /// number (`inf` for infinity), a whole number, or `true`/`false`.
    /// [`ParamError::UnknownName`] or [`ParamError::BadValue`] otherwise;
    /// the value itself is checked by [`Params::validate`], as every other.
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), ParamError> {
        let field = field(name).ok_or(ParamError::UnknownName)?;
        (field.set)(self, value)
    }

    /// The value of the parameter `name`, if there is one of that name.
    pub fn get(&self, name: &str) -> Option<Value> {
        field(name).map(|f| (f.get)(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each field set through the table to a value of its own (its place
    /// in the table, or a flipped switch), compared with a literal that
    /// names every field: a field missing from the table, or a table entry
    /// writing another field, fails; a field added to `Params` and not
    /// here does not compile.
    #[test]
    fn the_table_covers_every_field() {
        let mut p = Params::DEFAULT;
        for (i, f) in FIELDS.iter().enumerate() {
            let text = match (f.get)(&Params::DEFAULT) {
                Value::Flag(b) => (!b).to_string(),
                _ => (i + 1).to_string(),
            };
            p.set(f.name, &text).unwrap();
            assert_eq!((f.get)(&p).to_string(), text, "{}", f.name);
        }
        let every = Params {
            sigma: 1.0,
            q: 2.0,
            iterations: 3,
            tau: 4.0,
            min_points: 5,
            max_chi2: 6.0,
            min_length: 7.0,
            fit_shared_points: true,
            merge: false,
            merge_gap_beams: 10,
            merge_gate: 11.0,
            corner_gap: 12.0,
            min_corner_angle_deg: 13.0,
            split_depth: 14,
            max_range: 15.0,
            merge_collinear: false,
            max_alpha_sd_deg: 17.0,
            grazing_noise: 18.0,
            same_turn_windows: false,
            fit_sigma: 20.0,
            per_turn: true,
            bridge_merge: false,
            footprint: 23.0,
            arc_chain: 24,
            arc_min_turn_deg: 25.0,
            arc_max_turn_deg: 26.0,
            split_budget: 27,
            merge_anchor_gate: 28.0,
            turn_offsets: false,
            merge_f_test: 30.0,
            arc_pairs: false,
        };
        assert_eq!(p, every);
        assert_eq!(FIELDS.len(), 31);
    }

    #[test]
    fn values_read_back_to_the_same_bits() {
        for preset in &PRESETS {
            let mut p = *crate::params::ValidParams::UNSET.get();
            for f in FIELDS {
                p.set(f.name, &(f.get)(&preset.params).to_string()).unwrap();
            }
            assert_eq!(
                format!("{p:?}"),
                format!("{:?}", preset.params),
                "{}",
                preset.name
            );
            assert_eq!(p, preset.params, "{}", preset.name);
            assert!(preset.params.validate().is_ok(), "{}", preset.name);
        }
    }

    #[test]
    fn text_is_checked_and_names_the_parameter() {
        let mut p = Params::DEFAULT;
        assert_eq!(p.set("no_such", "1"), Err(ParamError::UnknownName));
        p.set("max_range", "inf").unwrap();
        assert_eq!(p.max_range, f32::INFINITY);
        p.set("merge", "false").unwrap();
        assert!(!p.merge);
        p.set("split_depth", " 3 ").unwrap();
        assert_eq!(p.split_depth, 3);
        for (name, bad) in [
            ("merge", "yes"),
            ("merge", "1"),
            ("split_depth", "256"),
            ("split_depth", "-1"),
            ("min_points", "2.5"),
            ("sigma", "nan"),
            ("sigma", ""),
        ] {
            match p.set(name, bad) {
                Err(ParamError::BadValue { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}={bad}: {other:?}"),
            }
        }
        assert_eq!(p.get("split_depth"), Some(Value::Count(3)));
        assert_eq!(p.get("nope"), None);
    }

    #[test]
    fn presets_by_name() {
        assert_eq!(preset("default").map(|p| p.params), Some(Params::DEFAULT));
        assert_eq!(preset("v2").map(|p| p.params), Some(Params::V2));
        assert_eq!(preset("paper").map(|p| p.params), Some(Params::PAPER));
        assert!(preset("v1").is_none());
    }
}
