//! `host-bridge verify`: drive a co-processor from both of its serial lines
//! and check, bit for bit, that the features it sends are the ones the std
//! build computes from the very scans it passed through.
//!
//! ```text
//! host-bridge verify [--host | --qemu [ELF] | --ports HOST SENSOR]
//!                    [--scene room|corridor|random] [--seed N] [--count N]
//!                    [--noise-sigma S] [--dropout P]
//!                    [--replay LOG] [--frames A..B]
//!                    [--scans N] [--timeout S] [--host-baud BAUD]
//!                    [--max-in-flight N] [-v]
//!                    [--iterations N] [--q Q] [--sigma S] [--tau T]
//!                    [--min-points N] [--max-chi2 X] [--no-merge]
//! ```
//!
//! # What it plays
//!
//! * **The sensor** on the co-processor's sensor line: a simulated LMS 2xx
//!   ([`lms_core::device::emulator::Emulator`]) that the co-processor brings up
//!   itself (variant, mm, 500 kBd, continuous output). Its scans come from a
//!   [`PlaySource`]: the synthetic scene (default; the frames of
//!   `host-bridge extract` with the same scene options) or the `FLASER`
//!   frames `--frames A..B` of a CARMEN log (`--replay`); 180° logs of other
//!   resolutions are resampled to 180°/0.5° like `simulate --replay` does, 100°
//!   logs are refused. Each scan of the selection is sent exactly once, in
//!   order, at the emulator's real pace (one `B0` per 26.7 ms at 500 kBd).
//! * **The client** on the co-processor's host line, with raw LMS telegrams:
//!   the counters request `55` (retried until the `D5` comes: the first
//!   bytes may be lost while the board starts), `20 48` (500 kBd,
//!   `--host-baud`), `20 24`; then it reads the `B0` + feature telegrams
//!   (`D4 D3 D1… D2… D0`), reassembles them per scan
//!   ([`FeatureAssembler`]), and at the end `20 25` and a last `55`.
//!
//! # Sequence (deterministic)
//!
//! The emulator runs on the real clock, except that its clock is held:
//!
//! * from the moment the co-processor has started the sensor's stream until
//!   the client's `20 24` is acknowledged, so that no scan of the selection
//!   is spent before the host side streams;
//! * while `--max-in-flight` scans are out and not back (default 8 with
//!   `--qemu`: QEMU moves only ~10 KB/s into a UART, a third of the 500 kBd
//!   line rate, and the rest would pile up in its socket; off otherwise);
//! * after the last scan of the selection has gone out, or at `--timeout`.
//!
//! The LMS's first mirror tick falls at the very start of its stream, so
//! one scan is drawn before the clock can be held (a warm-up scan); it
//! reaches the co-processor after the client's stream is on, and is checked
//! like every scan that comes back, but not counted as part of the
//! selection. So `scans_in` is one more than the selection.
//!
//! # The check
//!
//! For every scan that comes back on the host line:
//!
//! 1. its `B0` must be byte for byte (count word and value words) a scan
//!    the sensor side sent, in order (the pass-through);
//! 2. the std build recomputes the features: [`MeasuredView::to_frame`]
//!    with 13 range bits, [`Extractor::run`] with the parameters echoed in
//!    the `D0` summary (`iterations`, `sigma`, `q`, `tau`; the others from
//!    the command line, default ALGORITHM.md);
//! 3. segments, edge points, every field of every line and corner (floats
//!    by their bits; all NaNs count as equal) and the statistics must be
//!    identical.
//!
//! Every failing scan prints one line on stdout with its first differing
//! field:
//!
//! ```text
//! MISMATCH scan 12 (frame 11): line 3 alpha: co-processor 0x3FC90FDB (1.5707964), recomputed 0x3FC90FDA (1.5707963); 4 fields differ
//! ```
//!
//! and the run ends with `N/N scans bit-identical`, the scans lost (sent by
//! the sensor side, never back with features, found by counting), and the
//! co-processor's counters from the final `55`. The exit status is 1 on any
//! mismatch or lost scan (not back although the host line went quiet for
//! 3 s), when fewer than `--scans` scans were checked before `--timeout`
//! (those still on their way are reported as such), or without the final
//! counters.
//!
//! # Modes (how the lines are connected)
//!
//! * `--host` (default): the core's [`CoProcessor`] runs natively in a
//!   thread on the masters of two pseudo-terminals ([`crate::pty`], behind
//!   [`PtyPort`], an `embedded-io` 0.7 port); verify opens the two slave
//!   devices with the `serialport` crate, exactly as in `--ports`.
//! * `--qemu [ELF]`: the firmware under `qemu-system-arm -M netduinoplus2`
//!   (extra QEMU arguments from the `QEMU_EXTRA` environment variable)
//!   with its three serial ports on TCP sockets on 127.0.0.1 (free ports
//!   chosen at start), as `firmware/run-qemu.sh` does: USART1 = host line,
//!   USART2 = sensor line, USART3 = console (read all the time, since QEMU
//!   stalls on a full socket; `s` at the end for the firmware's report, then
//!   `q`). QEMU runs in its own process group under `timeout` (when
//!   installed), so it is bounded even if verify is killed; a guard kills
//!   the group on every exit, errors and panics included. Its `defmt` log
//!   is kept in a temporary directory and its tail decoded with
//!   `defmt-print` (if installed) when the run fails.
//! * `--ports HOST SENSOR`: two serial ports wired to a co-processor
//!   (`serialport` crate, 8N1, 9600 Bd at the start as after power-on).

use std::collections::VecDeque;
use std::fmt;
use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, ensure, Context, Result};
use clap::Args;
use lms_core::device::coprocessor::{CoProcessor, PollError, SensorSetup};
use lms_core::device::emulator::{Emulator, Event as EmuEvent, ScanSource, Settings};
use lms_core::telegram::features::{
    Assembled, Counters, EchoedParams, FeatureAssembler, Summary, CMD_CORNERS, CMD_COUNTERS,
    CMD_EDGES, CMD_LINES, CMD_SEGMENTS, CMD_SUMMARY, REQ_COUNTERS,
};
use lms_core::telegram::{
    emit_telegram, Baud, Direction, Event, Framer, Handshake, MeasuredValues, MeasuredView,
    RangeBits, Request, Telegram,
};
use lms_core::Unit;
use lms_core::{Extractor, Features, Frame, Invalid, Params, ValidParams, Variant};

use crate::carmen::{self, UnitMode};
use crate::options::{FrameRange, ParamArgs};
use crate::pty::{Pty, ReadOutcome, WriteOutcome};
use crate::synthetic::{self, SceneArgs};

