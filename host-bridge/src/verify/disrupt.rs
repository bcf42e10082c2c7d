//! The disruptions asked for, run: the LMS power cycle of
//! `--power-cycle-sensor-after` and the MCU reset of `--reset-mcu-after`,
//! each with the client's recovery from it.

use std::time::Instant;

use anyhow::{bail, Result};
use lms_core::telegram::Baud;

use super::client_side::host_framer;
use super::recovery::{disruption_due, Recovery};
use super::session::{Session, SETTLE};
use crate::qemu::QemuIntake;
use crate::serial::TICK;

impl Session {
    /// `--power-cycle-sensor-after N`: once N scans are back, hold the
    /// sensor until nothing is in flight, then switch it off and on (its
    /// `90`, 9600 Bd, values on request); note when the co-processor has
    /// it streaming again and when the next scan comes back.
    pub(super) fn maybe_power_cycle(&mut self, deadline: Instant) -> Result<()> {
        let (back, now) = (self.checker.tally.play_back, self.sensor.clock.now_us());
        if !disruption_due(
            self.recovery.power_cycle_after,
            &mut self.recovery.power_cycle,
            back,
            now,
        ) {
            return Ok(());
        }
        self.quiesce_all(deadline)?;
        let on = self.sensor.clock.now_us();
        self.log("sensor side: switched off and on");
        self.sensor.emu.power_on(on);
        self.sensor.streaming = false;
        self.recovery.power_cycle = Some(Recovery {
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
        self.sensor.quiesce = true;
        while Instant::now() < deadline {
            let t = &self.checker.tally;
            let others_done = t.play_back + t.other_back >= self.sensor.sent
                || self.client.last_rx.elapsed() >= SETTLE;
            if t.play_back >= self.sensor.play_sent && self.sensor.emu.line_idle() && others_done {
                break;
            }
            self.pump(TICK)?;
        }
        self.sensor.quiesce = false;
        self.sensor.clock.release();
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
    pub(super) fn maybe_reset_mcu(&mut self, deadline: Instant) -> Result<()> {
        let (back, now) = (self.checker.tally.play_back, self.sensor.clock.now_us());
        if !disruption_due(
            self.recovery.reset_mcu_after,
            &mut self.recovery.mcu_reset,
            back,
            now,
        ) {
            return Ok(());
        }
        self.quiesce_all(deadline)?;
        self.sensor.emu.source_mut().disarm();
        self.recovery.recovering = true;
        self.recovery.qemu_intake = QemuIntake::new();
        let at = self.sensor.clock.now_us();
        let held_before = self.sensor.clock.held();
        self.log("co-processor: MCU reset");
        self.dut.reset_mcu()?;
        self.recovery.mcu_reset = Some(Recovery {
            after: back,
            on_us: Some(at),
            ..Default::default()
        });
        self.client.link.set_baud(Baud::B9600)?;
        self.client.rate = Baud::B9600;
        self.client.link.discard_input()?;
        self.client.framer = host_framer();
        self.client.pending_b0 = None;
        let after = self.counters(deadline)?;
        self.log(format!("counters after the reset: {after:?}"));
        self.start_host_stream(self.client.baud, deadline)?;
        let t = &self.checker.tally;
        let back_before = t.other_back;
        while self.checker.tally.other_back == back_before {
            if Instant::now() >= deadline {
                bail!("no scan came back within --timeout after the MCU reset");
            }
            self.pump(TICK)?;
        }
        let t = &self.checker.tally;
        self.recovery.written_off = self.sensor.sent - self.sensor.play_sent - t.other_back;
        self.sensor.others_given_up = self.sensor.others_given_up.max(self.recovery.written_off);
        if let Some(r) = self.recovery.mcu_reset.as_mut() {
            r.first_back_us = Some(self.sensor.clock.now_us());
            r.waited_for_qemu = self.sensor.clock.held().saturating_sub(held_before);
        }
        self.recovery.recovering = false;
        self.sensor.emu.source_mut().arm();
        Ok(())
    }
}
