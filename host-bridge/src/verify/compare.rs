//! Bit-for-bit comparison of the co-processor's features with the
//! recomputed ones: every field of every item, floats by their bits.

use std::fmt;

use lms_core::{Features, Stats};

/// A field's value: a float (compared by its bits), an integer or a flag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// An `f32`, compared by its bits; every NaN equals every NaN.
    Float(f32),
    /// An integer.
    Int(u32),
    /// A flag.
    Flag(bool),
}

impl Value {
    /// Equal bit for bit (all NaNs are equal).
    pub fn same(self, other: Value) -> bool {
        match (self, other) {
            (Value::Float(a), Value::Float(b)) => {
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
            }
            (a, b) => a == b,
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Value::Float(x) => write!(f, "0x{:08X} ({x:?})", x.to_bits()),
            Value::Int(v) => write!(f, "0x{v:X} ({v})"),
            Value::Flag(b) => write!(f, "0x{:X} ({b})", u8::from(b)),
        }
    }
}

/// One field that differs between the co-processor's features and the
/// recomputed ones.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    /// The item: `segment 2`, `line 3`, `stats`, `lines` (for a count) …
    pub item: String,
    /// The field: `alpha`, `first`, `count`, `merges` …
    pub field: &'static str,
    /// The co-processor's value.
    pub got: Value,
    /// The recomputed value.
    pub want: Value,
}

impl fmt::Display for Difference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}: co-processor {}, recomputed {}",
            self.item, self.field, self.got, self.want
        )
    }
}

/// The fields of a line, in the order of the `D1` record.
fn line_fields(l: &lms_core::Line) -> [(&'static str, Value); 13] {
    use Value::{Float as F, Int as I};
    [
        ("alpha", F(l.alpha)),
        ("r", F(l.r)),
        ("cov_aa", F(l.cov.a)),
        ("cov_ar", F(l.cov.b)),
        ("cov_rr", F(l.cov.c)),
        ("chi2", F(l.chi2)),
        ("x0", F(l.endpoints[0][0])),
        ("y0", F(l.endpoints[0][1])),
        ("x1", F(l.endpoints[1][0])),
        ("y1", F(l.endpoints[1][1])),
        ("first", I(l.first.into())),
        ("last", I(l.last.into())),
        ("points", I(l.points.into())),
    ]
}

/// The fields of a corner, in the order of the `D2` record.
fn corner_fields(c: &lms_core::Corner) -> [(&'static str, Value); 9] {
    use Value::{Flag, Float as F, Int as I};
    [
        ("x", F(c.x)),
        ("y", F(c.y)),
        ("cov_xx", F(c.cov.a)),
        ("cov_xy", F(c.cov.b)),
        ("cov_yy", F(c.cov.c)),
        ("angle_deg", F(c.angle_deg)),
        ("well_conditioned", Flag(c.well_conditioned)),
        ("line_a", I(c.line_a.into())),
        ("line_b", I(c.line_b.into())),
    ]
}

/// Compare two lists item by item (fields from `fields`), then their lengths.
fn diff_list<T, const N: usize>(
    out: &mut Vec<Difference>,
    name: &str,
    plural: &str,
    got: &[T],
    want: &[T],
    fields: impl Fn(&T) -> [(&'static str, Value); N],
) {
    for (k, (a, b)) in got.iter().zip(want).enumerate() {
        for ((field, x), (_, y)) in fields(a).into_iter().zip(fields(b)) {
            if !x.same(y) {
                out.push(Difference {
                    item: format!("{name} {k}"),
                    field,
                    got: x,
                    want: y,
                });
            }
        }
    }
    if got.len() != want.len() {
        out.push(Difference {
            item: plural.to_string(),
            field: "count",
            got: Value::Int(got.len() as u32),
            want: Value::Int(want.len() as u32),
        });
    }
}

/// Every field in which `got` (the co-processor's) differs from `want` (the
/// recomputed features), in pipeline order: segments, edge points, lines,
/// corners, statistics. Empty if they are bit-identical.
pub fn differences(got: &Features, want: &Features) -> Vec<Difference> {
    let mut out = Vec::new();
    diff_list(
        &mut out,
        "segment",
        "segments",
        got.segments(),
        want.segments(),
        |s| {
            [
                ("first", Value::Int(s.first.into())),
                ("last", Value::Int(s.last.into())),
            ]
        },
    );
    let (got_edges, want_edges): (Vec<u16>, Vec<u16>) =
        (got.edges().iter().collect(), want.edges().iter().collect());
    diff_list(&mut out, "edge", "edges", &got_edges, &want_edges, |&e| {
        [("beam", Value::Int(e.into()))]
    });
    diff_list(
        &mut out,
        "line",
        "lines",
        got.lines(),
        want.lines(),
        line_fields,
    );
    diff_list(
        &mut out,
        "corner",
        "corners",
        got.corners(),
        want.corners(),
        corner_fields,
    );
    // The statistics the `D0` summary carries, in its order.
    for &(field, read) in &Stats::FIELDS[..Stats::D0_FIELDS] {
        let (x, y) = (read(got.stats()), read(want.stats()));
        if x != y {
            out.push(Difference {
                item: "stats".into(),
                field,
                got: Value::Int(x.into()),
                want: Value::Int(y.into()),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::maths::Sym2;

    fn features() -> Features {
        let mut f = Features::default();
        f.push_segment(lms_core::Segment { first: 3, last: 40 })
            .unwrap();
        f.push_edge(40).unwrap();
        f.push_line(lms_core::Line {
            alpha: 0.5,
            r: 2.0,
            cov: Sym2 {
                a: 1e-6,
                b: 0.0,
                c: 4e-6,
            },
            first: 3,
            last: 40,
            points: 38,
            chi2: f32::NAN,
            endpoints: [[1.0, 2.0], [3.0, 4.0]],
        })
        .unwrap();
        f.stats_mut().valid_beams = 361;
        f
    }

    #[test]
    fn verify_differences_by_bits_nans_equal() {
        let a = features();
        let mut b = a.clone();
        // A different NaN is still equal; identical otherwise.
        b.lines_mut()[0].chi2 = f32::from_bits(0x7FC0_0001);
        assert!(differences(&a, &b).is_empty());
        // One ulp in r, and -0.0 vs 0.0 in cov αr: two float differences.
        b.lines_mut()[0].r = f32::from_bits(2.0f32.to_bits() + 1);
        b.lines_mut()[0].cov.b = -0.0;
        b.stats_mut().merges = 1;
        let d = differences(&a, &b);
        assert_eq!(d.len(), 3, "{d:?}");
        assert_eq!((d[0].item.as_str(), d[0].field), ("line 0", "r"));
        assert_eq!(
            d[0].to_string(),
            "line 0 r: co-processor 0x40000000 (2.0), recomputed 0x40000001 (2.0000002)"
        );
        assert_eq!(d[1].field, "cov_ar");
        assert_eq!((d[2].item.as_str(), d[2].field), ("stats", "merges"));
        // A missing edge: the count.
        let mut c = Features::default();
        for &s in a.segments() {
            c.push_segment(s).unwrap();
        }
        for &l in a.lines() {
            c.push_line(l).unwrap();
        }
        *c.stats_mut() = *a.stats();
        let d = differences(&a, &c);
        assert_eq!(
            d[0].to_string(),
            "edges count: co-processor 0x1 (1), recomputed 0x0 (0)"
        );
    }
}
