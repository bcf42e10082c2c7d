//! The results on every shared log, pinned: the feature bits of every frame
//! of the seven recorded logs of `../shared/data/carmen` must hash to the
//! digests below. A change of any bit of any smoothed range,
//! `D`, edge, segment, line, corner or counter of any frame fails this test.
//!
//! Pinned at the defaults, at `Params::V3_1` (30 smoothing passes with
//! τ = 9), and at `Params::V3_1` less some of its measured additions, so
//! that each set stays reachable bit for bit:
//! `Params::V3_0` (the merges refitting every beam between the lines),
//! [`ARC_PAIRS_KEPT`] (and pairs of lines on a curve kept), [`NO_ANCHOR_GATE`]
//! (and no anchor gate on the merges, no turn offsets in the fits' χ²),
//! [`CONSECUTIVE_WINDOWS`] (and the windows of §2–6 in every mode, no work
//! bound on split before reject), [`ARCS_KEPT`] (and no lines of arcs
//! dropped) and `Params::V2` (and no footprint weights, no merge across
//! rejected segments: ALGORITHM.md v2). With arcs kept the `rejected_arc`
//! counter is always 0, and the last two are pinned with its text taken out
//! of each frame's `stats` line ([`WithoutArcCounter`]).
//!
//! The core's sines, cosines and `atan2` are its own f32-only forms
//! (`maths::cos_sin`, `maths::atan2`); with libm's `cosf`/`sinf`/`atan2f`
//! (feature `libm-trig`, ALGORITHM.md §9 as written) `Params::V2` has
//! digests of its own, also pinned.
//!
//! To re-pin after an intended change of results (say why in the commit):
//! `cargo run --release -p feature-bits -- LOG` and FNV-1a-64 its output
//! (`feature_bits::digest_of`), or read the digests this test prints.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

#[cfg(not(feature = "libm-trig"))]
use feature_bits::{per_data_params, write_log_bits};
use feature_bits::{write_log_bits_with, Fnv64};
use lms_core::Params;

/// `Params::V3_0` (the defaults with the merges refitting every beam
/// between the lines) with pairs of lines kept whatever a circle says of
/// them.
#[cfg(not(feature = "libm-trig"))]
const ARC_PAIRS_KEPT: Params = Params::V3_0.with_arc_pairs(false);

/// [`ARC_PAIRS_KEPT`] with no anchor gate on the merges and no turn offsets
/// in the fits' χ².
#[cfg(not(feature = "libm-trig"))]
const NO_ANCHOR_GATE: Params = ARC_PAIRS_KEPT
    .with_merge_anchor_gate(f32::INFINITY)
    .with_turn_offsets(false);

/// [`NO_ANCHOR_GATE`] with the windows of §2–6 (consecutive beams) in every
/// mode and no work bound on split before reject.
#[cfg(not(feature = "libm-trig"))]
const CONSECUTIVE_WINDOWS: Params = NO_ANCHOR_GATE
    .with_same_turn_windows(false)
    .with_split_budget(0);

/// [`CONSECUTIVE_WINDOWS`] with no lines of arcs dropped; with no footprint
/// weights and no merge across rejected segments too it is `Params::V2`.
#[cfg(not(feature = "libm-trig"))]
const ARCS_KEPT: Params = CONSECUTIVE_WINDOWS.with_arc_chain(0);

/// (log stem, FNV-1a-64 of the feature bits, frames) at `Params::V2`,
/// without the `rejected_arc` counter.
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
/// as written) at `Params::V2`, so that behaviour stays reachable bit for bit
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

/// (log stem, FNV-1a-64 of the feature bits, frames) at `Params::default`.
#[cfg(not(feature = "libm-trig"))]
const PINNED: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x21b4247459cb1bb4, 861),
    ("belgioioso-corrected", 0x083929fab599372b, 395),
    ("csail-corrected", 0x34aaa2a7ded6509e, 406),
    ("freiburg-101-corrected", 0x05d892fb930d39ec, 292),
    ("freiburg-campus-corrected", 0xedc5fe8834658682, 2008),
    ("intel-corrected", 0x73840e8990b9d108, 910),
    ("orebro-corrected", 0x8f6da1e5aca24ad7, 237),
];

