//! The phases of a run (see *Sequence* in the module docs): bring-up, the
//! host line's rate and stream, playing the selection, the rest coming
//! back, the closing requests.

use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use lms_core::telegram::features::Counters;
use lms_core::telegram::{Baud, Request};

use super::report::Outcome;
use super::session::Session;
use super::{CLOSING, QUIET};
use crate::serial::TICK;

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
        self.note_firmware_params();
        // The first exchange on the host line, retried: the board may
        // still be starting.
        let before = self.counters(deadline)?;
        self.log(format!("counters before: {before:?}"));
        self.client.baud = host_baud;
        self.start_host_stream(host_baud, deadline)?;
        self.sensor.emu.source_mut().arm();
        let streaming = Instant::now();
        self.play(deadline)?;
        let missing = self.await_rest(deadline)?;
        let streaming = streaming.elapsed();
        self.log(format_args!(
            "the sensor's clock left out {:.1} ms while verify's loop was held off the CPU",
            self.sensor.clock.away().as_secs_f64() * 1000.0
        ));
        self.note_unfinished();
        let closing = self.close();
        Ok(self.outcome(missing, closing, streaming))
    }

    /// 1. The co-processor brings the sensor up by itself.
    fn await_sensor_stream(&mut self, deadline: Instant) -> Result<()> {
        self.log("waiting for the co-processor to bring the sensor up");
        while !self.sensor.streaming {
            if Instant::now() >= deadline {
                bail!(
                    "the co-processor did not bring the sensor up within --timeout \
                     (sensor side: {} requests answered)",
                    self.sensor.emu.stats().requests
                );
            }
            self.pump(TICK)?;
        }
        Ok(())
    }

    /// The firmware's parameters, by their fingerprint on its console
    /// (`--qemu`; a board's console is not connected): the checker
    /// compares them with its own at the first summary.
    fn note_firmware_params(&mut self) {
        let Some(report) = self.console_report() else {
            return;
        };
        self.checker.firmware_fingerprint = report
            .split_whitespace()
            .find_map(|field| field.strip_prefix("params_fingerprint="))
            .and_then(|v| v.parse().ok());
        self.log(format_args!(
            "firmware params_fingerprint: {:?}",
            self.checker.firmware_fingerprint
        ));
    }

    /// 3. The host line's rate, then its stream.
    pub(super) fn start_host_stream(&mut self, host_baud: Baud, deadline: Instant) -> Result<()> {
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
            self.client.link.set_baud(host_baud)?;
        }
        self.client.rate = host_baud;
        self.features_on(deadline)?;
        self.mode(Request::Continuous, "20 24 (continuous output)", deadline)
    }

    /// 4. Play the selection.
    fn play(&mut self, deadline: Instant) -> Result<()> {
        self.log(format!("playing {} scans", self.sensor.wanted));
        while self.sensor.play_sent < self.sensor.wanted && Instant::now() < deadline {
            self.pump(TICK)?;
            self.maybe_power_cycle(deadline)?;
            self.maybe_reset_mcu(deadline)?;
        }
        self.sensor.finished = true;
        Ok(())
    }

    /// Step 5, let the rest come back: until all are back, the host line is
    /// quiet for [`QUIET`], or `deadline` passes (then the missing ones
    /// are late, not lost).
    fn await_rest(&mut self, deadline: Instant) -> Result<Missing> {
        let timed_out = loop {
            let t = &self.checker.tally;
            if t.play_back + t.other_back >= self.sensor.sent {
                break false;
            }
            if Instant::now() >= deadline {
                break true;
            }
            if self.client.last_rx.elapsed() >= QUIET {
                break false;
            }
            self.pump(TICK)?;
        };
        let t = &self.checker.tally;
        let missing = self.sensor.play_sent.saturating_sub(t.play_back);
        let other_lost = (self.sensor.sent.saturating_sub(self.sensor.play_sent))
            .saturating_sub(t.other_back)
            .saturating_sub(self.recovery.written_off);
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
        if self.client.pending_b0.take().is_some() {
            self.checker.without_features();
        }
        if self.client.assembler.discarded() > 0 {
            let n = self.client.assembler.discarded();
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
        let (power_cycle, mcu_reset) = self.recovery.outcomes();
        Outcome {
            wanted: self.sensor.wanted,
            lost: missing.lost,
            late: missing.late,
            other_lost: missing.other_lost - warmup_dropped,
            warmup_dropped,
            play_sent: self.sensor.play_sent,
            sensor_restarts: self.sensor.restarts,
            power_cycle,
            mcu_reset,
            written_off: self.recovery.written_off,
            garbled: (
                self.sensor.line_rate.garbled_to_sensor,
                self.sensor.line_rate.garbled_to_firmware,
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
