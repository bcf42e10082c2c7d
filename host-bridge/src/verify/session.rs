//! The session: both lines, the emulator on the sensor line, the client's
//! framer and feature assembler on the host line, the checker; one
//! [`Session::pump`] moves every byte that is due.

use std::collections::VecDeque;
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use lms_core::device::emulator::{Emulator, Event as EmuEvent, Settings};
use lms_core::telegram::features::{
    Assembled, FeatureAssembler, CMD_CORNERS, CMD_EDGES, CMD_LINES, CMD_SEGMENTS, CMD_SUMMARY,
};
use lms_core::telegram::{Baud, Direction, Event, Framer, Handshake};
use lms_core::Params;

use super::checker::Checker;
use super::dut::{Dut, Lines};
use super::line_rate::{LineRate, Toward};
use super::source::{PlaySource, Tag};
use super::VerifyArgs;
use crate::qemu::QemuIntake;
use crate::serial::Link;

/// A reply seen on the host line (not a scan, not a feature telegram).
pub(super) struct HostReply {
    pub(super) command: u8,
    pub(super) data: Vec<u8>,
}

/// Longest step of the emulator's clock from one pass of verify's loop to
/// the next ([`EmuClock::pass`]); a pass waits at most [`super::TICK`].
pub(super) const MAX_STEP: Duration = Duration::from_millis(5);

/// The emulator's clock: the real one, minus the time it was held and the
/// time verify's loop was away.
///
/// A real LMS sends every scan one period after the last, whatever its
/// client does. The emulator sends what is due by its clock when verify's
/// loop runs; on a loaded machine that loop is held off the CPU for tens
/// to hundreds of milliseconds (seen: 100 ms), and a clock that ran on
/// meanwhile had three scans due at once, which reached the co-processor
/// back to back, as no sensor sends them. So the clock advances at most
/// [`MAX_STEP`] from one pass to the next: time the loop was away beyond
/// that is not the sensor's (`away`).
pub(super) struct EmuClock {
    origin: Instant,
    held_since: Option<Instant>,
    held: Duration,
    away: Duration,
    last_pass: Instant,
}

impl EmuClock {
    fn new() -> Self {
        let origin = Instant::now();
        EmuClock {
            origin,
            held_since: None,
            held: Duration::ZERO,
            away: Duration::ZERO,
            last_pass: origin,
        }
    }

    pub(super) fn now_us(&self) -> u64 {
        let now = self.held_since.unwrap_or_else(Instant::now);
        let t = now
            .duration_since(self.origin)
            .saturating_sub(self.held + self.away);
        u64::try_from(t.as_micros()).unwrap_or(u64::MAX)
    }

    /// A pass of verify's loop begins: a gap since the last one beyond
    /// [`MAX_STEP`], while the clock ran, does not count.
    pub(super) fn pass(&mut self) {
        let now = Instant::now();
        let gap = now.duration_since(self.last_pass);
        if self.held_since.is_none() && gap > MAX_STEP {
            self.away += gap - MAX_STEP;
        }
        self.last_pass = now;
    }

    /// Time verify's loop was away, beyond [`MAX_STEP`] a pass, while the
    /// clock ran (not counted on it).
    pub(super) fn away(&self) -> Duration {
        self.away
    }

    fn hold(&mut self) {
        if self.held_since.is_none() {
            self.held_since = Some(Instant::now());
        }
    }

    /// Time held so far (wall clock).
    pub(super) fn held(&self) -> Duration {
        self.held + self.held_since.map_or(Duration::ZERO, |t| t.elapsed())
    }

    pub(super) fn release(&mut self) {
        if let Some(t) = self.held_since.take() {
            self.held += t.elapsed();
        }
    }
}

/// Bytes the firmware's sensor receive queue holds: `SENSOR_RX_SLOTS` − 1
/// in `firmware/src/board.rs` (a `heapless::spsc` queue of 1024 slots;
/// checked against that file by `tests/verify_qemu.rs`). A full queue holds
/// QEMU's UART (receive backpressure), so more in flight waits, not lost.
pub(super) const FIRMWARE_SENSOR_QUEUE: usize = 1023;

/// Scans out at once with `--qemu` (the default of `--max-in-flight`): as
/// many whole 361-value `B0`s (732 bytes) as fit the firmware's sensor
/// receive queue, 1023 / 742 = 1. QEMU drains a UART at about 10 KB/s, a
/// third of the line rate, so the scans not back yet may all be waiting in
/// that queue: more in flight than it holds are lost.
pub(super) fn qemu_max_in_flight() -> usize {
    // The count word and 361 value words (the played variant, 180°/0.5°).
    let data = 2 + 2 * lms_core::Variant::Fov180Res50.beams();
    let b0 = lms_core::telegram::buffer_len(data, Direction::SensorToHost);
    (FIRMWARE_SENSOR_QUEUE / b0).max(1)
}