/// The same at `Params::V3_2` (every line keeps its footprint weights).
#[cfg(not(feature = "libm-trig"))]
const PINNED_V3_2: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x8e87be236306a2c5, 861),
    ("belgioioso-corrected", 0xc6abfa6fe636b088, 395),
    ("csail-corrected", 0x04ee2743b6d501f2, 406),
    ("freiburg-101-corrected", 0x3c2945be5cc56759, 292),
    ("freiburg-campus-corrected", 0xcf7ba862fee9fde7, 2008),
    ("intel-corrected", 0x661e7a45036bce89, 910),
    ("orebro-corrected", 0xf558b3ea5241cc91, 237),
];

/// The same at `Params::V3_1`.
#[cfg(not(feature = "libm-trig"))]
const PINNED_V3_1: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x6b4fb7b476cf0741, 861),
    ("belgioioso-corrected", 0xdbb83249a14d9650, 395),
    ("csail-corrected", 0x82ff31945ffeae51, 406),
    ("freiburg-101-corrected", 0x979ba687504629d8, 292),
    ("freiburg-campus-corrected", 0x50aec1b8e05345ed, 2008),
    ("intel-corrected", 0x5b967dabc42b171c, 910),
    ("orebro-corrected", 0x1a565d843f54b931, 237),
];

/// The same at `Params::V3_0`.
#[cfg(not(feature = "libm-trig"))]
const PINNED_V3_0: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x3fd2675e26bb39dc, 861),
    ("belgioioso-corrected", 0x3908bce88a7db6d7, 395),
    ("csail-corrected", 0x0a89b0ef9fe8ed12, 406),
    ("freiburg-101-corrected", 0xa7666d445f566abe, 292),
    ("freiburg-campus-corrected", 0xb28a2bf3b7a4b1f1, 2008),
    ("intel-corrected", 0x995db2487c2251e4, 910),
    ("orebro-corrected", 0xe720b6fb012a9a3f, 237),
];

/// The same at [`ARC_PAIRS_KEPT`].
#[cfg(not(feature = "libm-trig"))]
const PINNED_ARC_PAIRS_KEPT: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x3fd2675e26bb39dc, 861),
    ("belgioioso-corrected", 0x68758aa19d2330ee, 395),
    ("csail-corrected", 0x9c838733fe481d31, 406),
    ("freiburg-101-corrected", 0xa7666d445f566abe, 292),
    ("freiburg-campus-corrected", 0xac44a5bcdb719bd4, 2008),
    ("intel-corrected", 0xfc7b49087a123459, 910),
    ("orebro-corrected", 0xe720b6fb012a9a3f, 237),
];

/// The same at [`NO_ANCHOR_GATE`].
#[cfg(not(feature = "libm-trig"))]
const PINNED_NO_ANCHOR_GATE: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x24ed53cce9a29316, 861),
    ("belgioioso-corrected", 0xa0cb8ce620b6ffe5, 395),
    ("csail-corrected", 0x79584256c0057d1f, 406),
    ("freiburg-101-corrected", 0x50eca2953d8310c3, 292),
    ("freiburg-campus-corrected", 0x2683e56940809f35, 2008),
    ("intel-corrected", 0xad71a8bdfa4237b8, 910),
    ("orebro-corrected", 0xee57028d62c2f364, 237),
];

/// The same at [`CONSECUTIVE_WINDOWS`].
#[cfg(not(feature = "libm-trig"))]
const PINNED_CONSECUTIVE_WINDOWS: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x24ed53cce9a29316, 861),
    ("belgioioso-corrected", 0x2743f09b450eb760, 395),
    ("csail-corrected", 0x58173c8a6729017c, 406),
    ("freiburg-101-corrected", 0xf3e45852f2fb8d7d, 292),
    ("freiburg-campus-corrected", 0x79697a5bde364063, 2008),
    ("intel-corrected", 0xad71a8bdfa4237b8, 910),
    ("orebro-corrected", 0xee57028d62c2f364, 237),
];

/// The same at [`ARCS_KEPT`], without the `rejected_arc` counter
/// ([`WithoutArcCounter`]).
#[cfg(not(feature = "libm-trig"))]
const PINNED_ARCS_KEPT: [(&str, u64, usize); 7] = [
    ("acapulco-corrected", 0x8f0f7db9f9d29277, 861),
    ("belgioioso-corrected", 0xe3bbcf6cdcd894f7, 395),
    ("csail-corrected", 0x86c3cced0b747d9c, 406),
    ("freiburg-101-corrected", 0xb558ced1acf8e17b, 292),
    ("freiburg-campus-corrected", 0x003450ef44cb2219, 2008),
    ("intel-corrected", 0x2c471986b13d5aeb, 910),
    ("orebro-corrected", 0xd4588364ce8a1fd3, 237),
];

