//! The results on every shared log, pinned: the feature bits of every frame
//! of the seven recorded logs of `../shared/data/carmen` at the
//! ALGORITHM.md defaults (30 passes) must hash to the digests below. A
//! change of any bit of any smoothed range, `D`, edge, segment, line,
//! corner or counter of any frame fails this test.
//!
//! Re-pinned when the core's sines, cosines and `atan2` moved from libm's
//! `cosf`/`sinf`/`atan2f` (f64 inside, or 600 B) to `maths::cos_sin` and
//! `maths::atan2` (f32 only, 7.2 KB less flash on the M4F): smoothed
//! ranges, `D`, edges, segments and counters kept every bit; about half of
//! the lines moved, on CSAIL by at most 5.8e-6 rad in α and 2.1e-5 m in r
//! (Örebro 1.6e-6 rad, 3.3e-6 m); well-conditioned corners by at most
//! 1.3 µm; ill-conditioned ones (flag cleared) by up to 0.16 m, at 179 m
//! with σ of kilometres (`atan2` alone: α by one ulp, 2.4e-7 rad).
//!
//! Re-pinned when the defaults took the footprint-weighted fits and the
//! merge across rejected segments (ALGORITHM.md §10 (e), (f); stop 21):
//! the digests before are those of `Params::V2`, checked below, so the old
//! behaviour stays reachable bit for bit.
//!
//! Stop 22: the defaults drop the lines of arcs (`Params::arc_chain`), and
//! `Stats` gained the counter `rejected_arc`, so every frame's `stats`
//! line gained `, rejected_arc: 0` where nothing is dropped. The digests
//! pinned before are checked as they were, at `Params::STOP21` and
//! `Params::V2`, with that text taken out ([`WithoutArcCounter`]): every
//! other bit of every frame is as pinned. The new defaults have their own
//! digests.
//!
//! Stop 23: the defaults take same-turn windows (`Params::same_turn_windows`,
//! ALGORITHM.md §10 (a)) in the interleaved 0.5° modes. Stop 22's digests
//! are checked as they were, at `Params::STOP22`; the new defaults have
//! their own.
//!
//! Stop 24: the defaults gate the merges on the larger line's own
//! parameters (`Params::merge_anchor_gate`) and take the turns' offsets out
//! of the fits' χ² in the 0.5° modes (`Params::turn_offsets`). Stop 23's
//! digests are checked as they were, at `Params::STOP23`; the new defaults
//! have their own.
//!
//! To re-pin after an intended change of results (say why in the commit):
//! `cargo run --release -p feature-bits -- LOG` and FNV-1a-64 its output
//! (`feature_bits::digest_of`), or read the digests this test prints.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

#[cfg(not(feature = "libm-trig"))]
use feature_bits::{per_data_params, write_log_bits};
use feature_bits::{write_log_bits_with, Fnv64};

/// (log stem, FNV-1a-64 of the feature bits, frames) at `Params::V2`, 30
/// passes (the defaults up to stop 20).
#[cfg(not(feature = "libm-trig"))]
const PINNED_V2: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x6ebae6f9863f5531, 861),
    ("belgioioso-corrected", 0xe74b61b71ab4085f, 395),
    ("csail-corrected", 0x2aef7e7d56bac119, 406),
    ("freiburg-101-corrected", 0x3b7aa069123bdcae, 292),
    ("freiburg-campus-corrected", 0x51eb7aa6a4d3eef4, 2008),
    ("intel-corrected", 0x0f87d6a25a9acae5, 910),
    ("orebro-corrected", 0xb82e116bd3e06034, 237),
];