/// A disruption and the recovery from it (emulator clock, µs): the LMS
/// power cycle of `--power-cycle-sensor-after` or the MCU reset of
/// `--reset-mcu-after`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Recovery {
    /// Scans of the selection back when it happened.
    pub(super) after: usize,
    /// When it happened (the LMS switched on again; the MCU reset).
    pub(super) on_us: Option<u64>,
    /// When the co-processor had started its stream again.
    pub(super) streaming_us: Option<u64>,
    /// When the first scan of the selection came back after it.
    pub(super) back_us: Option<u64>,
    /// MCU reset: when the first scan of any kind came back after it (the
    /// selection resumes then).
    pub(super) first_back_us: Option<u64>,
    /// MCU reset: wall time the sensor waited, until that first scan, for
    /// QEMU's UART to take what it had sent (see `Session::qemu_intake`);
    /// not on the sensor clock.
    pub(super) waited_for_qemu: Duration,
}

/// The client's framer for the co-processor's host line (replies and
/// scans, ACK/NAK expected): at the start and after an MCU reset.
pub(super) fn host_framer() -> Framer {
    Framer::new(Direction::SensorToHost, Handshake::Expected)
}

/// How long the host line must be quiet before a warm-up scan not back is
/// taken as dropped (it then no longer holds the sensor).
pub(super) const SETTLE: Duration = Duration::from_millis(500);

/// Both ends of the co-processor and everything verify keeps.
/// The sensor runs while the host line's backlog is below this: none. The
/// co-processor sends a scan's `B0` before its pipeline runs, so verify's
/// model of the line matches the co-processor's; any slack lets the next
/// scan reach the co-processor's budget early under QEMU, whose guest clock
/// lags the wall clock by up to a fifth.
const HOST_LINE_SLACK: Duration = Duration::ZERO;

