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

/// The values a parameter takes, as [`Params::validate`] checks them one
/// field at a time (a whole number is compared as its `f32`, exactly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Range {
    /// Every value of its type (a switch, or a count without bound).
    Any,
    /// Finite and > 0.
    Positive,
    /// Finite and ≥ 0.
    NonNegative,
    /// > 0, `+inf` included (no limit).
    PositiveOrInf,
    /// `lo ≤ x ≤ hi`.
    Between(f32, f32),
    /// `x ≥ lo`.
    AtLeast(f32),
    /// `x ≤ hi`.
    AtMost(f32),
    /// Checked together with other fields by [`Params::validate`] (the
    /// arcs' rule, [`ParamError::Arc`]); every value on its own.
    Joint,
}

impl Range {
    /// Whether `x` is in the range (NaN never is, but for [`Range::Any`]
    /// and [`Range::Joint`]).
    #[inline]
    pub const fn holds(self, x: f32) -> bool {
        match self {
            Range::Any | Range::Joint => true,
            Range::Positive => x.is_finite() && x > 0.0,
            Range::NonNegative => x.is_finite() && x >= 0.0,
            Range::PositiveOrInf => x > 0.0,
            Range::Between(lo, hi) => x >= lo && x <= hi,
            Range::AtLeast(lo) => x >= lo,
            Range::AtMost(hi) => x <= hi,
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
    /// The values it takes, as text: what an out-of-range value's
    /// [`ParamError::OutOfRange`] says after "must be".
    pub range: &'static str,
    /// The values it takes, as [`Params::validate`] checks them.
    pub bounds: Range,
    /// What it does, in one line.
    pub meaning: &'static str,
    /// Its value in some parameters.
    pub get: fn(&Params) -> Value,
    /// Set it from text: a number (`inf` for infinity), a whole number, or
    /// `true`/`false`. Not validated: [`Params::validate`] checks the whole.
    pub set: fn(&mut Params, &str) -> Result<(), ParamError>,
}

impl Field {
    /// The unit as messages and help texts name it: none for a pure number
    /// (`-`) or a switch (`bool`).
    pub const fn shown_unit(&self) -> Option<&'static str> {
        match self.unit.as_bytes() {
            b"-" | b"bool" => None,
            _ => Some(self.unit),
        }
    }
}

/// A range of the declaration as `(Range, text)`.
macro_rules! range {
    (any) => {
        (Range::Any, "any value")
    };
    (positive) => {
        (Range::Positive, "finite and > 0")
    };
    (non_negative) => {
        (Range::NonNegative, "finite and >= 0")
    };
    (positive_or_inf) => {
        (Range::PositiveOrInf, "> 0 or inf")
    };
    (between($lo:literal, $hi:literal)) => {
        (
            Range::Between($lo as f32, $hi as f32),
            concat!("between ", stringify!($lo), " and ", stringify!($hi)),
        )
    };
    (at_least($lo:literal)) => {
        (
            Range::AtLeast($lo as f32),
            concat!("at least ", stringify!($lo)),
        )
    };
    (at_most($hi:literal)) => {
        (
            Range::AtMost($hi as f32),
            concat!("at most ", stringify!($hi)),
        )
    };
    (joint($text:literal)) => {
        (Range::Joint, $text)
    };
}

/// A range of the declaration below, with its text.
type RangeOf = (Range, &'static str);
const ANY: RangeOf = range!(any);
const POSITIVE: RangeOf = range!(positive);
const NON_NEGATIVE: RangeOf = range!(non_negative);
const POSITIVE_OR_INF: RangeOf = range!(positive_or_inf);
const AT_LEAST_3: RangeOf = range!(at_least(3));
const AT_MOST_16: RangeOf = range!(at_most(16));
const DEGREES_0_TO_90: RangeOf = range!(between(0, 90));
const PASSES_1_TO_1000: RangeOf = range!(between(1, 1000));
const OFF_OR_AT_LEAST_2: RangeOf = range!(joint("0 (off) or at least 2"));
const UP_TO_ARC_MAX_TURN: RangeOf = range!(joint("between 0 and arc_max_turn_deg"));
const ARC_MIN_TURN_TO_180: RangeOf = range!(joint("between arc_min_turn_deg and 180"));

/// Whether the field value `$v` of type `$ty` is in `$range`.
macro_rules! holds {
    (bool, $range:expr, $v:expr) => {
        matches!($range, Range::Any)
    };
    (f32, $range:expr, $v:expr) => {
        $range.holds($v)
    };
    ($count:ident, $range:expr, $v:expr) => {
        $range.holds($v as f32)
    };
}

/// A value of the field type `$ty` from the sources.
macro_rules! take {
    (f32, $real:ident, $count:ident, $flag:ident) => {
        $real()
    };
    (u16, $real:ident, $count:ident, $flag:ident) => {
        $count()
    };
    (u8, $real:ident, $count:ident, $flag:ident) => {
        $count() as u8
    };
    (bool, $real:ident, $count:ident, $flag:ident) => {
        $flag()
    };
}

/// A field's value as [`Params::fingerprint`] hashes it: its low `bytes`
/// bytes of `bits`, least significant first.
#[derive(Clone, Copy)]
struct FieldBits {
    bits: u32,
    bytes: u32,
}

/// The [`FieldBits`] of a value `$v` of the field type `$ty`: an `f32` by
/// its bits (±0 as +0, as `==` sees them), a whole number by its 16 bits, a
/// switch as one byte.
macro_rules! field_bits {
    (f32, $v:expr) => {
        FieldBits {
            bits: if $v == 0.0 { 0 } else { $v.to_bits() },
            bytes: 4,
        }
    };
    (bool, $v:expr) => {
        FieldBits {
            bits: $v as u32,
            bytes: 1,
        }
    };
    ($count:ident, $v:expr) => {
        FieldBits {
            bits: $v as u32,
            bytes: 2,
        }
    };
}

/// FNV-1a (32 bits) of `hash` extended by `value`'s bytes.
const fn fnv1a(mut hash: u32, value: FieldBits) -> u32 {
    let mut k = 0;
    while k < value.bytes {
        hash ^= (value.bits >> (8 * k)) & 0xff;
        hash = hash.wrapping_mul(0x0100_0193);
        k += 1;
    }
    hash
}

/// The one declaration of the parameters: per field its name, the name of
/// its `const` setter, its type, unit, range, whether only a build with
/// feature `section10` runs it, and its meaning. Gives [`FIELDS`], the
/// setters (`Params::with_sigma`, …), the per-field range check and the
/// check of the host-only options, all in this order.
macro_rules! fields {
    ($($name:ident, $with:ident: $ty:ident, $unit:literal, $range:ident,
       $host_only:literal, $meaning:literal;)+) => {
        /// Every field of [`Params`], in declaration order.
        pub const FIELDS: &[Field] = &[$(Field {
            name: stringify!($name),
            unit: $unit,
            range: $range.1,
            bounds: $range.0,
            meaning: $meaning,
            get: |p: &Params| Value::from(p.$name),
            set: |p: &mut Params, text: &str| {
                p.$name = FromText::from_text(stringify!($name), text)?;
                Ok(())
            },
        },)+];

        /// The parameters only a build with feature `section10` runs (the
        /// host crates; the firmware leaves them out): any other value than
        /// the default fails validation elsewhere ([`ParamError::NotInBuild`]),
        /// and the co-processor paths of the host refuse them.
        pub const HOST_ONLY: &[&str] = {
            const ALL: [(&str, bool); FIELDS.len()] = [$((stringify!($name), $host_only),)+];
            const N: usize = {
                let mut n = 0;
                let mut i = 0;
                while i < ALL.len() {
                    n += ALL[i].1 as usize;
                    i += 1;
                }
                n
            };
            const NAMES: [&str; N] = {
                let mut names = [""; N];
                let (mut n, mut i) = (0, 0);
                while i < ALL.len() {
                    if ALL[i].1 {
                        names[n] = ALL[i].0;
                        n += 1;
                    }
                    i += 1;
                }
                names
            };
            &NAMES
        };

        impl Params {
            $(
                #[doc = concat!("These parameters with [`Params::", stringify!($name),
                                "`] set to `value` (", $unit, "; its range is in [`FIELDS`]).")]
                #[inline]
                #[must_use]
                pub const fn $with(mut self, value: $ty) -> Params {
                    self.$name = value;
                    self
                }
            )+

            /// Parameters with every field taken from a source of its type, in
            /// [`FIELDS`] order: `real` for the real numbers, `count` for the
            /// whole numbers (a field of 8 bits keeps the low 8), `flag` for the
            /// switches. Not validated. E.g. values an optimiser cannot see,
            /// or arbitrary ones for a property test.
            pub fn from_sources(
                mut real: impl FnMut() -> f32,
                mut count: impl FnMut() -> u16,
                mut flag: impl FnMut() -> bool,
            ) -> Params {
                let mut p = Params::DEFAULT;
                $(p.$name = take!($ty, real, count, flag);)+
                p
            }

            /// A 32-bit fingerprint of every field, in [`FIELDS`] order
            /// (FNV-1a over each value's bits; equal parameters give equal
            /// fingerprints). The firmware's console reports its build's
            /// (`params_fingerprint`), so that a host can tell whether it
            /// recomputes the firmware's features with the parameters the
            /// firmware runs (`host-bridge verify --qemu`).
            #[must_use]
            pub const fn fingerprint(&self) -> u32 {
                let mut hash = 0x811c_9dc5;
                $(
                    hash = fnv1a(hash, field_bits!($ty, self.$name));
                )+
                hash
            }

            /// The first field outside its own range (in [`FIELDS`] order),
            /// as `(name, range)`; the rules across fields are
            /// [`Params::validate`]'s.
            pub(super) const fn out_of_range(&self) -> Option<(&'static str, &'static str)> {
                $(
                    let (bounds, text) = $range;
                    if !holds!($ty, bounds, self.$name) {
                        return Some((stringify!($name), text));
                    }
                )+
                None
            }

            /// The option of [`HOST_ONLY`] set to another value than its
            /// default, if any.
            pub(super) const fn host_only_changed(&self) -> Option<&'static str> {
                $(
                    #[allow(clippy::float_cmp)]
                    let changed = self.$name != Params::DEFAULT.$name;
                    if $host_only && changed {
                        return Some(stringify!($name));
                    }
                )+
                None
            }
        }
    };
}

