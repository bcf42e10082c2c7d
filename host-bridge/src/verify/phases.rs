//! The phases of a run (see *Sequence* in the module docs): bring-up, the
//! host line's rate and stream, playing the selection, the rest coming
//! back, the closing requests.

use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use lms_core::telegram::features::Counters;
use lms_core::telegram::{Baud, Request};

use super::report::Outcome;
use super::session::{Session, SETTLE};
use super::{CLOSING, QUIET};
use crate::serial::TICK;

/// A disruption wanted after `after` scans of the selection back: `true`
/// once that many are back and it has not happened yet; once it has
/// (`done`), notes when the first scan of the selection came back after it.
fn disruption_due(
    after: Option<usize>,
    done: &mut Option<super::session::Recovery>,
    back: usize,
    now_us: u64,
) -> bool {
    if let Some(r) = done.as_mut() {
        if r.back_us.is_none() && back > r.after {
            r.back_us = Some(now_us);
        }
        return false;
    }
    after.is_some_and(|n| back >= n)
}

/// A disruption's outcome if it was asked for (`after`): what happened, or,
/// if it never happened, one that says after how many scans it was due.
fn asked_recovery(
    after: Option<usize>,
    done: Option<super::session::Recovery>,
) -> Option<super::session::Recovery> {
    after.map(|after| {
        done.unwrap_or(super::session::Recovery {
            after,
            ..Default::default()
        })
    })
}

/// The scans not back at the end.
struct Missing {
    /// Of the selection, given up once the host line was quiet.
    lost: usize,
    /// Of the selection, still on their way at `--timeout`.
    late: usize,
    /// Outside the selection (the warm-up scan), not back.
    other_lost: usize,
}

impl Session {
    /// The whole run (see the module docs).
    pub(super) fn run(&mut self, host_baud: Baud, deadline: Instant) -> Result<Outcome> {
        self.await_sensor_stream(deadline)?;
        // The first exchange on the host line, retried: the board may
        // still be starting.
        let before = self.counters(deadline)?;
        self.log(format!("counters before: {before:?}"));
        self.host_baud = host_baud;
        self.start_host_stream(host_baud, deadline)?;
        self.emu.source_mut().arm();
        let streaming = Instant::now();
        self.play(deadline)?;
        let missing = self.await_rest(deadline)?;
        let streaming = streaming.elapsed();
        self.log(format_args!(
            "the sensor's clock left out {:.1} ms while verify's loop was held off the CPU",
            self.clock.away().as_secs_f64() * 1000.0
        ));
        self.note_unfinished();
        let closing = self.close();
        Ok(self.outcome(missing, closing, streaming))
    }

    /// 1. The co-processor brings the sensor up by itself.
    fn await_sensor_stream(&mut self, deadline: Instant) -> Result<()> {
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
        Ok(())
    }

    /// 3. The host line's rate, then its stream.
    fn start_host_stream(&mut self, host_baud: Baud, deadline: Instant) -> Result<()> {
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
        self.host_rate = host_baud;
        self.features_on(deadline)?;
        self.mode(Request::Continuous, "20 24 (continuous output)", deadline)
    }

    /// 4. Play the selection.
    fn play(&mut self, deadline: Instant) -> Result<()> {
        self.log(format!("playing {} scans", self.wanted));
        while self.play_sent < self.wanted && Instant::now() < deadline {
            self.pump(TICK)?;
            self.maybe_power_cycle(deadline)?;
            self.maybe_reset_mcu(deadline)?;
        }
        self.finished = true;
        Ok(())
    }

    /// `--power-cycle-sensor-after N`: once N scans are back, hold the
    /// sensor until nothing is in flight, then switch it off and on (its
    /// `90`, 9600 Bd, values on request); note when the co-processor has
    /// it streaming again and when the next scan comes back.
    fn maybe_power_cycle(&mut self, deadline: Instant) -> Result<()> {
        let (back, now) = (self.checker.tally.play_back, self.clock.now_us());
        if !disruption_due(self.power_cycle_after, &mut self.power_cycle, back, now) {
            return Ok(());
        }
        self.quiesce_all(deadline)?;
        let on = self.clock.now_us();
        self.log("sensor side: switched off and on");
        self.emu.power_on(on);
        self.sensor_streaming = false;
        self.power_cycle = Some(super::session::Recovery {
            after: self.checker.tally.play_back,
            on_us: Some(on),
            ..Default::default()
        });
        Ok(())
    }

    /// Hold the sensor until the selection's scans sent are back and its
    /// line is idle, and every other scan is back or the host line has been
    /// quiet for [`SETTLE`] (the co-processor's budget may have dropped a
    /// warm-up scan), or `deadline`; then let its clock run again.
    fn quiesce_all(&mut self, deadline: Instant) -> Result<()> {
        self.quiesce = true;
        while Instant::now() < deadline {
            let t = &self.checker.tally;
            let others_done =
                t.play_back + t.other_back >= self.sent || self.last_host_rx.elapsed() >= SETTLE;
            if t.play_back >= self.play_sent && self.emu.line_idle() && others_done {
                break;
            }
            self.pump(TICK)?;
        }
        self.quiesce = false;
        self.clock.release();
        Ok(())
    }

