//! The session: both lines of the co-processor, the sensor's side
//! ([`SensorSide`]), the client's ([`ClientSide`]), the disruptions and
//! their recovery ([`Recoveries`]) and the checker; one [`Session::pump`]
//! moves every byte that is due.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use lms_core::device::emulator::Event as EmuEvent;
use lms_core::Params;

use super::checker::Checker;
use super::client_side::ClientSide;
use super::dut::{Dut, Lines};
use super::recovery::Recoveries;
use super::sensor_side::SensorSide;
use super::source::{PlaySource, Tag};
use super::VerifyArgs;
use crate::serial::Link;

/// How long the host line must be quiet before a warm-up scan not back is
/// taken as dropped (it then no longer holds the sensor).
pub(super) const SETTLE: Duration = Duration::from_millis(500);

/// The sensor runs while the host line's backlog is below this: none. The
/// co-processor sends a scan's `B0` before its pipeline runs, so verify's
/// model of the line matches the co-processor's; any slack lets the next
/// scan reach the co-processor's budget early under QEMU, whose guest clock
/// lags the wall clock by up to a fifth.
const HOST_LINE_SLACK: Duration = Duration::ZERO;

/// Both ends of the co-processor and everything verify keeps.
pub(super) struct Session {
    /// First, so that it is dropped first: QEMU is killed before its peers
    /// disconnect (it spins when they do).
    pub(super) dut: Dut,
    pub(super) sensor: SensorSide,
    pub(super) client: ClientSide,
    pub(super) recovery: Recoveries,
    pub(super) console: Option<Box<dyn Link>>,
    pub(super) console_text: Vec<u8>,
    pub(super) checker: Checker,
    /// `--timeout`.
    pub(super) timeout: Duration,
    pub(super) stop: Arc<AtomicBool>,
    pub(super) verbose: bool,
    pub(super) started: Instant,
}

impl Session {
    /// The session on `lines`, playing `source`.
    pub(super) fn new(
        lines: Lines,
        source: PlaySource,
        args: &VerifyArgs,
        params: Params,
        stop: Arc<AtomicBool>,
        started: Instant,
    ) -> Self {
        Session {
            dut: lines.runner,
            sensor: SensorSide::new(lines.sensor, source, args),
            client: ClientSide::new(lines.host),
            recovery: Recoveries::new(args),
            console: lines.console,
            console_text: Vec::new(),
            checker: Checker::new(params, args.recompute_tau),
            timeout: Duration::from_secs_f64(args.timeout),
            stop,
            verbose: args.verbose,
            started,
        }
    }

    pub(super) fn log(&self, msg: impl fmt::Display) {
        if self.verbose {
            eprintln!("[{:8.3} s] {msg}", self.started.elapsed().as_secs_f64());
        }
    }

    /// One pass: sensor bytes in, the emulator's bytes out, host bytes in
    /// (waiting up to `wait`), the console drained. A failing line is
    /// explained by the co-processor's end if it has one (QEMU's exit).
    pub(super) fn pump(&mut self, wait: Duration) -> Result<()> {
        if self.stop.load(Ordering::Relaxed) {
            bail!("interrupted");
        }
        self.sensor.clock.pass();
        self.dut.check()?;
        self.pump_lines(wait).map_err(|e| self.dut.explain(e))
    }

