//! The run's outcome and the summary on stdout.

use std::time::Duration;

use anyhow::{bail, Result};
use lms_core::telegram::features::Counters;

use super::checker::Tally;
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
        bail!("verify failed: {}", why.join(", "));
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
            (o.tally.play_back + o.tally.other_back) as f64 / secs
        } else {
            0.0
        }
    );
}