pub(super) struct Session {
    /// First, so that it is dropped first: QEMU is killed before its peers
    /// disconnect (it spins when they do).
    pub(super) dut: Dut,
    pub(super) sensor: Box<dyn Link>,
    pub(super) host: Box<dyn Link>,
    pub(super) console: Option<Box<dyn Link>>,
    pub(super) console_text: Vec<u8>,
    pub(super) emu: Emulator<PlaySource>,
    pub(super) clock: EmuClock,
    /// The sensor's stream runs (the co-processor sent `20 24`).
    pub(super) sensor_streaming: bool,
    /// `B0`s completed on the sensor line, and of those in the selection.
    pub(super) sent: usize,
    pub(super) play_sent: usize,
    pub(super) wanted: usize,
    /// `--max-in-flight` (0 = off).
    pub(super) max_in_flight: usize,
    /// Nothing more is to be sent (the selection is out, or time is up).
    pub(super) finished: bool,
    /// Times the co-processor stopped the sensor's stream while the
    /// selection played (a restart of its bring-up: e.g. its scan time-out).
    pub(super) sensor_restarts: usize,
    /// `--timeout`.
    pub(super) timeout: Duration,
    /// `--power-cycle-sensor-after`: wanted, and what happened.
    pub(super) power_cycle_after: Option<usize>,
    pub(super) power_cycle: Option<Recovery>,
    /// `--reset-mcu-after`: wanted, and what happened.
    pub(super) reset_mcu_after: Option<usize>,
    pub(super) mcu_reset: Option<Recovery>,
    /// Scans outside the selection that the sensor side sent while the
    /// co-processor was rebooting and that did not come back: lost to the
    /// reset, by design, so not counted as lost.
    pub(super) written_off: usize,
    /// Warm-up scans not back that no longer hold the sensor (see
    /// [`SETTLE`]); still counted at the end.
    pub(super) others_given_up: usize,
    /// The co-processor is recovering from an MCU reset: the sensor runs
    /// (the firmware must find it), with scans outside the selection.
    pub(super) recovering: bool,
    /// While recovering: what QEMU's sensor USART has not taken yet. The
    /// sensor waits while it is full, as a real line never queues (QEMU
    /// takes about 10 KB/s, the LMS streams up to 28 KB/s at 500 kBd):
    /// unpaced, seconds of stale scans queued ahead of the firmware's
    /// search and the first scan came back 7.7 s after a reset.
    pub(super) qemu_intake: QemuIntake,
    /// `--host-baud`, to set up again after an MCU reset.
    pub(super) host_baud: Baud,
    /// Hold the sensor until nothing is in flight (before the power cycle).
    pub(super) quiesce: bool,
    /// `--sensor-runs-free`: not held for the host line nor for scans in
    /// flight.
    pub(super) runs_free: bool,
    pub(super) framer: Framer,
    pub(super) assembler: FeatureAssembler,
    /// The last `B0` on the host line, waiting for its features.
    pub(super) pending_b0: Option<Vec<u8>>,
    pub(super) replies: VecDeque<HostReply>,
    pub(super) naks: u32,
    pub(super) last_host_rx: Instant,
    /// The host line's rate, and when what came over it would have left a
    /// real line at that rate: the sensor is held meanwhile (less
    /// [`HOST_LINE_SLACK`]), so that the co-processor's host-line budget
    /// passes every scan on (a sensor faster than the host line makes it
    /// drop scans, by design: docs/PROTOCOL.md).
    pub(super) host_rate: Baud,
    pub(super) host_line_free: Instant,
    pub(super) checker: Checker,
    /// The sensor line's rate model (QEMU ignores line rates).
    pub(super) line_rate: LineRate,
    rate_scratch: Vec<u8>,
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
        let clock = EmuClock::new();
        let wanted = source.len();
        let emu = Emulator::new(source, Settings::default(), clock.now_us());
        // Under QEMU one scan at a time: scans queued in the firmware's
        // sensor queue (QEMU's UART is slow) are processed back to back, and
        // the co-processor's host-line budget drops a scan that finds the
        // line busy for more than a scan period (docs/PROTOCOL.md §2c);
        // `qemu_max_in_flight()` is the most the queue could hold. In a
        // thread one at a time too: the sensor is otherwise paced by what
        // comes back on the host line, and while the co-processor's thread
        // is held off the CPU nothing comes back, the sensor runs free, and
        // a 361-value scan with its features (≈ 28 ms at 500 kBd) does not
        // fit the 26.7 ms scan period: after a stall of a third of a second
        // the budget dropped one of the scans queued meanwhile.
        let max_in_flight = args.max_in_flight.unwrap_or(if args.qemu.is_some() {
            qemu_max_in_flight().min(1)
        } else if args.ports.is_none() {
            1
        } else {
            0
        });
        Session {
            dut: lines.dut,
            sensor: lines.sensor,
            host: lines.host,
            console: lines.console,
            console_text: Vec::new(),
            emu,
            clock,
            sensor_streaming: false,
            sent: 0,
            play_sent: 0,
            wanted,
            max_in_flight,
            finished: false,
            sensor_restarts: 0,
            timeout: Duration::from_secs_f64(args.timeout),
            power_cycle_after: args.power_cycle_sensor_after,
            power_cycle: None,
            reset_mcu_after: args.reset_mcu_after,
            mcu_reset: None,
            written_off: 0,
            others_given_up: 0,
            recovering: false,
            qemu_intake: QemuIntake::new(),
            host_baud: Baud::B9600,
            quiesce: false,
            runs_free: args.sensor_runs_free,
            framer: host_framer(),
            assembler: FeatureAssembler::new(),
            pending_b0: None,
            replies: VecDeque::new(),
            naks: 0,
            last_host_rx: Instant::now(),
            host_rate: Baud::B9600,
            host_line_free: Instant::now(),
            checker: Checker::new(params, args.recompute_tau),
            line_rate: LineRate::new(),
            rate_scratch: Vec::new(),
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
        self.clock.pass();
        self.dut.check()?;
        self.pump_lines(wait).map_err(|e| self.dut.explain(e))
    }

    fn pump_lines(&mut self, wait: Duration) -> Result<()> {
        let mut buf = [0u8; 4096];
        loop {
            let n = self
                .sensor
                .receive(&mut buf, Duration::ZERO)
                .with_context(|| format!("sensor line {}", self.sensor.name()))?;
            if n == 0 {
                break;
            }
            let mut heard = std::mem::take(&mut self.rate_scratch);
            heard.clear();
            let lms_rate = self.emu.baud().bits_per_second();
            let carried = self.line_rate.carry_line(
                Toward::Sensor,
                &mut self.dut,
                lms_rate,
                &buf[..n],
                &mut heard,
            );
            self.emu.receive(self.clock.now_us(), &heard);
            self.rate_scratch = heard;
            carried?;
        }
        self.pump_emulator()?;
        let mut wait = wait;
        loop {
            let n = self
                .host
                .receive(&mut buf, wait)
                .with_context(|| format!("host line {}", self.host.name()))?;
            if n == 0 {
                break;
            }
            self.last_host_rx = Instant::now();
            let start = self.host_line_free.max(self.last_host_rx);
            self.host_line_free = start + crate::serial::line_time(n, self.host_rate);
            self.feed_host(&buf[..n]);
            wait = Duration::ZERO;
        }
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
        let armed = self.emu.source().armed();
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
        let play_out = self.play_sent.saturating_sub(tally.play_back);
        let others_out = (self.sent - self.play_sent).saturating_sub(tally.other_back);
        if play_out == 0
            && others_out > self.others_given_up
            && self.pending_b0.is_none()
            && self.last_host_rx.elapsed() >= SETTLE
        {
            self.others_given_up = others_out;
        }
        let in_flight = play_out + others_out.saturating_sub(self.others_given_up);
        let hold = self.finished
            || self.quiesce
            || (self.sensor_streaming && !armed && !self.recovering)
            || (self.recovering && self.qemu_intake.full())
            || (armed && self.play_sent >= self.wanted)
            || (armed && !self.runs_free && self.paced_hold(in_flight));
        if hold {
            self.clock.hold();
        } else {
            self.clock.release();
        }
    }

