//! The check of every scan that comes back on the host line (see *The
//! check* in the module docs): the pass-through, the recomputation, the
//! comparison, and the tally.

use std::fmt;

use lms_core::params::{FIELDS, PRESETS};
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
    /// The firmware's [`Params::fingerprint`] from its console
    /// (`params_fingerprint`; `--qemu` only), checked at the first summary.
    pub(super) firmware_fingerprint: Option<u32>,
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
            firmware_fingerprint: None,
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
    /// summary and features as reassembled. An error ends the run: the
    /// firmware runs other parameters than the check recomputes with.
    pub(super) fn check(
        &mut self,
        b0: Option<&[u8]>,
        summary: &Summary,
        got: &Features,
        source: &PlaySource,
    ) -> anyhow::Result<()> {
        if self.echoed.is_none() {
            self.first_summary(summary)?;
        }
        self.check_scan(b0, summary, got, source);
        Ok(())
    }

    /// The parameters the first summary echoes: noted where they change
    /// the command line's, and compared with the firmware's fingerprint.
    fn first_summary(&mut self, summary: &Summary) -> anyhow::Result<()> {
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
        match self.firmware_fingerprint {
            Some(firmware) if ran.fingerprint() != firmware => {
                anyhow::bail!(other_parameters(firmware, &summary.params, &ran))
            }
            _ => Ok(()),
        }
    }

    /// [`Checker::check`] of one scan, the parameters settled.
    fn check_scan(
        &mut self,
        b0: Option<&[u8]>,
        summary: &Summary,
        got: &Features,
        source: &PlaySource,
    ) {
        let counter = summary.scan_counter;
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

/// Why the firmware's features cannot be recomputed: its parameters
/// (fingerprint `firmware`) are not `ran`, the ones the check would use
/// with the `echoed` passes, σ, q and τ. Names the preset the firmware was
/// built with where one gives that fingerprint.
fn other_parameters(firmware: u32, echoed: &EchoedParams, ran: &Params) -> String {
    let check = PRESETS
        .iter()
        .find(|p| echoed.over(p.params) == *ran)
        .map_or_else(
            || "other parameters".to_string(),
            |p| format!("preset {}", p.name),
        );
    match PRESETS
        .iter()
        .find(|p| echoed.over(p.params).fingerprint() == firmware)
    {
        Some(p) => format!(
            "the firmware runs preset {0} (built with LMS_PRESET={0}) and this check {check}: \
             every scan would differ; run verify with --preset {0}",
            p.name
        ),
        None => format!(
            "the firmware runs parameters that no preset gives with the passes, sigma, q and \
             tau of its D0 (params_fingerprint {firmware:#010x} on its console, the check's \
             {:#010x}): its features cannot be recomputed here",
            ran.fingerprint()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_preset_in_the_firmware_is_named() {
        // The firmware built with LMS_PRESET=v3.2 and 8 passes; the check
        // recomputes with the defaults and the passes its D0 echoes.
        let firmware = Params::V3_2.with_iterations(8);
        let echoed = EchoedParams::from(&firmware);
        let ran = echoed.over(Params::DEFAULT);
        assert_ne!(ran.fingerprint(), firmware.fingerprint());
        let why = other_parameters(firmware.fingerprint(), &echoed, &ran);
        assert!(why.contains("runs preset v3.2"), "{why}");
        assert!(why.contains("this check preset default"), "{why}");
        assert!(why.contains("--preset v3.2"), "{why}");
        // Parameters no preset gives: said so, with both fingerprints.
        let odd = firmware.with_merge(!firmware.merge);
        let why = other_parameters(odd.fingerprint(), &echoed, &ran);
        assert!(why.contains("no preset gives"), "{why}");
        assert!(
            why.contains(&format!("{:#010x}", odd.fingerprint())),
            "{why}"
        );
    }
}
