//! The sensor's side of a run: the simulated LMS on the co-processor's
//! sensor line, its clock, the line's rate model and what it has sent.

use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lms_core::device::emulator::{Emulator, Settings};
use lms_core::telegram::Direction;

use super::dut::Dut;
use super::line_rate::{LineRate, Toward};
use super::source::PlaySource;
use super::VerifyArgs;
use crate::qemu::QemuIntake;
use crate::serial::Link;

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

    pub(super) fn hold(&mut self) {
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

/// The simulated LMS on the sensor line and what it has sent.
pub(super) struct SensorSide {
    pub(super) link: Box<dyn Link>,
    pub(super) emu: Emulator<PlaySource>,
    pub(super) clock: EmuClock,
    /// The sensor's stream runs (the co-processor sent `20 24`).
    pub(super) streaming: bool,
    /// `B0`s completed on the sensor line, and of those in the selection.
    pub(super) sent: usize,
    pub(super) play_sent: usize,
    /// Scans in the selection.
    pub(super) wanted: usize,
    /// `--max-in-flight` (0 = off).
    pub(super) max_in_flight: usize,
    /// Nothing more is to be sent (the selection is out, or time is up).
    pub(super) finished: bool,
    /// Times the co-processor stopped the sensor's stream while the
    /// selection played (a restart of its bring-up: e.g. its scan time-out).
    pub(super) restarts: usize,
    /// Hold the sensor until nothing is in flight (before the power cycle).
    pub(super) quiesce: bool,
    /// `--sensor-runs-free`: not held for the host line nor for scans in
    /// flight.
    pub(super) runs_free: bool,
    /// Warm-up scans not back that no longer hold the sensor (see
    /// [`super::session::SETTLE`]); still counted at the end.
    pub(super) others_given_up: usize,
    /// The sensor line's rate model (QEMU ignores line rates).
    pub(super) line_rate: LineRate,
    rate_scratch: Vec<u8>,
}

impl SensorSide {
    /// The LMS on `link`, playing `source`.
    pub(super) fn new(link: Box<dyn Link>, source: PlaySource, args: &VerifyArgs) -> Self {
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
        SensorSide {
            link,
            emu,
            clock,
            streaming: false,
            sent: 0,
            play_sent: 0,
            wanted,
            max_in_flight,
            finished: false,
            restarts: 0,
            quiesce: false,
            runs_free: args.sensor_runs_free,
            others_given_up: 0,
            line_rate: LineRate::new(),
            rate_scratch: Vec::new(),
        }
    }

    /// The co-processor's bytes on the sensor line, through the line's
    /// rate model, to the emulator; until the line has nothing more.
    pub(super) fn receive(&mut self, dut: &mut Dut) -> Result<()> {
        let mut buf = [0u8; 4096];
        loop {
            let n = self
                .link
                .receive(&mut buf, Duration::ZERO)
                .with_context(|| format!("sensor line {}", self.link.name()))?;
            if n == 0 {
                return Ok(());
            }
            let mut heard = std::mem::take(&mut self.rate_scratch);
            heard.clear();
            let lms_rate = self.emu.baud().bits_per_second();
            let carried =
                self.line_rate
                    .carry_line(Toward::Sensor, dut, lms_rate, &buf[..n], &mut heard);
            self.emu.receive(self.clock.now_us(), &heard);
            self.rate_scratch = heard;
            carried?;
        }
    }

    /// Send what the emulator has due at `now` (µs, its clock), through the
    /// line's rate model; `intake` counts what QEMU's USART is yet to take.
    /// Returns the bytes the emulator gave (0: nothing more is due).
    pub(super) fn transmit(
        &mut self,
        now: u64,
        dut: &mut Dut,
        intake: Option<&mut QemuIntake>,
    ) -> Result<usize> {
        let mut out = [0u8; 4096];
        let lms_rate = self.emu.baud().bits_per_second();
        let n = self.emu.transmit(now, &mut out);
        if n == 0 {
            return Ok(0);
        }
        let mut heard = std::mem::take(&mut self.rate_scratch);
        heard.clear();
        self.line_rate
            .carry_line(Toward::Firmware, dut, lms_rate, &out[..n], &mut heard)?;
        self.link
            .send(&heard)
            .with_context(|| format!("sensor line {}", self.link.name()))?;
        if let Some(intake) = intake {
            intake.add(heard.len());
        }
        self.rate_scratch = heard;
        Ok(n)
    }
}
