//! The check of every scan that comes back on the host line (see *The
//! check* in the module docs): the pass-through, the recomputation, the
//! comparison, and the tally.

use std::fmt;

use lms_core::params::FIELDS;
use lms_core::telegram::features::{EchoedParams, Summary};
use lms_core::telegram::{Direction, MeasuredView, RangeBits, Telegram};
use lms_core::{Extractor, Features, Params};

use super::compare::{differences, Value};
use super::source::{PlaySource, Tag};

/// What came back and how it compared: kept by the [`Checker`], reported
/// in the run's outcome.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tally {
    /// Scans of the selection back and checked, and of those identical.
    pub(super) play_back: usize,
    pub(super) play_identical: usize,
    /// Other scans (warm-up, extra) back and checked, and identical.
    pub(super) other_back: usize,
    pub(super) other_identical: usize,
    /// Lines printed for failures.
    pub(super) problems: usize,
    /// Lines and corners compared.
    pub(super) lines: u64,
    pub(super) corners: u64,
}

/// Checks every scan that comes back and keeps the tally.
pub(super) struct Checker {
    /// Parameters for what the summary does not echo.
    base: Params,
    recompute_tau: Option<f32>,
    extractor: Box<Extractor>,
    /// Draws before this index have been matched or passed over.
    cursor: usize,
    pub(super) tally: Tally,
    /// The parameters echoed by the first summary.
    echoed: Option<EchoedParams>,
}

impl Checker {
    pub(super) fn new(base: Params, recompute_tau: Option<f32>) -> Self {
        Checker {
            base,
            recompute_tau,
            extractor: Box::new(Extractor::new()),
            cursor: 0,
            tally: Tally::default(),
            echoed: None,
        }
    }

    /// Report a failure (one line on stdout).
    pub(super) fn problem(&mut self, msg: impl fmt::Display) {
        self.tally.problems += 1;
        println!("MISMATCH {msg}");
    }

    /// A `B0` that was not followed by its features.
    pub(super) fn without_features(&mut self) {
        self.problem("a B0 on the host line was not followed by its feature telegrams");
    }

    /// The recomputation parameters for a scan's summary.
    fn params(&self, echoed: &EchoedParams) -> Params {
        let ran = echoed.over(self.base);
        ran.with_tau(self.recompute_tau.unwrap_or(ran.tau))
    }

    /// Check one scan: its `B0` as the host received it (if one came), its
    /// summary and features as reassembled.
    pub(super) fn check(
        &mut self,
        b0: Option<&[u8]>,
        summary: &Summary,
        got: &Features,
        source: &PlaySource,
    ) {
        let counter = summary.scan_counter;
        if self.echoed.is_none() {
            self.echoed = Some(summary.params);
            let ran = summary.params.over(self.base);
            // The parameters the echo changes, by name ([`FIELDS`]).
            let differing: Vec<String> = FIELDS
                .iter()
                .filter(|f| (f.get)(&ran) != (f.get)(&self.base))
                .map(|f| format!("{}={}", f.name, (f.get)(&ran)))
                .collect();
            if !differing.is_empty() {
                eprintln!(
                    "host-bridge verify: note: the co-processor runs {} (echoed in D0), not the \
                     command line's; recomputing with those",
                    differing.join(" ")
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
                self.tally.play_back += 1;
                self.tally.play_identical += usize::from(identical);
            }
            _ => {
                self.tally.other_back += 1;
                self.tally.other_identical += usize::from(identical);
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
        self.tally.lines += got.lines().len() as u64;
        self.tally.corners += got.corners().len() as u64;
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
