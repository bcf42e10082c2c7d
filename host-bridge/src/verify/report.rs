//! The run's outcome and the summary on stdout.

use std::time::Duration;

use anyhow::{bail, Result};
use lms_core::telegram::features::{CounterKind, Counters};

use super::checker::Tally;
use super::recovery::Recovery;
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
    /// Every scan the sensor side sent and never got back with features
    /// (but the warm-up scans dropped by the budget before the client's
    /// stream was on).
    pub(super) fn all_lost(&self) -> usize {
        self.lost + self.other_lost
    }

    /// Every scan the sensor side sent that did not come back, the warm-up
    /// scans the budget dropped included (not those written off to an MCU
    /// reset): what the co-processor's drop counters must add up to.
    fn not_back(&self) -> usize {
        self.all_lost() + self.warmup_dropped
    }

    /// The co-processor's drop counters that are not 0, and the warm-up
    /// scans among them (as [`not_back`](Self::not_back) counts them).
    fn counted(&self) -> String {
        let Some(c) = &self.counters else {
            return "nothing (no counters)".into();
        };
        match self.warmup_dropped {
            0 => counted_drops(c),
            n => format!(
                "{}, {n} of them warm-up scans dropped before the client's stream was on",
                counted_drops(c)
            ),
        }
    }

    /// The co-processor's drop counters ([`drop_counters`]) do not add up
    /// to verify's own count of the scans not back (only when both are
    /// known: no scan still late): what they say. A scan written off to an
    /// MCU reset may have reached the rebooted firmware and been dropped
    /// there, counted, or been lost in QEMU's queue while it booted: each
    /// may or may not be counted.
    fn dropped_miscounted(&self) -> Option<String> {
        let c = self.counters.as_ref()?;
        let counted: u64 = drop_counters(c).map(|(_, n)| u64::from(n)).sum();
        let not_back = self.not_back() as u64;
        let adds_up = (not_back..=not_back + self.written_off as u64).contains(&counted);
        (self.late == 0 && !adds_up).then(|| counted_drops(c))
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
        let miscounted = self.dropped_miscounted();
        if self.all_lost() > 0 {
            let counted = match (&self.counters, &miscounted) {
                (Some(_), None) => format!(", as the co-processor counted ({})", self.counted()),
                _ => String::new(),
            };
            why.push(format!(
                "{} scans lost (sent by the sensor side, not back although the host line \
                 was quiet for {} s){counted}",
                self.all_lost(),
                QUIET.as_secs()
            ));
        }
        if let Some(counted) = miscounted {
            why.push(format!(
                "the co-processor's drop counters ({counted}) do not add up to the {} scans \
                 not back ({} lost, {} warm-up scans dropped before the client's stream was on)",
                self.not_back(),
                self.all_lost(),
                self.warmup_dropped
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

/// The co-processor's counters of the scans of the sensor's stream it did
/// not pass on ([`CounterKind::ScanLoss`]), by name: lost on the way in,
/// rejected, dropped by the host-line budget, of another setting.
fn drop_counters(c: &Counters) -> impl Iterator<Item = (&'static str, u32)> {
    c.entries()
        .filter(|e| e.1 == CounterKind::ScanLoss)
        .map(|(name, _, n)| (name, n))
}

/// The drop counters that are not 0, as the counters line names them
/// (`host_scans_dropped=3`), or that all are 0.
fn counted_drops(c: &Counters) -> String {
    let named: Vec<String> = drop_counters(c)
        .filter(|&(_, n)| n > 0)
        .map(|(name, n)| format!("{name}={n}"))
        .collect();
    if !named.is_empty() {
        return named.join(", ");
    }
    let names: Vec<&str> = drop_counters(c).map(|(name, _)| name).collect();
    match names.split_last() {
        Some((last, rest)) => format!("{} and {last} all 0", rest.join(", ")),
        None => "no drop counters".into(),
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
            Some(_) => format!("; the co-processor counted {}", o.counted()),
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
        (Some(c), _) => {
            let named: Vec<String> = c
                .entries()
                .filter(|e| e.1 != CounterKind::Boot)
                .map(|(name, _, n)| format!("{name}={n}"))
                .collect();
            println!(
                "host-bridge verify: co-processor counters: {}",
                named.join(" ")
            );
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of 10 scans of which `lost` did not come back, with the
    /// co-processor's counters `counters` (no warm-up scan dropped).
    fn outcome(lost: usize, counters: Counters) -> Outcome {
        Outcome {
            wanted: 10,
            lost,
            late: 0,
            other_lost: 0,
            play_sent: 10,
            sensor_restarts: 0,
            timeout: Duration::from_secs(60),
            power_cycle: None,
            mcu_reset: None,
            warmup_dropped: 0,
            written_off: 0,
            garbled: (0, 0),
            tally: Tally {
                play_back: 10 - lost,
                play_identical: 10 - lost,
                ..Tally::default()
            },
            counters: Some(counters),
            counters_error: None,
            firmware_report: None,
            elapsed: Duration::from_secs(1),
            streaming: Duration::from_secs(1),
        }
    }

    fn verdict(o: &Outcome) -> String {
        format!("{:#}", o.verdict().unwrap_err())
    }

    #[test]
    fn a_loss_is_named_by_the_counter_that_counted_it() {
        let counters = Counters {
            host_scans_dropped: 3,
            ..Counters::ZERO
        };
        let o = outcome(3, counters);
        let why = verdict(&o);
        assert!(
            why.contains("3 scans lost") && why.contains("host_scans_dropped=3"),
            "{why}"
        );
        assert!(!why.contains("do not add up"), "{why}");
        // A warm-up scan dropped too: the same counter, the same number.
        let counters = Counters {
            host_scans_dropped: 4,
            ..Counters::ZERO
        };
        let why = verdict(&Outcome {
            warmup_dropped: 1,
            ..outcome(3, counters)
        });
        assert!(
            why.contains("host_scans_dropped=4, 1 of them warm-up"),
            "{why}"
        );
        assert!(!why.contains("do not add up"), "{why}");
    }

    #[test]
    fn counters_that_do_not_add_up_fail_the_run_and_say_so() {
        // Lost scans the co-processor did not count.
        let why = verdict(&outcome(2, Counters::ZERO));
        assert!(why.contains("2 scans lost"), "{why}");
        assert!(
            why.contains(
                "drop counters (scans_dropped, scans_rejected, host_scans_dropped and \
                 scans_other_setting all 0) do not add up to the 2 scans not back"
            ),
            "{why}"
        );
        // Drops counted, nothing lost: fails too.
        let counters = Counters {
            scans_dropped: 1,
            ..Counters::ZERO
        };
        let o = outcome(0, counters);
        assert!(!o.ok());
        let why = verdict(&o);
        assert!(
            why.contains("(scans_dropped=1) do not add up to the 0 scans"),
            "{why}"
        );
        // All back, nothing counted: passes.
        assert!(outcome(0, Counters::ZERO).ok());
    }

    #[test]
    fn scans_written_off_to_an_mcu_reset_may_be_counted_or_not() {
        let dropped = |n: u32| Counters {
            host_scans_dropped: n,
            ..Counters::ZERO
        };
        let written_off = |n: u32, written_off: usize| Outcome {
            written_off,
            ..outcome(0, dropped(n))
        };
        // Seven written off: none, one or all seven counted by the rebooted
        // firmware add up; eight do not.
        for n in [0, 1, 7] {
            assert!(written_off(n, 7).dropped_miscounted().is_none(), "{n}");
        }
        assert!(written_off(8, 7).dropped_miscounted().is_some());
        // None written off: every drop is one not back.
        assert!(written_off(1, 0).dropped_miscounted().is_some());
    }
}