    /// `--reset-mcu-after N`: once N scans are back, with nothing in flight,
    /// reset the MCU (QEMU's system reset) while the LMS keeps streaming at
    /// its fast rate. Then do what a client does when its sensor went
    /// silent: the host line back to 9600 Bd, the counters asked for until
    /// the co-processor answers, its rate, features and stream set up again;
    /// the selection resumes once a scan has come back through it. Scans
    /// sent meanwhile that never come back are lost to the reset (written
    /// off, not counted as lost).
    fn maybe_reset_mcu(&mut self, deadline: Instant) -> Result<()> {
        let (back, now) = (self.checker.tally.play_back, self.clock.now_us());
        if !disruption_due(self.reset_mcu_after, &mut self.mcu_reset, back, now) {
            return Ok(());
        }
        self.quiesce_all(deadline)?;
        self.emu.source_mut().disarm();
        self.recovering = true;
        self.qemu_intake = crate::qemu::QemuIntake::new();
        let at = self.clock.now_us();
        let held_before = self.clock.held();
        self.log("co-processor: MCU reset");
        self.dut.reset_mcu()?;
        self.mcu_reset = Some(super::session::Recovery {
            after: back,
            on_us: Some(at),
            ..Default::default()
        });
        self.host.set_baud(Baud::B9600)?;
        self.host_rate = Baud::B9600;
        self.host.discard_input()?;
        self.framer = super::session::host_framer();
        self.pending_b0 = None;
        let after = self.counters(deadline)?;
        self.log(format!("counters after the reset: {after:?}"));
        self.start_host_stream(self.host_baud, deadline)?;
        let t = &self.checker.tally;
        let back_before = t.other_back;
        while self.checker.tally.other_back == back_before {
            if Instant::now() >= deadline {
                bail!("no scan came back within --timeout after the MCU reset");
            }
            self.pump(TICK)?;
        }
        let t = &self.checker.tally;
        self.written_off = self.sent - self.play_sent - t.other_back;
        self.others_given_up = self.others_given_up.max(self.written_off);
        if let Some(r) = self.mcu_reset.as_mut() {
            r.first_back_us = Some(self.clock.now_us());
            r.waited_for_qemu = self.clock.held().saturating_sub(held_before);
        }
        self.recovering = false;
        self.emu.source_mut().arm();
        Ok(())
    }

    /// Step 5, let the rest come back: until all are back, the host line is
    /// quiet for [`QUIET`], or `deadline` passes (then the missing ones
    /// are late, not lost).
    fn await_rest(&mut self, deadline: Instant) -> Result<Missing> {
        let timed_out = loop {
            let t = &self.checker.tally;
            if t.play_back + t.other_back >= self.sent {
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
        let t = &self.checker.tally;
        let missing = self.play_sent.saturating_sub(t.play_back);
        let other_lost = (self.sent.saturating_sub(self.play_sent))
            .saturating_sub(t.other_back)
            .saturating_sub(self.written_off);
        let (lost, late) = if timed_out {
            (0, missing)
        } else {
            (missing, 0)
        };
        Ok(Missing {
            lost,
            late,
            other_lost,
        })
    }

    /// A `B0` still waiting for its features, and feature telegrams cut
    /// short, are failures.
    fn note_unfinished(&mut self) {
        if self.pending_b0.take().is_some() {
            self.checker.without_features();
        }
        if self.assembler.discarded() > 0 {
            let n = self.assembler.discarded();
            self.checker.problem(format_args!(
                "{n} scans' feature telegrams were cut short (no D0)"
            ));
        }
    }

    /// 6. Stop the stream, read the counters.
    fn close(&mut self) -> Result<Counters, String> {
        let closing = Instant::now() + CLOSING;
        self.mode(Request::OnRequest, "20 25 (stop the stream)", closing)
            .and_then(|()| self.counters(closing))
            .map_err(|e| format!("{e:#}"))
    }

    /// The outcome from the tally.
    fn outcome(
        &self,
        missing: Missing,
        closing: Result<Counters, String>,
        streaming: Duration,
    ) -> Outcome {
        let c = &self.checker;
        let (counters, counters_error) = match closing {
            Ok(c) => (Some(c), None),
            Err(e) => (None, Some(e)),
        };
        // Warm-up scans not back that the co-processor counted as dropped by
        // its host-line budget: sent before the client's stream was on.
        let budget_drops = counters.as_ref().map_or(0, |c| {
            usize::try_from(c.host_scans_dropped).unwrap_or(usize::MAX)
        });
        let warmup_dropped = missing.other_lost.min(budget_drops);
        Outcome {
            wanted: self.wanted,
            lost: missing.lost,
            late: missing.late,
            other_lost: missing.other_lost - warmup_dropped,
            warmup_dropped,
            play_sent: self.play_sent,
            sensor_restarts: self.sensor_restarts,
            power_cycle: asked_recovery(self.power_cycle_after, self.power_cycle),
            mcu_reset: asked_recovery(self.reset_mcu_after, self.mcu_reset),
            written_off: self.written_off,
            garbled: (
                self.line_rate.garbled_to_sensor,
                self.line_rate.garbled_to_firmware,
            ),
            timeout: self.timeout,
            tally: c.tally,
            counters,
            counters_error,
            firmware_report: None,
            elapsed: self.started.elapsed(),
            streaming,
        }
    }
}
