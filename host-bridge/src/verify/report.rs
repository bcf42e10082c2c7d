//! The run's outcome and the summary on stdout.

use std::time::Duration;

use anyhow::{bail, Result};
use lms_core::telegram::features::Counters;

use super::checker::Tally;
use super::session::Recovery;
use super::QUIET;

/// The run's outcome.
#[derive(Debug)]
pub(super) struct Outcome {
    pub(super) wanted: usize,
    /// Scans of the selection sent and not back although the host line
    /// went quiet for [`QUIET`].
    pub(super) lost: usize,
    /// Scans of the selection sent and not back yet at `--timeout`.
    pub(super) late: usize,
    /// Scans outside the selection (the warm-up) sent and not back.
    pub(super) other_lost: usize,
    pub(super) play_sent: usize,
    /// Times the co-processor stopped the sensor's stream while the
    /// selection played.
    pub(super) sensor_restarts: usize,
    /// `--timeout`.
    pub(super) timeout: Duration,
    /// `--power-cycle-sensor-after`, if given: what happened.
    pub(super) power_cycle: Option<Recovery>,
    /// `--reset-mcu-after`, if given: what happened.
    pub(super) mcu_reset: Option<Recovery>,
    /// Warm-up scans not back that the co-processor counted as dropped by
    /// its host-line budget (not lost: sent before the client's stream was
    /// on, while a reply at 9600 Bd held the line).
    pub(super) warmup_dropped: usize,
    /// Scans outside the selection lost to the MCU reset (not counted).
    pub(super) written_off: usize,
    /// Bytes the sensor line's rate model garbled (to the LMS, to the
    /// firmware): the two ends' rates differed.
    pub(super) garbled: (u64, u64),
    pub(super) tally: Tally,
    pub(super) counters: Option<Counters>,
    pub(super) counters_error: Option<String>,
    pub(super) firmware_report: Option<String>,
    pub(super) elapsed: Duration,
    pub(super) streaming: Duration,
}

impl Outcome {
    /// Every scan the sensor side sent and never got back with features.
    pub(super) fn all_lost(&self) -> usize {
        self.lost + self.other_lost
    }

    /// The co-processor's `scans_dropped` disagrees with verify's own count
    /// of lost scans (only when both are known: no scan still late).
    fn dropped_miscounted(&self) -> Option<u32> {
        let c = self.counters.as_ref()?;
        let counted = usize::try_from(c.scans_dropped).ok()?;
        (self.late == 0 && counted != self.all_lost()).then_some(c.scans_dropped)
    }

    pub(super) fn ok(&self) -> bool {
        self.tally.problems == 0
            && self.all_lost() == 0
            && self.late == 0
            && self.sensor_restarts == 0
            && self.tally.play_back >= self.wanted
            && self.tally.play_identical == self.tally.play_back
            && self.tally.other_identical == self.tally.other_back
            && self.counters.is_some()
            && self.dropped_miscounted().is_none()
            && self.power_cycle_problem().is_none()
            && self.mcu_reset_problem().is_none()
    }

    /// Longest time from a disruption (the LMS's power-on, the MCU reset)
    /// to the first scan back (µs).
    pub(super) const RECOVERY_LIMIT_US: u64 = 1_000_000;

    /// What went wrong with `--power-cycle-sensor-after`, if anything.
    fn power_cycle_problem(&self) -> Option<String> {
        recovery_problem(self.power_cycle?, "the sensor's power cycle", |r| r.back_us)
    }

    /// What went wrong with `--reset-mcu-after`, if anything.
    fn mcu_reset_problem(&self) -> Option<String> {
        let r = self.mcu_reset?;
        recovery_problem(r, "the MCU reset", |r| r.first_back_us).or_else(|| {
            r.back_us
                .is_none()
                .then(|| "no scan of the selection came back after the MCU reset".into())
        })
    }

    /// `Ok` if the run passed, else an error naming why it failed.
    pub(super) fn verdict(&self) -> Result<()> {
        if self.ok() {
            return Ok(());
        }
        let mut why = Vec::new();
        if self.tally.problems > 0 {
            why.push(format!("{} mismatches", self.tally.problems));
        }
        if self.all_lost() > 0 {
            why.push(format!(
                "{} scans lost (sent by the sensor side, not back although the host line \
                 was quiet for {} s)",
                self.all_lost(),
                QUIET.as_secs()
            ));
        }
        if let Some(counted) = self.dropped_miscounted() {
            why.push(format!(
                "the co-processor counted scans_dropped={counted}, verify {} lost",
                self.all_lost()
            ));
        }
        if self.sensor_restarts > 0 {
            why.push(format!(
                "the co-processor restarted the sensor {} times during the run",
                self.sensor_restarts
            ));
        }
        let secs = self.timeout.as_secs_f64();
        if self.play_sent < self.wanted {
            why.push(format!(
                "--timeout ({secs} s) ran out after {} of {} scans were sent",
                self.play_sent, self.wanted
            ));
        } else if self.late > 0 {
            why.push(format!(
                "--timeout ({secs} s) ran out with {} scans still on their way",
                self.late
            ));
        }
        if let Some(e) = &self.counters_error {
            why.push(format!("no counters at the end: {e}"));
        }
        why.extend(self.power_cycle_problem());
        why.extend(self.mcu_reset_problem());
        bail!("verify failed: {}", why.join(", "));
    }
}