    fn pump_lines(&mut self, wait: Duration) -> Result<()> {
        self.sensor.receive(&mut self.dut)?;
        self.pump_emulator()?;
        self.client
            .receive(wait, &mut self.checker, self.sensor.emu.source())?;
        let mut buf = [0u8; 4096];
        if let Some(console) = self.console.as_mut() {
            loop {
                let n = console.receive(&mut buf, Duration::ZERO)?;
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
        let armed = self.sensor.emu.source().armed();
        // Every scan not back, the warm-up scans too: they may all sit in
        // the firmware's sensor queue, and two scans back to back do not fit
        // one scan period of the host line (181 beams at 500 kBd). But a
        // warm-up scan is sent before the client's stream is on, and the
        // co-processor's host-line budget may drop it (a reply at 9600 Bd
        // takes more than a scan period): once the host line has been quiet
        // for [`SETTLE`] with only warm-up scans out, they are given up on,
        // so that they do not hold the sensor for good. Not while a `B0`
        // awaits its features: the co-processor sends the `B0` before it
        // runs the pipeline, which takes long on a loaded QEMU, and a scan
        // it gets before the features are out is not taken.
        let tally = &self.checker.tally;
        let play_out = self.sensor.play_sent.saturating_sub(tally.play_back);
        let others_out =
            (self.sensor.sent - self.sensor.play_sent).saturating_sub(tally.other_back);
        if play_out == 0
            && others_out > self.sensor.others_given_up
            && self.client.pending_b0.is_none()
            && self.client.last_rx.elapsed() >= SETTLE
        {
            self.sensor.others_given_up = others_out;
        }
        let in_flight = play_out + others_out.saturating_sub(self.sensor.others_given_up);
        let hold = self.sensor.finished
            || self.sensor.quiesce
            || (self.sensor.streaming && !armed && !self.recovery.recovering)
            || (self.recovery.recovering && self.recovery.qemu_intake.full())
            || (armed && self.sensor.play_sent >= self.sensor.wanted)
            || (armed && !self.sensor.runs_free && self.paced_hold(in_flight));
        if hold {
            self.sensor.clock.hold();
        } else {
            self.sensor.clock.release();
        }
    }

    /// The sensor waits for the co-processor: `in_flight` scans are out
    /// and not back, as many as `--max-in-flight` allows, or the host line
    /// is still busy with what came back.
    fn paced_hold(&self, in_flight: usize) -> bool {
        (self.sensor.max_in_flight > 0 && in_flight >= self.sensor.max_in_flight)
            || self.client.line_free > Instant::now() + HOST_LINE_SLACK
    }

    /// Send what the emulator has due, act on its events.
    fn pump_emulator(&mut self) -> Result<()> {
        self.update_hold();
        let now = self.sensor.clock.now_us();
        loop {
            let intake = self
                .recovery
                .recovering
                .then_some(&mut self.recovery.qemu_intake);
            let n = self.sensor.transmit(now, &mut self.dut, intake)?;
            while let Some(event) = self.sensor.emu.next_event() {
                match event {
                    EmuEvent::BaudSwitched { to, .. } => {
                        self.log(format!("sensor line to {} Bd", to.bits_per_second()));
                        self.sensor.link.set_baud(to)?;
                    }
                    EmuEvent::StreamStarted => {
                        self.sensor.streaming = true;
                        let now = self.sensor.clock.now_us();
                        for r in [
                            self.recovery.power_cycle.as_mut(),
                            self.recovery.mcu_reset.as_mut(),
                        ]
                        .into_iter()
                        .flatten()
                        {
                            r.streaming_us.get_or_insert(now);
                        }
                        // Held until the client's stream is on.
                        self.update_hold();
                        self.log("sensor stream started (bring-up done)");
                    }
                    EmuEvent::StreamStopped => {
                        self.sensor.streaming = false;
                        if self.sensor.emu.source().armed() && !self.sensor.finished {
                            self.sensor.restarts += 1;
                            eprintln!(
                                "host-bridge verify: the co-processor stopped the sensor's stream \
                                 while the selection played ({} scans sent): it restarted its \
                                 bring-up",
                                self.sensor.play_sent
                            );
                        }
                        self.log("sensor stream stopped by the co-processor");
                    }
                    EmuEvent::ScanSent { .. } => {
                        self.sensor.sent += 1;
                        let tag = self
                            .sensor
                            .emu
                            .source()
                            .draws()
                            .get(self.sensor.sent - 1)
                            .map(|d| d.tag);
                        if let Some(Tag::Play(_)) = tag {
                            self.sensor.play_sent += 1;
                            self.update_hold();
                        }
                    }
                    EmuEvent::Request(h) => self.log(format!("sensor request: {h:?}")),
                    EmuEvent::BadChecksum => self.log("sensor side: bad checksum, NAK"),
                    EmuEvent::PowerOnSent
                    | EmuEvent::IgnoredAddress { .. }
                    | EmuEvent::Restarting => {}
                    other => self.log(format!("sensor side: {other:?}")),
                }
            }
            if n == 0 {
                return Ok(());
            }
        }
    }
}