/// How long a request waits for its reply before it is sent again.
const RETRY: Duration = Duration::from_millis(500);
/// After the last scan has gone out: give up waiting for the rest once the
/// host line has been silent this long.
const QUIET: Duration = Duration::from_secs(3);
/// Time for the closing `20 25` and `55` (also after `--timeout`).
const CLOSING: Duration = Duration::from_secs(5);
/// Longest wait of one pass of the loop (the emulator's pacing granularity).
const TICK: Duration = Duration::from_millis(1);
/// A write that cannot go out in this time is an error (the peer is stuck).
const WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Default firmware ELF (relative to the working directory, then to the
/// source tree).
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/lms-firmware";

/// Options of `host-bridge verify`.
#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// Run the firmware ELF under QEMU (netduinoplus2) [default ELF:
    /// firmware/target/thumbv7em-none-eabihf/release/lms-firmware]
    #[arg(long, value_name = "ELF", num_args = 0..=1, conflicts_with_all = ["host", "ports"])]
    pub qemu: Option<Option<PathBuf>>,
    /// Run the co-processor natively in a thread behind two pseudo-terminals
    /// (the default)
    #[arg(long, conflicts_with = "ports")]
    pub host: bool,
    /// Two serial ports wired to a co-processor: its host line, its sensor line
    #[arg(long, num_args = 2, value_names = ["HOST", "SENSOR"])]
    pub ports: Option<Vec<PathBuf>>,
    /// The synthetic scene (when no `--replay` log is given).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Play the FLASER frames of a CARMEN log (gzip or plain) instead of the
    /// synthetic scene
    #[arg(long = "replay", value_name = "LOG")]
    pub log: Option<PathBuf>,
    /// Frames of the log to play: A..B (B exclusive), A..=B, A.., ..B or A
    #[arg(long, value_name = "A..B", requires = "log")]
    pub frames: Option<FrameRange>,
    /// Scans to check: the first N of the selection [default: all of it]
    #[arg(long, value_name = "N")]
    pub scans: Option<usize>,
    /// Give up after this many seconds (the run then fails if fewer than
    /// --scans scans were checked)
    #[arg(long, value_name = "S", default_value_t = 60.0)]
    pub timeout: f64,
    /// Rate the client switches the host line to before streaming
    /// (9600 = no switch)
    #[arg(long, value_name = "BAUD", default_value_t = 500_000)]
    pub host_baud: u32,
    /// Hold the sensor's stream while this many scans are out and not back
    /// with features (0 = never) [default: 8 with --qemu, whose UARTs take
    /// a third of the line rate; else 0, as a real sensor never waits]
    #[arg(long, value_name = "N")]
    pub max_in_flight: Option<usize>,
    /// Pipeline parameters: the co-processor's in --host mode; in every mode
    /// those the D0 summary does not echo (min points, max chi2, merging)
    #[command(flatten)]
    pub params: ParamArgs,
    /// Log the phases of the run and the sensor-side requests on stderr
    #[arg(long, short)]
    pub verbose: bool,
    /// Testing only: recompute with this tau instead of the echoed one (so
    /// that the check must fail)
    #[arg(long, hide = true, value_name = "T", allow_negative_numbers = true)]
    pub recompute_tau: Option<f32>,
}

// ---------------------------------------------------------------------------
// The scans played on the sensor line

/// Why a scan was drawn from the [`PlaySource`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tag {
    /// Before the client's stream was on (not counted).
    Warmup,
    /// Scan `k` of the selection.
    Play(usize),
    /// After the selection was exhausted (not counted).
    Extra,
}

/// One scan as the sensor side sent it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Drawn {
    /// Why it was drawn.
    pub tag: Tag,
    /// Unit of its values.
    pub units: Unit,
    /// Its value words, as in the `B0`.
    pub words: Vec<u16>,
}

/// The scans of the run as an emulator scan source: the selection in order,
/// each exactly once after [`PlaySource::arm`]; other scans of the
/// selection, cycling, before it and after the end. Every draw is logged
/// ([`PlaySource::draws`]) so that the scans coming back can be matched.
#[derive(Debug)]
pub struct PlaySource {
    frames: Vec<Frame>,
    /// Index of each frame in its log or scene, for messages.
    labels: Vec<usize>,
    /// The frames' variant.
    variant: Variant,
    armed: bool,
    next: usize,
    spare: usize,
    draws: Vec<Drawn>,
}

/// Field of a variant in the 180° frame, in 1/100 °: (first beam, step).
fn field(variant: Variant) -> (u32, u32) {
    let fov = u32::from(variant.fov_deg());
    ((180 - fov) * 50, u32::from(variant.resolution_centideg()))
}

impl PlaySource {
    /// Play `frames` (all of one 180° variant; `labels` name them).
    pub fn new(frames: Vec<Frame>, labels: Vec<usize>) -> Result<Self> {
        let first = frames.first().context("no scans to play")?;
        let variant = Variant::from_beams(first.len())
            .with_context(|| format!("{} beams per scan", first.len()))?;
        ensure!(
            variant.fov_deg() == 180,
            "the scans are {}° wide: the co-processor runs 180°/0.5°, which a 100° scan cannot give",
            variant.fov_deg()
        );
        ensure!(
            frames.iter().all(|f| f.len() == first.len()),
            "all scans must have the same number of beams"
        );
        ensure!(labels.len() == frames.len(), "one label per frame");
        Ok(PlaySource {
            frames,
            labels,
            variant,
            armed: false,
            next: 0,
            spare: 0,
            draws: Vec::new(),
        })
    }

    /// Scans in the selection.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// `true` if there is nothing to play (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Keep only the first `n` scans.
    pub fn truncate(&mut self, n: usize) {
        self.frames.truncate(n.max(1));
        self.labels.truncate(n.max(1));
    }

    /// From now on draw the selection, in order.
    pub fn arm(&mut self) {
        self.armed = true;
    }

    /// `true` once [`PlaySource::arm`] was called.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Every scan drawn so far, in order.
    pub fn draws(&self) -> &[Drawn] {
        &self.draws
    }

    /// The log or scene index of scan `k` of the selection.
    pub fn label(&self, k: usize) -> usize {
        self.labels.get(k).copied().unwrap_or(k)
    }

    /// The value words of frame `k` resampled to `target` (nearest beam, as
    /// `simulate --replay`), in `units`.
    fn words(&self, k: usize, target: Variant, units: Unit, out: &mut [u16]) {
        let frame = &self.frames[k];
        let values = MeasuredValues::from_frame(frame, units, RangeBits::Bits13, 0);
        let values = values.values();
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        let (first_s, res_s) = field(self.variant);
        let (first_t, res_t) = field(target);
        for (i, slot) in out.iter_mut().enumerate() {
            let angle = first_t + i as u32 * res_t;
            *slot = angle
                .checked_sub(first_s)
                .map(|d| ((2 * d + res_s) / (2 * res_s)) as usize)
                .and_then(|j| values.get(j).copied())
                .unwrap_or(not_valid);
        }
    }
}

impl ScanSource for PlaySource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        let (tag, k) = if self.armed && self.next < self.frames.len() {
            self.next += 1;
            (Tag::Play(self.next - 1), self.next - 1)
        } else {
            self.spare += 1;
            let tag = if self.armed { Tag::Extra } else { Tag::Warmup };
            (tag, (self.spare - 1) % self.frames.len())
        };
        self.words(k, variant, units, out);
        self.draws.push(Drawn {
            tag,
            units,
            words: out.to_vec(),
        });
        out.len()
    }

    fn supports(&self, variant: Variant) -> bool {
        field(variant).0 >= field(self.variant).0
    }
}

/// The scans the options ask for, and a description for the log.
pub fn play_source(args: &VerifyArgs) -> Result<(PlaySource, String)> {
    let (mut source, about) = match &args.log {
        Some(path) => {
            let log = carmen::read_log(path, UnitMode::Auto)?;
            let range = args.frames.unwrap_or_default();
            let total = log.scans.len();
            let (labels, frames): (Vec<usize>, Vec<Frame>) = log
                .scans
                .into_iter()
                .filter(|s| range.contains(s.index))
                .map(|s| (s.index, resample_carmen(s.frame)))
                .unzip();
            ensure!(
                !frames.is_empty(),
                "{}: --frames {range} selects no frame (the log has {total} FLASER frames)",
                path.display()
            );
            let beams = frames[0].len();
            let about = format!(
                "{} frames {range} of {} ({} beams, {} ranges{})",
                frames.len(),
                path.display(),
                beams,
                log.unit,
                if beams == 361 {
                    ""
                } else {
                    "; resampled to 361 beams, nearest beam"
                }
            );
            let source = PlaySource::new(frames, labels)
                .with_context(|| format!("cannot play {}", path.display()))?;
            (source, about)
        }
        None => {
            let frames = synthetic::frames(&args.scene)?;
            let labels = frames.iter().map(|f| f.index).collect();
            let frames = frames.into_iter().map(|f| f.frame).collect();
            let about = format!(
                "synthetic scene {:?} (seed {}, {} frames, noise {} m, dropout {})",
                args.scene.scene,
                args.scene.seed,
                args.scene.count,
                args.scene.noise_sigma,
                args.scene.dropout
            )
            .to_lowercase();
            (PlaySource::new(frames, labels)?, about)
        }
    };
    if let Some(n) = args.scans {
        ensure!(n > 0, "--scans must be at least 1");
        ensure!(
            n <= source.len(),
            "--scans {n}: the selection has only {} scans (each is played once; use --count or --frames)",
            source.len()
        );
        source.truncate(n);
    }
    Ok((source, about))
}