/// What went wrong with a disruption `r` (named `what`), if anything:
/// it never happened, nothing came back (by `back`), or too late.
fn recovery_problem(
    r: Recovery,
    what: &str,
    back: impl Fn(&Recovery) -> Option<u64>,
) -> Option<String> {
    let Some(on) = r.on_us else {
        return Some(format!(
            "{what} never happened (fewer than {} scans back)",
            r.after
        ));
    };
    match back(&r) {
        None => Some(format!("no scan came back after {what}")),
        Some(t) if t - on > Outcome::RECOVERY_LIMIT_US => Some(format!(
            "the first scan came back {} ms after {what} (limit {} ms)",
            (t - on) / 1000,
            Outcome::RECOVERY_LIMIT_US / 1000
        )),
        Some(_) => None,
    }
}

/// The summary's lines on power cycles, MCU resets, scans written off and
/// the sensor line's rate model.
fn report_disruptions(o: &Outcome) {
    let ms = |t: Option<u64>, on: Option<u64>| match (t, on) {
        (Some(t), Some(on)) => format!("{:.1} ms", (t - on) as f64 / 1000.0),
        _ => "never".into(),
    };
    if let Some(pc) = o.power_cycle {
        println!(
            "host-bridge verify: sensor power-cycled after {} scans: streaming again after {}, \
             first scan back after {} (sensor clock)",
            pc.after,
            ms(pc.streaming_us, pc.on_us),
            ms(pc.back_us, pc.on_us)
        );
    }
    if let Some(r) = o.mcu_reset {
        println!(
            "host-bridge verify: MCU reset after {} scans: sensor streaming again after {}, \
             first scan back after {}, the selection's after {} (sensor clock; the client's \
             set-up included); {} warm-up scans lost to the reset; the sensor waited {:.1} ms \
             (wall clock) for QEMU's UART meanwhile",
            r.after,
            ms(r.streaming_us, r.on_us),
            ms(r.first_back_us, r.on_us),
            ms(r.back_us, r.on_us),
            o.written_off,
            r.waited_for_qemu.as_secs_f64() * 1000.0
        );
    }
    if o.warmup_dropped > 0 {
        println!(
            "host-bridge verify: {} warm-up scans dropped by the co-processor's host-line budget \
             (counted in host_scans_dropped; sent before the client's stream was on)",
            o.warmup_dropped
        );
    }
    if o.garbled != (0, 0) {
        println!(
            "host-bridge verify: sensor line rate model: {} bytes to the sensor and {} to the \
             firmware arrived as noise (the two ends' rates differed)",
            o.garbled.0, o.garbled.1
        );
    }
}

/// The summary on stdout.
pub(super) fn report(o: &Outcome) {
    let mut line = format!(
        "host-bridge verify: {}/{} scans bit-identical; {} lost ({} sent by the sensor side, {} back with features)",
        o.tally.play_identical, o.tally.play_back, o.all_lost(), o.play_sent, o.tally.play_back
    );
    if o.all_lost() > 0 {
        line.push_str(&match &o.counters {
            Some(c) => format!("; the co-processor counted {} dropped", c.scans_dropped),
            None => "; the co-processor's count is unknown".into(),
        });
    }
    if o.late > 0 {
        line.push_str(&format!("; {} still on their way at --timeout", o.late));
    }
    if o.tally.other_back > 0 {
        line.push_str(&format!(
            "; scans outside the selection (warm-up): {}/{} bit-identical",
            o.tally.other_identical, o.tally.other_back
        ));
    }
    println!("{line}");
    println!(
        "host-bridge verify: compared {} lines and {} corners; {} mismatch lines",
        o.tally.lines, o.tally.corners, o.tally.problems
    );
    match (&o.counters, &o.counters_error) {
        (Some(c), _) => println!(
            "host-bridge verify: co-processor counters: scans_in={} feature_scans_out={} \
             feature_telegrams_out={} sensor_crc_errors={} sensor_resyncs={} \
             sensor_bytes_skipped={} host_crc_errors={} scans_dropped={} scans_rejected={} \
             host_scans_dropped={} scans_other_setting={}",
            c.scans_in,
            c.feature_scans_out,
            c.feature_telegrams_out,
            c.sensor_crc_errors,
            c.sensor_resyncs,
            c.sensor_bytes_skipped,
            c.host_crc_errors,
            c.scans_dropped,
            c.scans_rejected,
            c.host_scans_dropped,
            c.scans_other_setting
        ),
        (None, Some(e)) => println!("host-bridge verify: no counters at the end: {e}"),
        (None, None) => {}
    }
    report_disruptions(o);
    if let Some(r) = &o.firmware_report {
        println!("host-bridge verify: firmware report: {r}");
    }
    let secs = o.streaming.as_secs_f64();
    println!(
        "host-bridge verify: {:.2} s in all, {:.2} s streaming ({:.1} scans/s back)",
        o.elapsed.as_secs_f64(),
        secs,
        if secs > 0.0 {
            (o.tally.play_back + o.tally.other_back) as f64 / secs
        } else {
            0.0
        }
    );
}