/// With libm's `cosf`/`sinf`/`atan2f` (feature `libm-trig`, ALGORITHM.md §9
/// as written) at `Params::V2`: the digests pinned before the core had its
/// own forms, so that behaviour stays reachable bit for bit
/// (`cargo test -p feature-bits --features libm-trig --test digests`).
#[cfg(feature = "libm-trig")]
const PINNED_V2: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0xf0d32dddc9de977a, 861),
    ("belgioioso-corrected", 0xc3f785b5bc14c817, 395),
    ("csail-corrected", 0xe9bcddc73a5fe2b0, 406),
    ("freiburg-101-corrected", 0xee4a2c29de0ffe99, 292),
    ("freiburg-campus-corrected", 0x0a4538fb5d45d88e, 2008),
    ("intel-corrected", 0x614af93f50ea9151, 910),
    ("orebro-corrected", 0x0304a0f320ecf355, 237),
];

fn log(stem: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/carmen")
        .join(format!("{stem}.log.gz"))
}

/// (log stem, FNV-1a-64 of the feature bits, frames) at `Params::default`,
/// 30 passes.
#[cfg(not(feature = "libm-trig"))]
const PINNED: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x3fd2675e26bb39dc, 861),
    ("belgioioso-corrected", 0x3908bce88a7db6d7, 395),
    ("csail-corrected", 0x0a89b0ef9fe8ed12, 406),
    ("freiburg-101-corrected", 0xa7666d445f566abe, 292),
    ("freiburg-campus-corrected", 0xb28a2bf3b7a4b1f1, 2008),
    ("intel-corrected", 0x995db2487c2251e4, 910),
    ("orebro-corrected", 0xe720b6fb012a9a3f, 237),
];

/// The same at `Params::STOP24` (the defaults of stop 24: pairs of lines
/// on a curve kept).
#[cfg(not(feature = "libm-trig"))]
const PINNED_STOP24: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x3fd2675e26bb39dc, 861),
    ("belgioioso-corrected", 0x68758aa19d2330ee, 395),
    ("csail-corrected", 0x9c838733fe481d31, 406),
    ("freiburg-101-corrected", 0xa7666d445f566abe, 292),
    ("freiburg-campus-corrected", 0xac44a5bcdb719bd4, 2008),
    ("intel-corrected", 0xfc7b49087a123459, 910),
    ("orebro-corrected", 0xe720b6fb012a9a3f, 237),
];

/// The same at `Params::STOP23` (the defaults of stop 23: no anchor gate on
/// the merges).
#[cfg(not(feature = "libm-trig"))]
const PINNED_STOP23: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x24ed53cce9a29316, 861),
    ("belgioioso-corrected", 0xa0cb8ce620b6ffe5, 395),
    ("csail-corrected", 0x79584256c0057d1f, 406),
    ("freiburg-101-corrected", 0x50eca2953d8310c3, 292),
    ("freiburg-campus-corrected", 0x2683e56940809f35, 2008),
    ("intel-corrected", 0xad71a8bdfa4237b8, 910),
    ("orebro-corrected", 0xee57028d62c2f364, 237),
];

/// The same at `Params::STOP22` (the defaults of stop 22: the windows of
/// §2–6 in every mode).
#[cfg(not(feature = "libm-trig"))]
const PINNED_STOP22: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x24ed53cce9a29316, 861),
    ("belgioioso-corrected", 0x2743f09b450eb760, 395),
    ("csail-corrected", 0x58173c8a6729017c, 406),
    ("freiburg-101-corrected", 0xf3e45852f2fb8d7d, 292),
    ("freiburg-campus-corrected", 0x79697a5bde364063, 2008),
    ("intel-corrected", 0xad71a8bdfa4237b8, 910),
    ("orebro-corrected", 0xee57028d62c2f364, 237),
];

/// The same at `Params::STOP21` (the defaults of stop 21: no arcs dropped),
/// without the `rejected_arc` counter ([`WithoutArcCounter`]).
#[cfg(not(feature = "libm-trig"))]
const PINNED_STOP21: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x8f0f7db9f9d29277, 861),
    ("belgioioso-corrected", 0xe3bbcf6cdcd894f7, 395),
    ("csail-corrected", 0x86c3cced0b747d9c, 406),
    ("freiburg-101-corrected", 0xb558ced1acf8e17b, 292),
    ("freiburg-campus-corrected", 0x003450ef44cb2219, 2008),
    ("intel-corrected", 0x2c471986b13d5aeb, 910),
    ("orebro-corrected", 0xd4588364ce8a1fd3, 237),
];