/// CARMEN drops the last beam of 181/361-beam scans: put it back as "no
/// echo", so that 180 and 360 beams play as the LMS variants they come from.
fn resample_carmen(frame: Frame) -> Frame {
    let n = frame.len();
    let Some(variant) = carmen::variant_for_beams(n) else {
        return frame;
    };
    if variant.beams() == n {
        return frame;
    }
    let Ok(mut full) = Frame::new(variant.geometry(), variant.beams()) else {
        return frame;
    };
    for (j, (&r, beam)) in frame.ranges().iter().zip(frame.beams()).enumerate() {
        match beam {
            lms_core::Beam::Valid => full.set_metres(j, r),
            lms_core::Beam::Invalid(why) => full.set_invalid(j, *why),
        }
    }
    for j in n..variant.beams() {
        full.set_invalid(j, Invalid::NoEcho);
    }
    full
}

// ---------------------------------------------------------------------------
// Bit-for-bit comparison

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

/// The statistics, in the order of the `D0` summary.
fn stats_fields(s: &lms_core::Stats) -> [(&'static str, Value); 12] {
    let i = |v: u16| Value::Int(v.into());
    [
        ("valid_beams", i(s.valid_beams)),
        ("invalid_windows", i(s.invalid_windows)),
        ("short_segments", i(s.short_segments)),
        ("segment_overflow", i(s.segment_overflow)),
        ("edge_overflow", i(s.edge_overflow)),
        ("degenerate_fits", i(s.degenerate_fits)),
        ("rejected_chi2", i(s.rejected_chi2)),
        ("rejected_short", i(s.rejected_short)),
        ("merges", i(s.merges)),
        ("line_overflow", i(s.line_overflow)),
        ("degenerate_corners", i(s.degenerate_corners)),
        ("corner_overflow", i(s.corner_overflow)),
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
    diff_list(&mut out, "edge", "edges", got.edges(), want.edges(), |&e| {
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
    for ((field, x), (_, y)) in stats_fields(got.stats())
        .into_iter()
        .zip(stats_fields(want.stats()))
    {
        if !x.same(y) {
            out.push(Difference {
                item: "stats".into(),
                field,
                got: x,
                want: y,
            });
        }
    }
    out
}

/// Checks every scan that comes back and keeps the tally.
struct Checker {
    /// Parameters for what the summary does not echo.
    base: Params,
    recompute_tau: Option<f32>,
    extractor: Box<Extractor>,
    /// Draws before this index have been matched or passed over.
    cursor: usize,
    /// Scans of the selection back and checked, and of those identical.
    play_back: usize,
    play_identical: usize,
    /// Other scans (warm-up, extra) back and checked, and identical.
    other_back: usize,
    other_identical: usize,
    /// Lines printed for failures.
    problems: usize,
    lines: u64,
    corners: u64,
    /// The parameters echoed by the first summary.
    echoed: Option<EchoedParams>,
}

impl Checker {
    fn new(base: Params, recompute_tau: Option<f32>) -> Self {
        Checker {
            base,
            recompute_tau,
            extractor: Box::new(Extractor::new()),
            cursor: 0,
            play_back: 0,
            play_identical: 0,
            other_back: 0,
            other_identical: 0,
            problems: 0,
            lines: 0,
            corners: 0,
            echoed: None,
        }
    }

    /// Report a failure (one line on stdout).
    fn problem(&mut self, msg: impl fmt::Display) {
        self.problems += 1;
        println!("MISMATCH {msg}");
    }

    /// A `B0` that was not followed by its features.
    fn without_features(&mut self) {
        self.problem("a B0 on the host line was not followed by its feature telegrams");
    }

    /// The recomputation parameters for a scan's summary.
    fn params(&self, echoed: &EchoedParams) -> Params {
        Params {
            iterations: echoed.iterations,
            sigma: echoed.sigma,
            q: echoed.q,
            tau: self.recompute_tau.unwrap_or(echoed.tau),
            ..self.base
        }
    }

    /// Check one scan: its `B0` as the host received it (if one came), its
    /// summary and features as reassembled.
    fn check(&mut self, b0: Option<&[u8]>, summary: &Summary, got: &Features, source: &PlaySource) {
        let counter = summary.scan_counter;
        if self.echoed.is_none() {
            self.echoed = Some(summary.params);
            let p = summary.params;
            let b = &self.base;
            if (p.iterations, p.sigma, p.q, p.tau) != (b.iterations, b.sigma, b.q, b.tau) {
                eprintln!(
                    "host-bridge verify: note: the co-processor runs iterations={} sigma={} q={} \
                     tau={} (echoed in D0), not the command line's; recomputing with those",
                    p.iterations, p.sigma, p.q, p.tau
                );
            }
        }
        let Some(b0) = b0 else {
            self.problem(format_args!(
                "scan {counter}: features without a B0 before them"
            ));
            return;
        };
        let view = Telegram::new_checked(b0, Direction::SensorToHost)
            .ok()
            .and_then(|t| MeasuredView::parse(&t).ok());
        let Some(view) = view else {
            self.problem(format_args!("scan {counter}: its B0 does not parse"));
            return;
        };
        // 1. The pass-through: the B0 is one the sensor side sent, in order.
        let units = view.units();
        let words: Vec<u16> = view.words().collect();
        let draws = source.draws();
        let found = draws
            .iter()
            .enumerate()
            .skip(self.cursor)
            .find(|(_, d)| d.units == units && d.words == words)
            .map(|(j, d)| (j, d.tag));
        let tag = match found {
            Some((j, tag)) => {
                self.cursor = j + 1;
                Some(tag)
            }
            None => None,
        };
        let name = match tag {
            Some(Tag::Play(k)) => format!("scan {counter} (frame {})", source.label(k)),
            Some(Tag::Warmup) => format!("scan {counter} (warm-up)"),
            Some(Tag::Extra) => format!("scan {counter} (extra)"),
            None => format!("scan {counter}"),
        };
        let identical = self.compare(&name, &view, summary, got, tag.is_none());
        match tag {
            Some(Tag::Play(_)) => {
                self.play_back += 1;
                self.play_identical += usize::from(identical);
            }
            _ => {
                self.other_back += 1;
                self.other_identical += usize::from(identical);
            }
        }
    }

    /// Recompute and compare; `true` if bit-identical (and passed through
    /// unchanged, `altered` false).
    fn compare(
        &mut self,
        name: &str,
        view: &MeasuredView<'_>,
        summary: &Summary,
        got: &Features,
        altered: bool,
    ) -> bool {
        if altered {
            self.problem(format_args!(
                "{name}: its B0 is not a scan the sensor side sent (pass-through altered, or out of order)"
            ));
            return false;
        }
        let frame = match view.to_frame(RangeBits::Bits13) {
            Ok(f) => f,
            Err(e) => {
                self.problem(format_args!("{name}: its B0 gives no frame: {e}"));
                return false;
            }
        };
        if usize::from(summary.beams) != frame.len() {
            self.problem(format_args!(
                "{name}: summary beams: co-processor {}, B0 {}",
                Value::Int(summary.beams.into()),
                Value::Int(frame.len() as u32)
            ));
            return false;
        }
        let params = self.params(&summary.params);
        let want = match params.validate() {
            Ok(valid) => self.extractor.run(&frame, &valid),
            Err(e) => {
                self.problem(format_args!(
                    "{name}: the std build refuses the echoed parameters: {e}"
                ));
                return false;
            }
        };
        self.lines += got.lines().len() as u64;
        self.corners += got.corners().len() as u64;
        let diffs = differences(got, want);
        match diffs.first() {
            None => true,
            Some(first) => {
                let more = if diffs.len() > 1 {
                    format!("; {} fields differ", diffs.len())
                } else {
                    String::new()
                };
                let line = format!("{name}: {first}{more}");
                self.problem(line);
                false
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Lines: the verify's ends of the two serial lines

/// One end of a serial line as verify uses it.
pub trait Line: Send {
    /// Read what is there, waiting up to `wait` for the first byte
    /// (`Duration::ZERO`: do not wait); `Ok(0)` if nothing came.
    fn read_some(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize>;
    /// Send all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Switch the line rate (after what was sent has gone out).
    fn set_baud(&mut self, baud: Baud) -> io::Result<()>;
    /// Name for messages.
    fn name(&self) -> &str;
}

/// A serial port (or a pseudo-terminal's slave) through `serialport`.
pub struct TtyLine {
    port: serialport::TTYPort,
    name: String,
}

impl TtyLine {
    /// Open `path` at `baud`, 8N1, no flow control.
    pub fn open(path: &Path, baud: Baud) -> Result<Self> {
        let name = path.display().to_string();
        let port = serialport::new(name.as_str(), baud.bits_per_second())
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(WRITE_TIMEOUT)
            .open_native()
            .map_err(|e| anyhow!("cannot open {name}: {e}"))?;
        Ok(TtyLine { port, name })
    }
}

impl Line for TtyLine {
    fn read_some(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize> {
        use serialport::SerialPort;
        self.port.set_timeout(wait)?;
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        use serialport::SerialPort;
        self.port.set_timeout(WRITE_TIMEOUT)?;
        self.port.write_all(bytes)
    }

    fn set_baud(&mut self, baud: Baud) -> io::Result<()> {
        use serialport::SerialPort;
        self.port.set_timeout(WRITE_TIMEOUT)?;
        self.port.flush()?;
        self.port.set_baud_rate(baud.bits_per_second())?;
        Ok(())
    }

    fn name(&self) -> &str {
        &self.name
    }
}

/// A TCP connection to one of QEMU's serial ports.
pub struct TcpLine {
    stream: TcpStream,
    name: String,
    /// The socket is in non-blocking mode.
    nonblocking: bool,
}

impl TcpLine {
    /// Connect to `addr`, retrying until `deadline` while `alive` says the
    /// server may still come up.
    fn connect(
        addr: SocketAddr,
        name: String,
        deadline: Instant,
        mut alive: impl FnMut() -> Result<()>,
    ) -> Result<Self> {
        loop {
            match TcpStream::connect_timeout(&addr, Duration::from_millis(200)) {
                Ok(stream) => {
                    stream.set_nodelay(true)?;
                    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
                    return Ok(TcpLine {
                        stream,
                        name,
                        nonblocking: false,
                    });
                }
                Err(e) if Instant::now() >= deadline => {
                    bail!("cannot connect to {name} ({addr}): {e}")
                }
                Err(_) => {
                    alive()?;
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        }
    }

    fn set_nonblocking(&mut self, on: bool) -> io::Result<()> {
        if self.nonblocking != on {
            self.stream.set_nonblocking(on)?;
            self.nonblocking = on;
        }
        Ok(())
    }
}

impl Line for TcpLine {
    fn read_some(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize> {
        if wait.is_zero() {
            self.set_nonblocking(true)?;
        } else {
            self.set_nonblocking(false)?;
            self.stream.set_read_timeout(Some(wait))?;
        }
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                "QEMU closed the connection",
            )),
            Ok(n) => Ok(n),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.set_nonblocking(false)?;
        self.stream.write_all(bytes)
    }

    fn set_baud(&mut self, _baud: Baud) -> io::Result<()> {
        Ok(()) // QEMU ignores line rates.
    }

    fn name(&self) -> &str {
        &self.name
    }
}

// ---------------------------------------------------------------------------
// --host: the co-processor in a thread on two pseudo-terminals

/// A pseudo-terminal's master as an `embedded-io` 0.7 serial port, for
/// [`CoProcessor::poll`].
///
/// * `read_ready`: `poll` with a zero time-out (also `true` when the other
///   end has gone away; `read` then returns 0, which `poll` takes as "no
///   more bytes").
/// * `read`: never blocks (the co-processor reads only after `read_ready`).
/// * `write`: blocks while the other end's input queue is full (as a UART
///   transmits at its own pace), at most 2 s; bytes written while nobody
///   has the other end open are dropped, like a UART with nothing attached.
pub struct PtyPort {
    pty: Pty,
}

impl PtyPort {
    /// Wrap a pseudo-terminal.
    pub fn new(pty: Pty) -> Self {
        PtyPort { pty }
    }

    /// The device the other end opens.
    pub fn slave_path(&self) -> &Path {
        self.pty.slave_path()
    }

    /// Wait up to `timeout` for input.
    pub fn wait_readable(&self, timeout: Duration) -> io::Result<bool> {
        self.pty.wait_readable(timeout).map_err(to_io)
    }
}

fn to_io(e: anyhow::Error) -> io::Error {
    io::Error::other(format!("{e:#}"))
}

impl embedded_io::ErrorType for PtyPort {
    type Error = io::Error;
}

impl embedded_io::ReadReady for PtyPort {
    fn read_ready(&mut self) -> io::Result<bool> {
        self.wait_readable(Duration::ZERO)
    }
}

impl embedded_io::Read for PtyPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.pty.read(buf).map_err(to_io)? {
            ReadOutcome::Data(n) => Ok(n),
            ReadOutcome::Empty | ReadOutcome::Closed => Ok(0),
        }
    }
}

impl embedded_io::Write for PtyPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let until = Instant::now() + WRITE_TIMEOUT;
        loop {
            match self.pty.write(buf).map_err(to_io)? {
                WriteOutcome::Written(n) if n > 0 => return Ok(n),
                WriteOutcome::Closed => return Ok(buf.len()),
                WriteOutcome::Written(_) | WriteOutcome::Full => {
                    if Instant::now() >= until {
                        return Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            format!("{}: nobody reads", self.pty.slave_path().display()),
                        ));
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Run a [`CoProcessor`] on two ports until `stop`: poll, then wait up to
/// 1 ms for sensor bytes. Returns its counters.
pub fn run_coprocessor(
    params: ValidParams,
    mut sensor: PtyPort,
    mut host: PtyPort,
    stop: &AtomicBool,
) -> Result<Counters, String> {
    let clock = Instant::now();
    let now_us = || u64::try_from(clock.elapsed().as_micros()).unwrap_or(u64::MAX);
    let mut cop = Box::new(CoProcessor::new(params, SensorSetup::default()));
    cop.start(now_us());
    while !stop.load(Ordering::Relaxed) {
        cop.poll(&mut sensor, &mut host, now_us())
            .map_err(|e| match e {
                PollError::Sensor(e) => format!("co-processor thread: sensor port: {e}"),
                PollError::Host(e) => format!("co-processor thread: host port: {e}"),
            })?;
        sensor
            .wait_readable(TICK)
            .map_err(|e| format!("co-processor thread: {e}"))?;
    }
    Ok(cop.counters())
}

// ---------------------------------------------------------------------------
// --qemu: the firmware under QEMU

/// QEMU running the firmware; killed (its whole process group) when dropped.
struct Qemu {
    child: Child,
    elf: PathBuf,
    /// Holds the raw defmt log and QEMU's stderr.
    dir: PathBuf,
    /// Keep `dir` when dropped (the run failed).
    keep: bool,
}

/// `name` as an executable found on `PATH`.
fn on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}

/// The firmware ELF: the one given, or the default relative to the working
/// directory, then to this source tree.
fn firmware_elf(given: Option<&Path>) -> Result<PathBuf> {
    if let Some(p) = given {
        ensure!(p.is_file(), "no firmware ELF at {}", p.display());
        return Ok(p.to_path_buf());
    }
    let here = PathBuf::from(DEFAULT_ELF);
    if here.is_file() {
        return Ok(here);
    }
    let tree = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(DEFAULT_ELF);
    ensure!(
        tree.is_file(),
        "no firmware ELF at {DEFAULT_ELF} (build it: cd firmware && cargo build --release)"
    );
    Ok(tree)
}

/// Three free TCP ports on the loopback interface.
fn free_ports() -> io::Result<[u16; 3]> {
    let listeners = [
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
    ];
    let mut ports = [0u16; 3];
    for (p, l) in ports.iter_mut().zip(&listeners) {
        *p = l.local_addr()?.port();
    }
    Ok(ports)
}

impl Qemu {
    /// Start `qemu-system-arm -M netduinoplus2` with the firmware and its
    /// serial ports on TCP `ports` (host, sensor, console), bounded by
    /// `bound` (with `timeout`, if installed).
    fn start(elf: &Path, ports: [u16; 3], bound: Duration) -> Result<Qemu> {
        let qemu = on_path("qemu-system-arm")
            .context("qemu-system-arm not found on PATH (apt-get install qemu-system-arm)")?;
        let dir = std::env::temp_dir().join(format!("host-bridge-verify-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let mut cmd = match on_path("timeout") {
            Some(timeout) => {
                let mut c = Command::new(timeout);
                c.arg("--kill-after=5")
                    .arg(format!("{}", bound.as_secs().max(1)))
                    .arg(&qemu);
                c
            }
            None => Command::new(&qemu),
        };
        let serial = |p: u16| format!("tcp:127.0.0.1:{p},server=on,wait=off,nodelay=on");
        cmd.args([
            "-M",
            "netduinoplus2",
            "-display",
            "none",
            "-monitor",
            "none",
        ])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-serial", &serial(ports[0])])
        .args(["-serial", &serial(ports[1])])
        .args(["-serial", &serial(ports[2])])
        // Extra QEMU arguments, as firmware/run-qemu.sh takes them (e.g. the
        // instruction-counting plugin of tools/qemu-icount).
        .args(
            std::env::var("QEMU_EXTRA")
                .unwrap_or_default()
                .split_whitespace(),
        )
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(dir.join("defmt.raw"))?)
        .stderr(std::fs::File::create(dir.join("qemu.stderr"))?);
        // Its own process group, so that the guard can kill QEMU together
        // with the `timeout` around it.
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        let child = cmd
            .spawn()
            .with_context(|| format!("cannot start {}", qemu.display()))?;
        Ok(Qemu {
            child,
            elf: elf.to_path_buf(),
            dir,
            keep: false,
        })
    }

    /// An error if QEMU has exited (with the first lines of what it said;
    /// all of it stays in the temporary directory).
    fn check(&mut self) -> Result<()> {
        if let Some(status) = self.child.try_wait()? {
            self.keep = true;
            let path = self.dir.join("qemu.stderr");
            let stderr = std::fs::read_to_string(&path).unwrap_or_default();
            let said: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
            let said = match said.len() {
                0 => String::new(),
                1..=2 => format!("; QEMU said: {}", said.join(" / ")),
                n => format!(
                    "; QEMU said: {} / {} (+{} lines in {})",
                    said[0],
                    said[1],
                    n - 2,
                    path.display()
                ),
            };
            bail!(
                "QEMU exited during the run ({status}; firmware exit codes: 1 panic, 2 hard \
                 fault, 3 unexpected interrupt, 124 time-out){said}"
            );
        }
        Ok(())
    }

    /// Wait up to `limit` for QEMU to exit; its status if it did.
    fn wait_exit(&mut self, limit: Duration) -> Option<std::process::ExitStatus> {
        let until = Instant::now() + limit;
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            if Instant::now() >= until {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The end of the firmware's log, decoded with `defmt-print` if it is
    /// installed.
    fn log_tail(&self) -> String {
        let raw = self.dir.join("defmt.raw");
        let decoded = on_path("defmt-print").and_then(|tool| {
            let input = std::fs::File::open(&raw).ok()?;
            let out = Command::new(tool)
                .arg("-e")
                .arg(&self.elf)
                .stdin(input)
                .stderr(Stdio::null())
                .output()
                .ok()?;
            Some(String::from_utf8_lossy(&out.stdout).into_owned())
        });
        match decoded {
            Some(text) if text.trim().is_empty() => {
                format!("the firmware logged nothing ({})", self.dir.display())
            }
            Some(text) => {
                let lines: Vec<&str> = text.lines().collect();
                let tail = &lines[lines.len().saturating_sub(15)..];
                format!("firmware log (last lines):\n  {}", tail.join("\n  "))
            }
            None => format!(
                "raw defmt log in {} (decode: defmt-print -e {} < it)",
                raw.display(),
                self.elf.display()
            ),
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            if let Ok(pid) = i32::try_from(self.child.id()) {
                use nix::sys::signal::{killpg, Signal};
                let _ = killpg(nix::unistd::Pid::from_raw(pid), Signal::SIGKILL);
            }
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

// ---------------------------------------------------------------------------
// The session: both lines, the emulator, the client, the checker

/// What the co-processor under test is.
enum Dut {
    /// A [`CoProcessor`] in a thread (`--host`).
    Thread {
        handle: Option<JoinHandle<Result<Counters, String>>>,
        stop: Arc<AtomicBool>,
    },
    /// The firmware under QEMU (`--qemu`).
    Qemu(Qemu),
    /// Something on two serial ports (`--ports`).
    Ports,
}

impl Dut {
    /// An error if the co-processor is gone.
    fn check(&mut self) -> Result<()> {
        match self {
            Dut::Thread { handle, .. } => {
                if handle.as_ref().is_some_and(|h| h.is_finished()) {
                    let result = handle.take().map(|h| h.join());
                    match result {
                        Some(Ok(Err(e))) => bail!("{e}"),
                        Some(Err(_)) => bail!("the co-processor thread panicked"),
                        _ => bail!("the co-processor thread stopped"),
                    }
                }
                Ok(())
            }
            Dut::Qemu(q) => q.check(),
            Dut::Ports => Ok(()),
        }
    }

    /// `error` happened on a line: if the co-processor has gone (QEMU
    /// exits a moment after it closes its sockets), say that instead.
    fn explain(&mut self, error: anyhow::Error) -> anyhow::Error {
        if let Dut::Qemu(q) = self {
            q.wait_exit(Duration::from_secs(1));
        }
        match self.check() {
            Err(gone) => anyhow!("{gone:#} (seen as: {error:#})"),
            Ok(()) => error,
        }
    }
}

impl Drop for Dut {
    fn drop(&mut self) {
        if let Dut::Thread { handle, stop } = self {
            stop.store(true, Ordering::Relaxed);
            if let Some(h) = handle.take() {
                let _ = h.join();
            }
        }
    }
}

/// A reply seen on the host line (not a scan, not a feature telegram).
struct HostReply {
    command: u8,
    data: Vec<u8>,
}

/// The emulator's clock: the real one, minus the time it was held.
struct EmuClock {
    origin: Instant,
    held_since: Option<Instant>,
    held: Duration,
}

impl EmuClock {
    fn new() -> Self {
        EmuClock {
            origin: Instant::now(),
            held_since: None,
            held: Duration::ZERO,
        }
    }

    fn now_us(&self) -> u64 {
        let now = self.held_since.unwrap_or_else(Instant::now);
        let t = now.duration_since(self.origin).saturating_sub(self.held);
        u64::try_from(t.as_micros()).unwrap_or(u64::MAX)
    }

    fn hold(&mut self) {
        if self.held_since.is_none() {
            self.held_since = Some(Instant::now());
        }
    }

    fn release(&mut self) {
        if let Some(t) = self.held_since.take() {
            self.held += t.elapsed();
        }
    }
}

/// The run's outcome.
#[derive(Debug)]
struct Outcome {
    wanted: usize,
    /// Scans of the selection sent and not back although the host line
    /// went quiet.
    lost: usize,
    /// Scans of the selection sent and not back yet at `--timeout`.
    late: usize,
    play_sent: usize,
    play_back: usize,
    play_identical: usize,
    other_back: usize,
    other_identical: usize,
    problems: usize,
    lines: u64,
    corners: u64,
    counters: Option<Counters>,
    counters_error: Option<String>,
    firmware_report: Option<String>,
    elapsed: Duration,
    streaming: Duration,
}

impl Outcome {
    fn ok(&self) -> bool {
        self.problems == 0
            && self.lost == 0
            && self.late == 0
            && self.play_back >= self.wanted
            && self.play_identical == self.play_back
            && self.other_identical == self.other_back
            && self.counters.is_some()
    }
}

/// Both ends of the co-processor and everything verify keeps.
struct Session {
    /// First, so that it is dropped first: QEMU is killed before its peers
    /// disconnect (it spins when they do).
    dut: Dut,
    sensor: Box<dyn Line>,
    host: Box<dyn Line>,
    console: Option<Box<dyn Line>>,
    console_text: Vec<u8>,
    emu: Emulator<PlaySource>,
    clock: EmuClock,
    /// The sensor's stream runs (the co-processor sent `20 24`).
    sensor_streaming: bool,
    /// `B0`s completed on the sensor line, and of those in the selection.
    sent: usize,
    play_sent: usize,
    wanted: usize,
    /// `--max-in-flight` (0 = off).
    max_in_flight: usize,
    /// Nothing more is to be sent (the selection is out, or time is up).
    finished: bool,
    framer: Framer,
    assembler: FeatureAssembler,
    /// The last `B0` on the host line, waiting for its features.
    pending_b0: Option<Vec<u8>>,
    replies: VecDeque<HostReply>,
    naks: u32,
    last_host_rx: Instant,
    checker: Checker,
    stop: Arc<AtomicBool>,
    verbose: bool,
    started: Instant,
}

impl Session {
    fn log(&self, msg: impl fmt::Display) {
        if self.verbose {
            eprintln!("[{:8.3} s] {msg}", self.started.elapsed().as_secs_f64());
        }
    }

    /// One pass: sensor bytes in, the emulator's bytes out, host bytes in
    /// (waiting up to `wait`), the console drained. A failing line is
    /// explained by the co-processor's end if it has one (QEMU's exit).
    fn pump(&mut self, wait: Duration) -> Result<()> {
        if self.stop.load(Ordering::Relaxed) {
            bail!("interrupted");
        }
        self.dut.check()?;
        self.pump_lines(wait).map_err(|e| self.dut.explain(e))
    }

    fn pump_lines(&mut self, wait: Duration) -> Result<()> {
        let mut buf = [0u8; 4096];
        loop {
            let n = self
                .sensor
                .read_some(&mut buf, Duration::ZERO)
                .with_context(|| format!("sensor line {}", self.sensor.name()))?;
            if n == 0 {
                break;
            }
            self.emu.receive(self.clock.now_us(), &buf[..n]);
        }
        self.pump_emulator()?;
        let mut wait = wait;
        loop {
            let n = self
                .host
                .read_some(&mut buf, wait)
                .with_context(|| format!("host line {}", self.host.name()))?;
            if n == 0 {
                break;
            }
            self.last_host_rx = Instant::now();
            self.feed_host(&buf[..n]);
            wait = Duration::ZERO;
        }
        if let Some(console) = self.console.as_mut() {
            loop {
                let n = console.read_some(&mut buf, Duration::ZERO)?;
                if n == 0 {
                    break;
                }
                self.console_text.extend_from_slice(&buf[..n]);
            }
        }
        Ok(())
    }

    /// Hold or release the emulator's clock (see *Sequence* in the module
    /// docs).
    fn update_hold(&mut self) {
        let armed = self.emu.source().armed();
        let in_flight = self.play_sent.saturating_sub(self.checker.play_back);
        let hold = self.finished
            || (self.sensor_streaming && !armed)
            || (armed && self.play_sent >= self.wanted)
            || (armed && self.max_in_flight > 0 && in_flight >= self.max_in_flight);
        if hold {
            self.clock.hold();
        } else {
            self.clock.release();
        }
    }

    /// Send what the emulator has due, act on its events.
    fn pump_emulator(&mut self) -> Result<()> {
        self.update_hold();
        let now = self.clock.now_us();
        let mut out = [0u8; 4096];
        loop {
            let n = self.emu.transmit(now, &mut out);
            if n > 0 {
                self.sensor
                    .send(&out[..n])
                    .with_context(|| format!("sensor line {}", self.sensor.name()))?;
            }
            while let Some(event) = self.emu.next_event() {
                match event {
                    EmuEvent::BaudSwitched { to, .. } => {
                        self.log(format!("sensor line to {} Bd", to.bits_per_second()));
                        self.sensor.set_baud(to)?;
                    }
                    EmuEvent::StreamStarted => {
                        self.sensor_streaming = true;
                        // Held until the client's stream is on.
                        self.update_hold();
                        self.log("sensor stream started (bring-up done)");
                    }
                    EmuEvent::StreamStopped => {
                        self.sensor_streaming = false;
                        self.log("sensor stream stopped by the co-processor");
                    }
                    EmuEvent::ScanSent { .. } => {
                        self.sent += 1;
                        let tag = self.emu.source().draws().get(self.sent - 1).map(|d| d.tag);
                        if let Some(Tag::Play(_)) = tag {
                            self.play_sent += 1;
                            self.update_hold();
                        }
                    }
                    EmuEvent::Request(h) => self.log(format!("sensor request: {h:?}")),
                    EmuEvent::BadChecksum => self.log("sensor side: bad checksum, NAK"),
                    EmuEvent::PowerOnSent
                    | EmuEvent::IgnoredAddress { .. }
                    | EmuEvent::Restarting => {}
                }
            }
            if n == 0 {
                return Ok(());
            }
        }
    }

    /// Bytes from the co-processor's host line.
    fn feed_host(&mut self, bytes: &[u8]) {
        let mut input = bytes;
        loop {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            match fed.event {
                Some(Event::Ack) => {}
                Some(Event::Nak) => self.naks += 1,
                Some(Event::Telegram(t)) => match t.command() {
                    0xB0 => {
                        if self.pending_b0.is_some() {
                            self.checker.without_features();
                        }
                        self.pending_b0 = Some(t.as_bytes().to_vec());
                    }
                    CMD_SUMMARY | CMD_LINES | CMD_CORNERS | CMD_EDGES | CMD_SEGMENTS => {
                        match self.assembler.push(&t) {
                            Ok(Assembled::Complete(summary, features)) => {
                                let b0 = self.pending_b0.take();
                                self.checker.check(
                                    b0.as_deref(),
                                    &summary,
                                    features,
                                    self.emu.source(),
                                );
                            }
                            Ok(_) => {}
                            Err(e) => self.checker.problem(e),
                        }
                    }
                    command => self.replies.push_back(HostReply {
                        command,
                        data: t.data().to_vec(),
                    }),
                },
                None if input.is_empty() => break,
                None => {}
            }
        }
    }

    /// Send `request` on the host line until the reply `reply` comes (every
    /// [`RETRY`], until `deadline`); returns the reply's data.
    fn exchange(
        &mut self,
        request: &[u8],
        reply: u8,
        what: &str,
        deadline: Instant,
    ) -> Result<Vec<u8>> {
        let mut attempts = 0u32;
        loop {
            if Instant::now() >= deadline {
                bail!(
                    "no answer to {what} on the host line {} ({attempts} attempts)",
                    self.host.name()
                );
            }
            self.replies.clear();
            self.naks = 0;
            self.host
                .send(request)
                .with_context(|| format!("host line {}", self.host.name()))?;
            attempts += 1;
            self.log(format!("client: {what} (attempt {attempts})"));
            let sent = Instant::now();
            while sent.elapsed() < RETRY && Instant::now() < deadline && self.naks == 0 {
                self.pump(TICK)?;
                if let Some(i) = self.replies.iter().position(|r| r.command == reply) {
                    let data = self.replies.remove(i).map(|r| r.data).unwrap_or_default();
                    return Ok(data);
                }
                if self.replies.iter().any(|r| r.command == 0x92) {
                    bail!(
                        "{what}: the host line answered 92 (unknown command){}",
                        if request.get(4) == Some(&REQ_COUNTERS) {
                            ": not the co-processor (the firmware's stand-in, or an LMS?)"
                        } else {
                            ""
                        }
                    );
                }
            }
        }
    }

    /// A mode request (`20 xx`): expects `A0 00`.
    fn mode(&mut self, request: Request<'_>, what: &str, deadline: Instant) -> Result<()> {
        let mut buf = [0u8; 64];
        let n = request.emit(0, &mut buf)?;
        let data = self.exchange(&buf[..n], 0xA0, what, deadline)?;
        ensure!(
            data.first() == Some(&0),
            "{what}: the co-processor answered A0 {:02X?}",
            data
        );
        Ok(())
    }

    /// The co-processor's counters (`55` → `D5`).
    fn counters(&mut self, deadline: Instant) -> Result<Counters> {
        let mut buf = [0u8; 16];
        let n = emit_telegram(&mut buf, 0, REQ_COUNTERS, &[], None)?;
        let data = self.exchange(&buf[..n], CMD_COUNTERS, "55 (counters)", deadline)?;
        Counters::decode(&data).context("malformed D5 counters")
    }

    /// The whole run (see the module docs).
    fn run(&mut self, host_baud: Baud, deadline: Instant) -> Result<Outcome> {
        // 1. The co-processor brings the sensor up by itself.
        self.log("waiting for the co-processor to bring the sensor up");
        while !self.sensor_streaming {
            if Instant::now() >= deadline {
                bail!(
                    "the co-processor did not bring the sensor up within --timeout \
                     (sensor side: {} requests answered)",
                    self.emu.stats().requests
                );
            }
            self.pump(TICK)?;
        }
        // 2. The first exchange on the host line, retried: the board may
        //    still be starting.
        let before = self.counters(deadline)?;
        self.log(format!("counters before: {before:?}"));
        // 3. The rate, then the stream.
        if host_baud != Baud::B9600 {
            self.mode(
                Request::SetBaud(host_baud),
                &format!(
                    "20 {:02X} ({} Bd)",
                    host_baud.mode_byte(),
                    host_baud.bits_per_second()
                ),
                deadline,
            )?;
            self.host.set_baud(host_baud)?;
        }
        self.mode(Request::Continuous, "20 24 (continuous output)", deadline)?;
        // 4. Play the selection.
        self.emu.source_mut().arm();
        let streaming = Instant::now();
        self.log(format!("playing {} scans", self.wanted));
        while self.play_sent < self.wanted && Instant::now() < deadline {
            self.pump(TICK)?;
        }
        self.finished = true;
        // 5. Let the rest come back.
        let timed_out = loop {
            if self.checker.play_back >= self.play_sent {
                break false;
            }
            if Instant::now() >= deadline {
                break true;
            }
            if self.last_host_rx.elapsed() >= QUIET {
                break false;
            }
            self.pump(TICK)?;
        };
        let streaming = streaming.elapsed();
        let missing = self.play_sent.saturating_sub(self.checker.play_back);
        let (lost, late) = if timed_out {
            (0, missing)
        } else {
            (missing, 0)
        };
        if self.pending_b0.take().is_some() {
            self.checker.without_features();
        }
        if self.assembler.discarded() > 0 {
            let n = self.assembler.discarded();
            self.checker.problem(format_args!(
                "{n} scans' feature telegrams were cut short (no D0)"
            ));
        }
        // 6. Stop the stream, read the counters.
        let closing = Instant::now() + CLOSING;
        let (counters, counters_error) = match self
            .mode(Request::OnRequest, "20 25 (stop the stream)", closing)
            .and_then(|()| self.counters(closing))
        {
            Ok(c) => (Some(c), None),
            Err(e) => (None, Some(format!("{e:#}"))),
        };
        let c = &self.checker;
        Ok(Outcome {
            wanted: self.wanted,
            lost,
            late,
            play_sent: self.play_sent,
            play_back: c.play_back,
            play_identical: c.play_identical,
            other_back: c.other_back,
            other_identical: c.other_identical,
            problems: c.problems,
            lines: c.lines,
            corners: c.corners,
            counters,
            counters_error,
            firmware_report: None,
            elapsed: self.started.elapsed(),
            streaming,
        })
    }

    /// The firmware's console report (`s`), then `q`.
    fn firmware_report(&mut self) -> Option<String> {
        self.console.as_ref()?;
        self.console_text.clear();
        let until = Instant::now() + Duration::from_secs(2);
        if let Some(c) = self.console.as_mut() {
            c.send(b"s").ok()?;
        }
        while !self.console_text.contains(&b'\n') && Instant::now() < until {
            if self.pump(TICK).is_err() {
                break;
            }
        }
        let text = String::from_utf8_lossy(&self.console_text)
            .trim()
            .to_string();
        if let Some(c) = self.console.as_mut() {
            let _ = c.send(b"q");
        }
        (!text.is_empty()).then_some(text)
    }
}

/// Stop flag set by SIGINT and SIGTERM.
fn stop_flag() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("cannot install the signal handler")?;
    }
    Ok(stop)
}

/// Run `host-bridge verify`.
pub fn run(args: &VerifyArgs) -> Result<()> {
    let started = Instant::now();
    ensure!(
        args.timeout.is_finite() && args.timeout > 0.0,
        "--timeout must be > 0 (seconds)"
    );
    let host_baud = Baud::from_bits_per_second(args.host_baud).with_context(|| {
        format!(
            "--host-baud {}: not a rate of the LMS 2xx (9600, 19200, 38400 or 500000)",
            args.host_baud
        )
    })?;
    let params = args.params.to_params()?;
    if let Some(t) = args.recompute_tau {
        ensure!(t.is_finite() && t > 0.0, "--recompute-tau must be > 0");
    }
    let (source, about) = play_source(args)?;
    let wanted = source.len();
    let timeout = Duration::from_secs_f64(args.timeout);
    let deadline = started + timeout;
    let stop = stop_flag()?;

    let (sensor, host, console, dut, how): (Box<dyn Line>, Box<dyn Line>, _, Dut, String) =
        if let Some(elf) = &args.qemu {
            let elf = firmware_elf(elf.as_deref())?;
            let ports = free_ports().context("no free TCP ports")?;
            let mut qemu = Qemu::start(&elf, ports, timeout + Duration::from_secs(30))?;
            let addr = |p: u16| SocketAddr::from((Ipv4Addr::LOCALHOST, p));
            let connect_by = Instant::now() + Duration::from_secs(10);
            let mut lines = Vec::new();
            for (p, name) in
                ports
                    .iter()
                    .zip(["host (USART1)", "sensor (USART2)", "console (USART3)"])
            {
                let line = TcpLine::connect(addr(*p), name.to_string(), connect_by, || {
                    ensure!(!stop.load(Ordering::Relaxed), "interrupted");
                    qemu.check()
                })?;
                lines.push(line);
            }
            let console = lines.pop().map(|l| Box::new(l) as Box<dyn Line>);
            let sensor = lines.pop().context("sensor line")?;
            let host = lines.pop().context("host line")?;
            let how = format!(
                "firmware {} under QEMU netduinoplus2 (pid {}), host line tcp:{}, sensor line tcp:{}, console tcp:{}",
                elf.display(),
                qemu.child.id(),
                ports[0],
                ports[1],
                ports[2]
            );
            (
                Box::new(sensor),
                Box::new(host),
                console,
                Dut::Qemu(qemu),
                how,
            )
        } else if let Some(ports) = &args.ports {
            let [host, sensor] = ports.as_slice() else {
                bail!("--ports takes two paths: HOST SENSOR");
            };
            let how = format!(
                "co-processor on serial ports {} (host line) and {} (sensor line)",
                host.display(),
                sensor.display()
            );
            (
                Box::new(TtyLine::open(sensor, Baud::B9600)?),
                Box::new(TtyLine::open(host, Baud::B9600)?),
                None,
                Dut::Ports,
                how,
            )
        } else {
            let sensor_pty = PtyPort::new(Pty::open(9600)?);
            let host_pty = PtyPort::new(Pty::open(9600)?);
            // Our ends first, so that nothing the co-processor sends is lost.
            let sensor = TtyLine::open(sensor_pty.slave_path(), Baud::B9600)?;
            let host = TtyLine::open(host_pty.slave_path(), Baud::B9600)?;
            let how = format!(
                "lms_core::device::coprocessor::CoProcessor in a thread, host line {}, sensor line {}",
                host_pty.slave_path().display(),
                sensor_pty.slave_path().display()
            );
            let params = params
                .validate()
                .map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
            let thread_stop = Arc::new(AtomicBool::new(false));
            let flag = Arc::clone(&thread_stop);
            let handle = std::thread::Builder::new()
                .name("coprocessor".into())
                .spawn(move || run_coprocessor(params, sensor_pty, host_pty, &flag))
                .context("cannot start the co-processor thread")?;
            let dut = Dut::Thread {
                handle: Some(handle),
                stop: thread_stop,
            };
            (Box::new(sensor), Box::new(host), None, dut, how)
        };
    eprintln!("host-bridge verify: {how}");
    eprintln!("host-bridge verify: sensor side plays {about}");

    let clock = EmuClock::new();
    let emu = Emulator::new(source, Settings::default(), clock.now_us());
    let max_in_flight = args
        .max_in_flight
        .unwrap_or(if args.qemu.is_some() { 8 } else { 0 });
    let mut session = Session {
        dut,
        sensor,
        host,
        console,
        console_text: Vec::new(),
        emu,
        clock,
        sensor_streaming: false,
        sent: 0,
        play_sent: 0,
        wanted,
        max_in_flight,
        finished: false,
        framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
        assembler: FeatureAssembler::new(),
        pending_b0: None,
        replies: VecDeque::new(),
        naks: 0,
        last_host_rx: Instant::now(),
        checker: Checker::new(params, args.recompute_tau),
        stop,
        verbose: args.verbose,
        started,
    };
    let result = session.run(host_baud, deadline);
    let result = result.map(|mut outcome| {
        outcome.firmware_report = session.firmware_report();
        outcome
    });
    let failed = !result.as_ref().is_ok_and(Outcome::ok);
    if let Dut::Qemu(q) = &mut session.dut {
        if failed {
            q.keep = true;
            eprintln!("host-bridge verify: {}", q.log_tail());
        } else if q.wait_exit(Duration::from_secs(2)).is_none() {
            eprintln!("host-bridge verify: note: QEMU did not exit on the console's q; killed");
        }
    }
    let outcome = result?;
    report(&outcome);
    drop(session);
    if !outcome.ok() {
        let mut why = Vec::new();
        if outcome.problems > 0 {
            why.push(format!("{} mismatches", outcome.problems));
        }
        if outcome.lost > 0 {
            why.push(format!("{} scans lost", outcome.lost));
        }
        if outcome.play_back < outcome.wanted {
            why.push(format!(
                "{} of {} scans checked before --timeout",
                outcome.play_back, outcome.wanted
            ));
        }
        if let Some(e) = &outcome.counters_error {
            why.push(format!("no counters at the end: {e}"));
        }
        bail!("verify failed: {}", why.join(", "));
    }
    Ok(())
}

/// The summary on stdout.
fn report(o: &Outcome) {
    let mut line = format!(
        "host-bridge verify: {}/{} scans bit-identical; {} lost ({} sent by the sensor side, {} back with features)",
        o.play_identical, o.play_back, o.lost, o.play_sent, o.play_back
    );
    if o.late > 0 {
        line.push_str(&format!("; {} still on their way at --timeout", o.late));
    }
    if o.other_back > 0 {
        line.push_str(&format!(
            "; scans outside the selection (warm-up): {}/{} bit-identical",
            o.other_identical, o.other_back
        ));
    }
    println!("{line}");
    println!(
        "host-bridge verify: compared {} lines and {} corners; {} mismatch lines",
        o.lines, o.corners, o.problems
    );
    match (&o.counters, &o.counters_error) {
        (Some(c), _) => println!(
            "host-bridge verify: co-processor counters: scans_in={} feature_scans_out={} \
             feature_telegrams_out={} sensor_crc_errors={} sensor_resyncs={} \
             sensor_bytes_skipped={} host_crc_errors={} scans_dropped={} scans_rejected={}",
            c.scans_in,
            c.feature_scans_out,
            c.feature_telegrams_out,
            c.sensor_crc_errors,
            c.sensor_resyncs,
            c.sensor_bytes_skipped,
            c.host_crc_errors,
            c.scans_dropped,
            c.scans_rejected
        ),
        (None, Some(e)) => println!("host-bridge verify: no counters at the end: {e}"),
        (None, None) => {}
    }
    if let Some(r) = &o.firmware_report {
        println!("host-bridge verify: firmware report: {r}");
    }
    let secs = o.streaming.as_secs_f64();
    println!(
        "host-bridge verify: {:.2} s in all, {:.2} s streaming ({:.1} scans/s back)",
        o.elapsed.as_secs_f64(),
        secs,
        if secs > 0.0 {
            (o.play_back + o.other_back) as f64 / secs
        } else {
            0.0
        }
    );
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

    #[test]
    fn verify_source_plays_each_scan_once_after_arming() {
        let frames = synthetic::frames(&SceneArgs {
            count: 3,
            ..SceneArgs::default()
        })
        .unwrap();
        let labels = (10..13).collect();
        let mut src =
            PlaySource::new(frames.iter().map(|f| f.frame.clone()).collect(), labels).unwrap();
        let mut out = [0u16; 361];
        let v = Variant::Fov180Res50;
        src.next_scan(v, Unit::Millimetre, &mut out);
        src.arm();
        for _ in 0..4 {
            src.next_scan(v, Unit::Millimetre, &mut out);
        }
        let tags: Vec<Tag> = src.draws().iter().map(|d| d.tag).collect();
        assert_eq!(
            tags,
            [
                Tag::Warmup,
                Tag::Play(0),
                Tag::Play(1),
                Tag::Play(2),
                Tag::Extra
            ]
        );
        assert_eq!(src.label(2), 12);
        // Play(k) is frame k in whole mm, as `extract` reads it.
        let want =
            MeasuredValues::from_frame(&frames[1].frame, Unit::Millimetre, RangeBits::Bits13, 0);
        assert_eq!(src.draws()[2].words, want.values());
    }

    #[test]
    fn verify_carmen_frames_get_their_last_beam_back() {
        let frame = Frame::from_metres(Variant::Fov180Res50.geometry(), &[1.5; 360]).unwrap();
        let full = resample_carmen(frame);
        assert_eq!(full.len(), 361);
        assert!(!full.beams()[360].is_valid());
        assert_eq!(full.ranges()[359], 1.5);
        // 1°: every beam twice at 0.5° (odd beams take the next one).
        let coarse = Frame::from_metres(
            Variant::Fov180Res100.geometry(),
            &(0..181).map(|j| 1.0 + j as f32 / 100.0).collect::<Vec<_>>(),
        )
        .unwrap();
        let mut src = PlaySource::new(vec![coarse], vec![0]).unwrap();
        src.arm();
        let mut out = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut out);
        assert_eq!(&out[..4], &[1000, 1010, 1010, 1020]);
        assert_eq!(out[360], 2800);
        // 100° scans cannot give 180°.
        let narrow = Frame::from_metres(Variant::Fov100Res50.geometry(), &[1.0; 201]).unwrap();
        assert!(PlaySource::new(vec![narrow], vec![0]).is_err());
    }
}