/// A writer that takes `, rejected_arc: 0` out of each line before passing
/// it on: the feature bits without that counter.
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

/// FNV-1a-64 of the feature bits as written, and of the same bits without
/// the `rejected_arc` counter, from one run.
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
fn digests(path: &Path, params: &Params) -> (u64, u64, usize) {
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

/// Every log of `pinned` at `params`, with or without the
/// `rejected_arc` counter: the digests that differ.
fn check_pins(
    pinned: &[(&str, u64, usize)],
    params: &Params,
    without_arc_counter: bool,
) -> Vec<String> {
    let mut wrong = Vec::new();
    for &(stem, pin, frames) in pinned {
        let (full, without, n) = digests(&log(stem), params);
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
    let wrong = check_pins(&PINNED, &Params::default(), false);
    assert!(wrong.is_empty(), "results changed:\n{}", wrong.join("\n"));
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_v3_2_are_pinned() {
    let wrong = check_pins(&PINNED_V3_2, &Params::V3_2, false);
    assert!(
        wrong.is_empty(),
        "v3.2 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_v3_1_are_pinned() {
    let wrong = check_pins(&PINNED_V3_1, &Params::V3_1, false);
    assert!(
        wrong.is_empty(),
        "v3.1 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_at_v3_0_are_pinned() {
    let wrong = check_pins(&PINNED_V3_0, &Params::V3_0, false);
    assert!(
        wrong.is_empty(),
        "v3.0 results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_with_arc_pairs_kept_are_pinned() {
    let wrong = check_pins(&PINNED_ARC_PAIRS_KEPT, &ARC_PAIRS_KEPT, false);
    assert!(
        wrong.is_empty(),
        "arc-pairs-kept results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_without_the_anchor_gate_are_pinned() {
    let wrong = check_pins(&PINNED_NO_ANCHOR_GATE, &NO_ANCHOR_GATE, false);
    assert!(
        wrong.is_empty(),
        "no-anchor-gate results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_with_consecutive_windows_are_pinned() {
    let wrong = check_pins(&PINNED_CONSECUTIVE_WINDOWS, &CONSECUTIVE_WINDOWS, false);
    assert!(
        wrong.is_empty(),
        "consecutive-windows results changed:\n{}",
        wrong.join("\n")
    );
}

#[cfg(not(feature = "libm-trig"))]
#[test]
fn feature_bits_of_every_shared_log_with_arcs_kept_are_pinned() {
    let wrong = check_pins(&PINNED_ARCS_KEPT, &ARCS_KEPT, true);
    assert!(
        wrong.is_empty(),
        "arcs-kept results changed:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn feature_bits_of_every_shared_log_at_v2_are_pinned() {
    let wrong = check_pins(&PINNED_V2, &Params::V2, true);
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
    let passes = Params::DEFAULT.iterations;
    write_log_bits(&path, passes, &mut a).unwrap();
    write_log_bits(&path, passes + 1, &mut b).unwrap();
    assert_ne!(a.0, b.0);
    assert_eq!(a.0, PINNED[6].1);
}

/// (log stem, σ (m), `max_range` (m), digests: defaults, `Params::V3_0`,
/// [`ARC_PAIRS_KEPT`], [`NO_ANCHOR_GATE`], [`CONSECUTIVE_WINDOWS`],
/// [`ARCS_KEPT`], v2).
#[cfg(not(feature = "libm-trig"))]
type PerDataPin = (&'static str, f32, f32, u64, u64, u64, u64, u64, u64, u64);

/// With the parameters `host-bridge extract LOG` uses when no flag is given
/// (σ and `max_range` from the survey of the log,
/// [`per_data_params`]): (log stem, σ (m), `max_range` (m),
/// FNV-1a-64 of the feature bits). σ is 1 cm on the cm logs, 30 mm on
/// Acapulco's 5 cm steps and 5 mm on Örebro (mm); `max_range` is the unit's
/// and mode's largest true range, and 50 m on Acapulco, below its ~51 m fill
/// values. (Örebro has no range beyond its limit: its digest is the one at
/// `Params::default`.) `host-bridge`'s
/// `extract_cli::per_data_defaults_match_the_pinned_feature_bits` checks
/// that its `defaults::for_log` gives these same parameters. The last six
/// columns are the digests with `Params::V3_0`, [`ARC_PAIRS_KEPT`], [`NO_ANCHOR_GATE`],
/// [`CONSECUTIVE_WINDOWS`], [`ARCS_KEPT`] and `Params::V2` otherwise, the
/// last two without the `rejected_arc` counter ([`WithoutArcCounter`]).
#[cfg(not(feature = "libm-trig"))]
const PINNED_PER_DATA: [PerDataPin; 7] = [
    (
        "acapulco-corrected",
        0.030000001,
        50.0,
        0x4abd58c2453206f7,
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
        0xcd3e336571bac5a9,
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
        0xbc9f83267eb3a9ee,
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
        0x5c8727c99e050b28,
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
        0x7d26c7996bb4bd14,
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
        0x2e0cbaa7489a0eab,
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
        0x8f6da1e5aca24ad7,
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
    for (
        stem,
        sigma,
        max_range,
        pin,
        pin_v3_0,
        pin_pairs,
        pin_gate,
        pin_windows,
        pin_arcs,
        pin_v2,
    ) in PINNED_PER_DATA
    {
        let path = log(stem);
        let params = per_data_params(&path).unwrap();
        let on_data = |base: Params| {
            base.with_sigma(params.sigma)
                .with_max_range(params.max_range)
        };
        let (pairs, gate, windows, arcs) = (
            on_data(ARC_PAIRS_KEPT),
            on_data(NO_ANCHOR_GATE),
            on_data(CONSECUTIVE_WINDOWS),
            on_data(ARCS_KEPT),
        );
        let v2 = arcs.with_bridge_merge(false).with_footprint(0.0);
        assert_eq!(v2, Params::V2.with_sigma(sigma).with_max_range(max_range));
        let (d, _, _) = digests(&path, &params);
        let (d_v3_0, _, _) = digests(&path, &on_data(Params::V3_0));
        let (d_pairs, _, _) = digests(&path, &pairs);
        let (d_gate, _, _) = digests(&path, &gate);
        let (d_windows, d_windows_without, _) = digests(&path, &windows);
        let (_, d_arcs, _) = digests(&path, &arcs);
        // No line of these logs is taken for an arc with consecutive
        // windows: but for the counter, dropping arcs there changes no bit.
        assert_eq!(
            d_windows_without, pin_arcs,
            "{stem}: a line of a real log dropped as an arc"
        );
        let (_, d2, _) = digests(&path, &v2);
        println!(
            "(\"{stem}\", {:?}, {:?}, 0x{d:016x}, 0x{d_v3_0:016x}, 0x{d_pairs:016x}, \
             0x{d_gate:016x}, 0x{d_windows:016x}, 0x{d_arcs:016x}, 0x{d2:016x}),",
            params.sigma, params.max_range
        );
        if (
            params.sigma,
            params.max_range,
            d,
            d_v3_0,
            d_pairs,
            d_gate,
            d_windows,
            d_arcs,
            d2,
        ) != (
            sigma,
            max_range,
            pin,
            pin_v3_0,
            pin_pairs,
            pin_gate,
            pin_windows,
            pin_arcs,
            pin_v2,
        ) {
            wrong.push(format!(
                "{stem}: σ {} m, max_range {} m, 0x{d:016x}, v3.0 0x{d_v3_0:016x}, \
                 arc pairs kept 0x{d_pairs:016x}, \
                 no anchor gate 0x{d_gate:016x}, consecutive windows 0x{d_windows:016x}, \
                 arcs kept 0x{d_arcs:016x}, v2 0x{d2:016x}; pinned {sigma}, {max_range}, \
                 0x{pin:016x}, 0x{pin_v3_0:016x}, 0x{pin_pairs:016x}, 0x{pin_gate:016x}, 0x{pin_windows:016x}, \
                 0x{pin_arcs:016x}, 0x{pin_v2:016x}",
                params.sigma, params.max_range
            ));
        }
        // Only σ and the range limit come from the data.
        let defaults = on_data(Params::DEFAULT);
        assert_eq!(params, defaults, "{stem}");
    }
    assert!(
        wrong.is_empty(),
        "per-data results changed:\n{}",
        wrong.join("\n")
    );
}