/// A writer that takes `, rejected_arc: 0` out of each line before passing
/// it on: the feature bits as written before `Stats` had that counter.
struct WithoutArcCounter<W: Write> {
    inner: W,
    line: Vec<u8>,
}

impl<W: Write> WithoutArcCounter<W> {
    const TEXT: &'static [u8] = b", rejected_arc: 0";

    fn new(inner: W) -> Self {
        WithoutArcCounter {
            inner,
            line: Vec::new(),
        }
    }

    fn flush_line(&mut self) -> io::Result<()> {
        let line = std::mem::take(&mut self.line);
        match line.windows(Self::TEXT.len()).position(|w| w == Self::TEXT) {
            Some(at) => {
                self.inner.write_all(&line[..at])?;
                self.inner.write_all(&line[at + Self::TEXT.len()..])
            }
            None => self.inner.write_all(&line),
        }
    }
}

impl<W: Write> Write for WithoutArcCounter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        for &b in buf {
            self.line.push(b);
            if b == b'\n' {
                self.flush_line()?;
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.flush_line()?;
        self.inner.flush()
    }
}

/// FNV-1a-64 of the feature bits as written, and of the same bits as
/// written before `Stats` had `rejected_arc`, from one run.
struct Digests {
    full: Fnv64,
    without_arc_counter: WithoutArcCounter<Fnv64>,
}

impl Write for Digests {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.full.write_all(buf)?;
        self.without_arc_counter.write_all(buf)?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.without_arc_counter.flush()
    }
}

/// The feature bits of the log at `path` with `params`, hashed: (digest,
/// digest without the `rejected_arc` counter, frames).
fn digests(path: &Path, params: &lms_core::Params) -> (u64, u64, usize) {
    let mut d = Digests {
        full: Fnv64::default(),
        without_arc_counter: WithoutArcCounter::new(Fnv64::default()),
    };
    let n = write_log_bits_with(path, params, &mut d).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (../shared must sit beside the repo)",
            path.display()
        )
    });
    d.flush().unwrap();
    (d.full.0, d.without_arc_counter.inner.0, n)
}

