//! The run's outcome and the summary on stdout.

use std::time::Duration;

use anyhow::{bail, Result};
use lms_core::telegram::features::Counters;

use super::checker::Tally;

/// The run's outcome.
#[derive(Debug)]
pub(super) struct Outcome {
    pub(super) wanted: usize,
    /// Scans of the selection sent and not back although the host line
    /// went quiet.
    pub(super) lost: usize,
    /// Scans of the selection sent and not back yet at `--timeout`.
    pub(super) late: usize,
    pub(super) play_sent: usize,
    pub(super) tally: Tally,
    pub(super) counters: Option<Counters>,
    pub(super) counters_error: Option<String>,
    pub(super) firmware_report: Option<String>,
    pub(super) elapsed: Duration,
    pub(super) streaming: Duration,
}

impl Outcome {
    pub(super) fn ok(&self) -> bool {
        self.tally.problems == 0
            && self.lost == 0
            && self.late == 0
            && self.tally.play_back >= self.wanted
            && self.tally.play_identical == self.tally.play_back
            && self.tally.other_identical == self.tally.other_back
            && self.counters.is_some()
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
        if self.lost > 0 {
            why.push(format!("{} scans lost", self.lost));
        }
        if self.tally.play_back < self.wanted {
            why.push(format!(
                "{} of {} scans checked before --timeout",
                self.tally.play_back, self.wanted
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
        o.tally.play_identical, o.tally.play_back, o.lost, o.play_sent, o.tally.play_back
    );
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