fields! {
    sigma, with_sigma: f32, "m", POSITIVE, false,
        "Range noise standard deviation of the smoothing filter and the segmentation";
    q, with_q: f32, "m²", NON_NEGATIVE, false,
        "Process noise of the smoothing filter, the second scale parameter";
    iterations, with_iterations: u16, "passes", PASSES_1_TO_1000, false,
        "Smoothing passes, the first scale parameter";
    tau, with_tau: f32, "-", POSITIVE, false,
        "Segmentation gate on D: a window above it breaks a segment";
    min_points, with_min_points: u16, "beams", AT_LEAST_3, false,
        "Smallest segment kept";
    max_chi2, with_max_chi2: f32, "-", POSITIVE, false,
        "Largest chi-square of an accepted line";
    min_length, with_min_length: f32, "m", NON_NEGATIVE, false,
        "Shortest accepted line, endpoint to endpoint";
    fit_shared_points, with_fit_shared_points: bool, "bool", ANY, false,
        "Fit a corner beam shared by two segments into both lines";
    merge, with_merge: bool, "bool", ANY, false,
        "Merge consecutive lines that agree";
    merge_gap_beams, with_merge_gap_beams: u16, "beams", ANY, false,
        "Most valid beams between two lines that may merge";
    merge_gate, with_merge_gate: f32, "chi2 (2 dof)", POSITIVE, false,
        "Gate of the merge test";
    corner_gap, with_corner_gap: f32, "m", NON_NEGATIVE, false,
        "Largest gap between facing endpoints of two lines made a corner";
    min_corner_angle_deg, with_min_corner_angle_deg: f32, "deg", DEGREES_0_TO_90, false,
        "Smallest angle between two lines for a well-conditioned corner";
    split_depth, with_split_depth: u8, "levels", AT_MOST_16, false,
        "Split before reject: times a segment that is not one line may be split (0 off)";
    max_range, with_max_range: f32, "m", POSITIVE_OR_INF, false,
        "Largest true range: a beam at or beyond it is invalid (inf: no limit)";
    merge_collinear, with_merge_collinear: bool, "bool", ANY, false,
        "Merge touching, nearly collinear lines whose union fits";
    max_alpha_sd_deg, with_max_alpha_sd_deg: f32, "deg", POSITIVE_OR_INF, false,
        "Largest standard deviation of a line's angle; a less certain line is dropped (inf: keep all)";
    grazing_noise, with_grazing_noise: f32, "-", NON_NEGATIVE, true,
        "Grazing-incidence term of the window noise (0 off; host builds only)";
    same_turn_windows, with_same_turn_windows: bool, "bool", ANY, false,
        "Windows of one mirror turn's beams in the interleaved 0.5° and 0.25° modes";
    fit_sigma, with_fit_sigma: f32, "m", NON_NEGATIVE, true,
        "Range noise of the line fits (0: sigma; host builds only)";
    per_turn, with_per_turn: bool, "bool", ANY, true,
        "Extract each mirror turn alone and fuse their lines (interleaved modes; host builds only)";
    bridge_merge, with_bridge_merge: bool, "bool", ANY, false,
        "Merge two accepted lines across the rejected segments between them when their union fits";
    footprint, with_footprint: f32, "rad", NON_NEGATIVE, false,
        "Beam-footprint term of the fits' range noise, sigma² + (footprint·d·tan θ)² (0 off)";
    arc_chain, with_arc_chain: u8, "lines", OFF_OR_AT_LEAST_2, false,
        "Fewest touching lines turning the same way that are dropped as an arc";
    arc_min_turn_deg, with_arc_min_turn_deg: f32, "deg", UP_TO_ARC_MAX_TURN, false,
        "Smallest turn between consecutive lines of an arc";
    arc_max_turn_deg, with_arc_max_turn_deg: f32, "deg", ARC_MIN_TURN_TO_180, false,
        "Largest turn between consecutive lines of an arc";
    split_budget, with_split_budget: u16, "beams", ANY, false,
        "Work bound of split before reject per frame, in beams tested (0: no bound)";
    merge_anchor_gate, with_merge_anchor_gate: f32, "chi2 (2 dof)", POSITIVE_OR_INF, false,
        "A merge keeps the union line within this of the larger line's own (inf: no test)";
    turn_offsets, with_turn_offsets: bool, "bool", ANY, false,
        "Line fits' chi-square allows an offset between interleaved mirror turns";
    merge_f_test, with_merge_f_test: f32, "F", NON_NEGATIVE, true,
        "Nested-model F test of the merges (0 off; host builds only)";
    arc_pairs, with_arc_pairs: bool, "bool", ANY, false,
        "Drop a pair of touching lines that a circle explains better";
    merge_own_beams, with_merge_own_beams: bool, "bool", ANY, false,
        "Merges refit the two lines' own beams, leaving out the beams between them";
    footprint_choice, with_footprint_choice: bool, "bool", ANY, false,
        "Each line takes the fit with or without the footprint term whose noise model its beams are likelier under";
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

/// The presets: `default` ([`Params::DEFAULT`]), `v3.2` ([`Params::V3_2`]),
/// `v3.1` ([`Params::V3_1`]), `v3.0` ([`Params::V3_0`]), `v2`
/// ([`Params::V2`]) and `paper` ([`Params::PAPER`]).
pub const PRESETS: [Preset; 6] = [
    Preset {
        name: "default",
        summary: "For extraction: ALGORITHM.md v2 with the additions measured in docs/ALGORITHM.md (the defaults)",
        params: Params::DEFAULT,
    },
    Preset {
        name: "v3.2",
        summary: "For comparison with ALGORITHM.md v3.2: the defaults with every line keeping the footprint weights",
        params: Params::V3_2,
    },
    Preset {
        name: "v3.1",
        summary: "For comparison with ALGORITHM.md v3.1: v3.2 at 30 smoothing passes and tau 9 (too slow for the MCU)",
        params: Params::V3_1,
    },
    Preset {
        name: "v3.0",
        summary: "For comparison with ALGORITHM.md v3.0: v3.1 with the merges refitting every beam between the lines",
        params: Params::V3_0,
    },
    Preset {
        name: "v2",
        summary: "For comparison with ALGORITHM.md v2 as written (with the collinear merge and the line-angle gate)",
        params: Params::V2,
    },
    Preset {
        name: "paper",
        summary: "For reproducing the seed paper: its method, ALGORITHM.md v1",
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
            merge_own_beams: false,
            footprint_choice: false,
        };
        assert_eq!(p, every);
        assert_eq!(FIELDS.len(), 33);
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
    fn the_fingerprint_tells_every_field_apart() {
        let base = Params::DEFAULT;
        assert_eq!(base.fingerprint(), Params::DEFAULT.fingerprint());
        assert_eq!(
            base.with_q(-0.0).fingerprint(),
            base.with_q(0.0).fingerprint()
        );
        let mut seen = std::vec![base.fingerprint()];
        for f in FIELDS {
            let mut p = base;
            let changed = match (f.get)(&base) {
                Value::Real(x) => std::format!("{}", if x == 1.0 { 2.0 } else { 1.0 }),
                Value::Count(n) => std::format!("{}", if n == 1 { 2 } else { 1 }),
                Value::Flag(b) => std::format!("{}", !b),
            };
            p.set(f.name, &changed).unwrap();
            assert_ne!(p, base, "{}", f.name);
            assert!(!seen.contains(&p.fingerprint()), "{}", f.name);
            seen.push(p.fingerprint());
        }
        let presets: std::vec::Vec<u32> = PRESETS.iter().map(|p| p.params.fingerprint()).collect();
        for (k, fp) in presets.iter().enumerate() {
            assert!(!presets[..k].contains(fp), "{}", PRESETS[k].name);
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

    /// The checks of every field as written out by hand, one by one: the
    /// table's ranges must accept and refuse exactly these.
    fn accepted_by_hand(p: &Params) -> bool {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let non_neg = |x: f32| x.is_finite() && x >= 0.0;
        pos(p.sigma)
            && non_neg(p.q)
            && (1..=1000).contains(&p.iterations)
            && pos(p.tau)
            && p.min_points >= 3
            && pos(p.max_chi2)
            && non_neg(p.min_length)
            && pos(p.merge_gate)
            && non_neg(p.corner_gap)
            && (0.0..=90.0).contains(&p.min_corner_angle_deg)
            && p.split_depth <= 16
            && p.max_range > 0.0
            && p.max_alpha_sd_deg > 0.0
            && non_neg(p.merge_f_test)
            && p.merge_anchor_gate > 0.0
            && non_neg(p.grazing_noise)
            && non_neg(p.fit_sigma)
            && non_neg(p.footprint)
    }

    #[test]
    fn the_ranges_accept_and_refuse_what_they_say() {
        let reals = [
            f32::NAN,
            f32::NEG_INFINITY,
            -1.0,
            -0.0,
            0.0,
            1e-30,
            0.5,
            2.0,
            89.9,
            90.0,
            90.01,
            180.0,
            1e30,
            f32::INFINITY,
        ];
        let counts = [0u16, 1, 2, 3, 16, 17, 255, 256, 1000, 1001, 65535];
        let mut tried = 0;
        for f in FIELDS {
            let values: Vec<String> = match (f.get)(&Params::DEFAULT) {
                Value::Real(_) => reals.iter().map(|x| x.to_string()).collect(),
                Value::Count(_) => counts.iter().map(|n| n.to_string()).collect(),
                Value::Flag(_) => vec!["true".into(), "false".into()],
            };
            for v in values {
                let mut p = Params::DEFAULT;
                if p.set(f.name, &v).is_err() {
                    continue; // not a value of the field's type
                }
                tried += 1;
                let out = p.out_of_range();
                assert_eq!(out.is_none(), accepted_by_hand(&p), "{}={v}", f.name);
                if let Some((name, range)) = out {
                    assert_eq!((name, range), (f.name, f.range), "{}={v}", f.name);
                    let e = p.validate().unwrap_err();
                    assert_eq!(e, ParamError::OutOfRange { name, range });
                    assert!(e
                        .to_string()
                        .starts_with(&format!("{name} must be {range}")));
                }
            }
        }
        assert!(tried > 250, "{tried}");
        let e = Params::DEFAULT.with_sigma(-1.0).validate().unwrap_err();
        assert_eq!(e.to_string(), "sigma must be finite and > 0 (m)");
        let e = Params::DEFAULT.with_tau(0.0).validate().unwrap_err();
        assert_eq!(e.to_string(), "tau must be finite and > 0");
        let e = Params::DEFAULT.with_iterations(0).validate().unwrap_err();
        assert_eq!(
            e.to_string(),
            "iterations must be between 1 and 1000 (passes)"
        );
    }

    #[test]
    fn the_setters_set_their_field_only() {
        let p = Params::DEFAULT
            .with_iterations(5)
            .with_tau(7.0)
            .with_merge(false);
        let mut q = Params::DEFAULT;
        q.iterations = 5;
        q.tau = 7.0;
        q.merge = false;
        assert_eq!(p, q);
        let (mut x, mut n, mut b) = (0.25f32, 0u16, false);
        let each = Params::from_sources(
            || {
                x += 1.5;
                x
            },
            || {
                n += 1;
                n
            },
            || {
                b = !b;
                b
            },
        );
        let mut values: Vec<String> = FIELDS
            .iter()
            .filter(|f| !matches!((f.get)(&each), Value::Flag(_)))
            .map(|f| (f.get)(&each).to_string())
            .collect();
        let n = values.len();
        values.sort();
        values.dedup();
        assert_eq!(values.len(), n, "two fields from one source value");
        assert_eq!(
            HOST_ONLY,
            ["grazing_noise", "fit_sigma", "per_turn", "merge_f_test"]
        );
    }

    #[test]
    fn presets_by_name() {
        assert_eq!(preset("default").map(|p| p.params), Some(Params::DEFAULT));
        assert_eq!(preset("v2").map(|p| p.params), Some(Params::V2));
        assert_eq!(preset("paper").map(|p| p.params), Some(Params::PAPER));
        assert!(preset("v1").is_none());
    }
}