/// Every log of `pinned` at `params` (30 passes), with or without the
/// `rejected_arc` counter: the digests that differ.
fn check_pins(
    pinned: &[(&str, u64, usize)],
    params: &lms_core::Params,
    without_arc_counter: bool,
) -> Vec<String> {
    let mut wrong = Vec::new();
    let params = lms_core::Params {
        iterations: 30,
        ..*params
    };
    for &(stem, pin, frames) in pinned {
        let (full, without, n) = digests(&log(stem), &params);
        let d = if without_arc_counter { without } else { full };
        println!("(\"{stem}\", 0x{d:016x}, {n}),");
        if (d, n) != (pin, frames) {
            wrong.push(format!(
                "{stem}: 0x{d:016x} over {n} frames, pinned 0x{pin:016x} over {frames}"
            ));
        }
    }
    wrong
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_are_pinned() {
    let wrong = check_pins(&PINNED, &lms_core::Params::default(), false);
    assert!(wrong.is_empty(), "results changed:\n{}", wrong.join("\n"));
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_stop_24_are_pinned() {
    let wrong = check_pins(&PINNED_STOP24, &lms_core::Params::STOP24, false);
    assert!(
        wrong.is_empty(),
        "stop-24 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_stop_23_are_pinned() {
    let wrong = check_pins(&PINNED_STOP23, &lms_core::Params::STOP23, false);
    assert!(
        wrong.is_empty(),
        "stop-23 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_stop_22_are_pinned() {
    let wrong = check_pins(&PINNED_STOP22, &lms_core::Params::STOP22, false);
    assert!(
        wrong.is_empty(),
        "stop-22 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_stop_21_are_pinned() {
    let wrong = check_pins(&PINNED_STOP21, &lms_core::Params::STOP21, true);
    assert!(
        wrong.is_empty(),
        "stop-21 results changed:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn feature_bits_of_every_shared_log_at_v2_are_pinned() {
    let wrong = check_pins(&PINNED_V2, &lms_core::Params::V2, true);
    assert!(
        wrong.is_empty(),
        "v2 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn a_changed_bit_changes_the_digest() {
    // The check can fail: one more pass changes the digest of a log.
    let path = log("orebro-corrected");
    let (mut a, mut b) = (Fnv64::default(), Fnv64::default());
    write_log_bits(&path, 30, &mut a).unwrap();
    write_log_bits(&path, 31, &mut b).unwrap();
    assert_ne!(a.0, b.0);
    assert_eq!(a.0, PINNED[6].1);
}

/// (log stem, σ (m), `max_range` (m), digests: defaults, stop 24, stop 23,
/// stop 22, stop 21, v2).
#[cfg(not(feature = "libm-trig"))]
type PerDataPin = (&'static str, f32, f32, u64, u64, u64, u64, u64, u64);

/// With the parameters `host-bridge extract LOG` uses when no flag is given
/// (issue 14, item 4: σ and `max_range` from the survey of the log,
/// [`per_data_params`]), 30 passes: (log stem, σ (m), `max_range` (m),
/// FNV-1a-64 of the feature bits). σ is 1 cm on the cm logs, 30 mm on
/// Acapulco's 5 cm steps and 5 mm on Örebro (mm); `max_range` is the unit's
/// and mode's largest true range, and 50 m on Acapulco, below its ~51 m fill
/// values. (Örebro has no range beyond its limit: its digest is the one at
/// `Params::default`.) `host-bridge`'s
/// `extract_cli::per_data_defaults_match_the_pinned_feature_bits` checks
/// that its `defaults::for_log` gives these same parameters. The last five
/// columns are the digests with `Params::STOP24`, `Params::STOP23`,
/// `Params::STOP22`, `Params::STOP21` and `Params::V2` otherwise (pinned at
/// stops 24, 23, 22 and 21 and up to stop 20), the last two without the
/// `rejected_arc` counter ([`WithoutArcCounter`]).
#[cfg(not(feature = "libm-trig"))]
const PINNED_PER_DATA: [PerDataPin; 7] = [
    (
        "acapulco-corrected",
        0.030000001,
        50.0,
        0xd7e2f9506260af05,
        0xff362eae488123ab,
        0x456597c9d8b236ef,
        0x456597c9d8b236ef,
        0xcfa1b3384b29e6f2,
        0xbb10e8ac21ee7a2d,
    ),
    (
        "belgioioso-corrected",
        0.01,
        81.83,
        0x898fc07de11d58a7,
        0x898fc07de11d58a7,
        0x04407f65d761c00e,
        0xc2c8950c6374724d,
        0xcf25f846ba026f7e,
        0x537d9d69c2ff323b,
    ),
    (
        "csail-corrected",
        0.01,
        81.83,
        0x82e4874b6425520e,
        0x82e4874b6425520e,
        0x4373d6154e313a6d,
        0xeed794a1b8ba1c99,
        0x5498b108e1913fa7,
        0xd99b305f2acf4ee8,
    ),
    (
        "freiburg-101-corrected",
        0.01,
        81.83,
        0xd29bd4544d235609,
        0xd29bd4544d235609,
        0xb63357291e3ad9e8,
        0x47dce9c54f84e796,
        0x466d8dff9805249e,
        0x7ef20b88b6223797,
    ),
    (
        "freiburg-campus-corrected",
        0.01,
        81.83,
        0xd1d07c6f0d1ea572,
        0x02ae4a2203de1483,
        0x1710d46adb43c02b,
        0x43b22e4e673cb55e,
        0x9e88244309cea3ee,
        0xbe0ab76a3c025330,
    ),
    (
        "intel-corrected",
        0.01,
        81.83,
        0x5d872066b9cfec79,
        0xf5959bee1126b7fc,
        0xe3cf0b3e0d27c2db,
        0xe3cf0b3e0d27c2db,
        0xe90a374b585ed343,
        0x5d105f0e8dcf1438,
    ),
    (
        "orebro-corrected",
        0.005,
        32.759,
        0xe720b6fb012a9a3f,
        0xe720b6fb012a9a3f,
        0xee57028d62c2f364,
        0xee57028d62c2f364,
        0xd4588364ce8a1fd3,
        0xb82e116bd3e06034,
    ),
];

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_at_the_per_data_defaults_are_pinned() {
    let mut wrong = Vec::new();
    for (stem, sigma, max_range, pin, pin_stop24, pin_stop23, pin_stop22, pin_stop21, pin_v2) in
        PINNED_PER_DATA
    {
        let path = log(stem);
        let params = per_data_params(&path).unwrap();
        let stop24 = lms_core::Params {
            arc_pairs: false,
            ..params
        };
        let stop23 = lms_core::Params {
            merge_anchor_gate: f32::INFINITY,
            turn_offsets: false,
            ..stop24
        };
        let stop22 = lms_core::Params {
            same_turn_windows: false,
            split_budget: 0,
            ..stop23
        };
        let stop21 = lms_core::Params {
            arc_chain: 0,
            ..stop22
        };
        let v2 = lms_core::Params {
            bridge_merge: false,
            footprint: 0.0,
            ..stop21
        };
        assert_eq!(
            v2,
            lms_core::Params {
                sigma,
                max_range,
                ..lms_core::Params::V2
            }
        );
        let (d, _, _) = digests(&path, &params);
        let (d24, _, _) = digests(&path, &stop24);
        let (d23, _, _) = digests(&path, &stop23);
        let (d22, d22_without, _) = digests(&path, &stop22);
        let (_, d21, _) = digests(&path, &stop21);
        // No line of these logs is taken for an arc at stop 22: but for the
        // counter, stop 22 gives the features of stop 21, bit for bit.
        assert_eq!(
            d22_without, pin_stop21,
            "{stem}: a line of a real log dropped as an arc"
        );
        let (_, d2, _) = digests(&path, &v2);
        println!(
            "(\"{stem}\", {:?}, {:?}, 0x{d:016x}, 0x{d24:016x}, 0x{d23:016x}, 0x{d22:016x}, \
             0x{d21:016x}, 0x{d2:016x}),",
            params.sigma, params.max_range
        );
        if (params.sigma, params.max_range, d, d24, d23, d22, d21, d2)
            != (
                sigma, max_range, pin, pin_stop24, pin_stop23, pin_stop22, pin_stop21, pin_v2,
            )
        {
            wrong.push(format!(
                "{stem}: σ {} m, max_range {} m, 0x{d:016x}, stop 24 0x{d24:016x}, stop 23 \
                 0x{d23:016x}, stop 22 0x{d22:016x}, stop 21 0x{d21:016x}, v2 0x{d2:016x}; \
                 pinned {sigma}, {max_range}, 0x{pin:016x}, 0x{pin_stop24:016x}, \
                 0x{pin_stop23:016x}, 0x{pin_stop22:016x}, 0x{pin_stop21:016x}, 0x{pin_v2:016x}",
                params.sigma, params.max_range
            ));
        }
        // Only σ and the range limit come from the data.
        let defaults = lms_core::Params {
            sigma: params.sigma,
            max_range: params.max_range,
            ..lms_core::Params::default()
        };
        assert_eq!(params, defaults, "{stem}");
    }
    assert!(
        wrong.is_empty(),
        "per-data results changed:\n{}",
        wrong.join("\n")
    );
}