    /// The sensor waits for the co-processor: `in_flight` scans are out
    /// and not back, as many as `--max-in-flight` allows, or the host line
    /// is still busy with what came back.
    fn paced_hold(&self, in_flight: usize) -> bool {
        (self.max_in_flight > 0 && in_flight >= self.max_in_flight)
            || self.host_line_free > Instant::now() + HOST_LINE_SLACK
    }

    /// Send what the emulator has due, act on its events.
    fn pump_emulator(&mut self) -> Result<()> {
        self.update_hold();
        let now = self.clock.now_us();
        let mut out = [0u8; 4096];
        loop {
            let lms_rate = self.emu.baud().bits_per_second();
            let n = self.emu.transmit(now, &mut out);
            if n > 0 {
                let mut heard = std::mem::take(&mut self.rate_scratch);
                heard.clear();
                self.line_rate.carry_line(
                    Toward::Firmware,
                    &mut self.dut,
                    lms_rate,
                    &out[..n],
                    &mut heard,
                )?;
                self.sensor
                    .send(&heard)
                    .with_context(|| format!("sensor line {}", self.sensor.name()))?;
                if self.recovering {
                    self.qemu_intake.add(heard.len());
                }
                self.rate_scratch = heard;
            }
            while let Some(event) = self.emu.next_event() {
                match event {
                    EmuEvent::BaudSwitched { to, .. } => {
                        self.log(format!("sensor line to {} Bd", to.bits_per_second()));
                        self.sensor.set_baud(to)?;
                    }
                    EmuEvent::StreamStarted => {
                        self.sensor_streaming = true;
                        let now = self.clock.now_us();
                        for r in [self.power_cycle.as_mut(), self.mcu_reset.as_mut()]
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
                        self.sensor_streaming = false;
                        if self.emu.source().armed() && !self.finished {
                            self.sensor_restarts += 1;
                            eprintln!(
                                "host-bridge verify: the co-processor stopped the sensor's stream \
                                 while the selection played ({} scans sent): it restarted its \
                                 bring-up",
                                self.play_sent
                            );
                        }
                        self.log("sensor stream stopped by the co-processor");
                    }
                    EmuEvent::ScanSent { .. } => {
                        self.sent += 1;
                        let tag = self.emu.source().draws().get(self.sent - 1).map(|d| d.tag);
                        if let Some(Tag::Play(_)) = tag {
                            self.play_sent += 1;
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

    /// Bytes from the co-processor's host line.
    fn feed_host(&mut self, bytes: &[u8]) {
        let mut input = bytes;
        loop {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            match fed.event {
                // (`Long`: not from a full-size framer.)
                Some(Event::Ack | Event::Long { .. }) => {}
                Some(Event::Nak) => self.naks += 1,
                Some(Event::Telegram(t)) => match t.command() {
                    0xB0 => {
                        if self.pending_b0.is_some() {
                            self.checker.without_features();
                        }
                        self.pending_b0 = Some(t.as_bytes().to_vec());
                    }
                    CMD_SUMMARY | CMD_LINES | CMD_CORNERS | CMD_EDGES | CMD_SEGMENTS => {
                        match self.assembler.push(&t) {
                            Ok(Assembled::Complete(summary, features)) => {
                                let b0 = self.pending_b0.take();
                                self.checker.check(
                                    b0.as_deref(),
                                    &summary,
                                    features,
                                    self.emu.source(),
                                );
                            }
                            Ok(_) => {}
                            Err(e) => self.checker.problem(e),
                        }
                    }
                    command => self.replies.push_back(HostReply {
                        command,
                        data: t.data().to_vec(),
                    }),
                },
                None if input.is_empty() => break,
                None => {}
            }
        }
    }
}
