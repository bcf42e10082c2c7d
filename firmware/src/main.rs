//! Firmware for the LMS 2xx feature co-processor on an STM32F405/407 board,
//! and the same ELF under QEMU's `netduinoplus2` (detected at run time,
//! [`rcc`]). Only glue: board bring-up ([`board`]), clocks ([`rcc`]), the
//! fault policy ([`fault`]), the log ([`log`]), the UARTs as `embedded-io`
//! streams ([`serial`]), the time base ([`clock`]), the scans' cycles
//! ([`scan_cycles`]), a control console ([`control`]) and the loop that
//! feeds the core's
//! [`CoProcessor`](lms_core::device::coprocessor::CoProcessor) (or, with the
//! `standin` feature, a plain forwarder, [`standin`]).
//!
//! Exit codes (semihosting, become QEMU's exit status; on the board a fault
//! resets the chip instead, see [`board::fatal`]): see [`EXIT_SUCCESS`] and
//! the constants after it.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod board;
mod clock;
mod control;
mod fault;
mod log;
mod rcc;
mod ring;
mod scan_cycles;
mod serial;
#[cfg(feature = "standin")]
mod standin;

use core::panic::PanicInfo;

use cortex_m_rt::entry;

use lms_core::device::coprocessor::{PollError, READ_CHUNK};

use crate::control::{Command, Report};
use crate::serial::Bd;

include!(concat!(env!("OUT_DIR"), "/build_config.rs"));

/// Exit code: asked to stop (console `q`, or `exit-after-scans`).
pub const EXIT_SUCCESS: i32 = 0;
/// Exit code: panic.
pub const EXIT_PANIC: i32 = 1;
/// Exit code: hard fault.
pub const EXIT_HARD_FAULT: i32 = 2;
/// Exit code: an exception or interrupt without a handler.
pub const EXIT_UNEXPECTED_IRQ: i32 = 3;

/// The application the loop runs: `App`, its constructor, and its sensor
/// bring-up step for the log.
#[cfg(not(feature = "standin"))]
mod app {
    use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
    use lms_core::{Params, ValidParams};

    pub type App = CoProcessor;

    /// The co-processor, every byte zero: the static lands in `.bss` (no
    /// flash image, nothing copied at boot); [`start`] configures it in place.
    pub const INITIAL: App = CoProcessor::unconfigured();

    /// The parameters of this build: the defaults (docs/ALGORITHM.md) or
    /// the preset `LMS_PRESET`, with the passes `LMS_ITERATIONS` if given.
    const RUN: Params = match crate::ITERATIONS {
        Some(n) => crate::PRESET.with_iterations(n),
        None => crate::PRESET,
    };

    /// [`RUN`], validated at compile time (an invalid setting fails the
    /// build).
    const PARAMS: ValidParams = match RUN.validate() {
        Ok(valid) => valid,
        Err(_) => panic!("the build's parameters are invalid (LMS_ITERATIONS?)"),
    };

    /// [`Params::fingerprint`] of this build's parameters, for the
    /// console's report.
    pub const PARAMS_FINGERPRINT: u32 = RUN.fingerprint();

    /// The sensor set-up: the build's variant (`LMS_VARIANT`, default
    /// 180°/0.5°), mm, 500 kBd.
    const SETUP: SensorSetup = SensorSetup {
        variant: crate::VARIANT,
        ..SensorSetup::DEFAULT
    };

    /// Configure it in place with the default parameters and sensor set-up
    /// and switch it on: its host side sends the LMS power-on telegram.
    pub fn start(app: &mut App, now_us: u64) {
        app.configure(PARAMS, SETUP);
        app.start(now_us);
    }

    pub fn step(app: &App) -> Option<Step> {
        Some(app.link().step())
    }

    /// The boot's findings into the counters (`55` → `D5`).
    pub fn note_boot(app: &mut App, boot: &crate::board::Boot) {
        app.note_boot(boot.record());
    }
}

#[cfg(feature = "standin")]
mod app {
    pub type App = crate::standin::Forwarder;

    pub const INITIAL: App = App::new();

    /// No pipeline, no parameters.
    pub const PARAMS_FINGERPRINT: u32 = 0;

    pub fn start(_app: &mut App, _now_us: u64) {}

    pub fn step(_app: &App) -> Option<lms_core::device::coprocessor::Step> {
        None
    }

    pub fn note_boot(_app: &mut App, _boot: &crate::board::Boot) {}
}

/// The application's state (about 20 KiB): a static built at compile time,
/// so it never passes through the stack.
static APP: static_cell::ConstStaticCell<app::App> =
    static_cell::ConstStaticCell::new(app::INITIAL);

defmt::timestamp!("{=u64:us}", clock::now_us());

#[entry]
fn main() -> ! {
    let Some(mut board) = board::init() else {
        defmt::panic!("board::init called twice");
    };
    let app = init_app();
    app::note_boot(app, &board.boot);
    // From here on the stack report covers the loop only.
    let boot_stack = board::repaint_stack();
    log_boot(&board.boot);
    defmt::info!(
        "lms-firmware {=str} ready: host=USART1 (rx queue {=usize} B, tx queue {=usize} B), sensor=USART2 (rx queue {=usize} B), control=USART3; start-up stack peak {=u32} B",
        env!("CARGO_PKG_VERSION"),
        board.host.rx_capacity(),
        board.host.tx_capacity(),
        board.sensor.rx_capacity(),
        boot_stack.peak
    );
    let mut watch = Watch::default();
    let mut pace = Pace::default();
    loop {
        fault::feed();
        pace.polled_at = clock::ticks();
        poll(app, &mut board, &mut watch);
        watch.sensor_queue(app, &board);
        watch.bring_up(app);
        serve_console(app, &mut board, &watch);
        pace.sleep_until_due(&board);
    }
}

/// The boot's findings into the log (clocks, reset cause, last fault).
fn log_boot(boot: &board::Boot) {
    let c = &boot.clocks;
    defmt::info!(
        "clocks: {} SYSCLK {=u32} Hz, APB1 {=u32} Hz, APB2 {=u32} Hz; reset cause {=str} ({=u32:#04x}); brown-out level: {}",
        c.source,
        c.sysclk_hz,
        c.pclk1_hz,
        c.pclk2_hz,
        boot.reset.name(),
        boot.reset.0,
        boot.bor
    );
    if let Some(f) = boot.last_fault {
        defmt::warn!(
            "last boot ended in {}: pc={=u32:#010x} lr={=u32:#010x} detail={=u32:#x}",
            f.cause,
            f.pc,
            f.lr,
            f.detail
        );
    }
}

/// What the loop remembers between rounds: scans processed, the sensor
/// queue's losses and the bring-up step last logged.
#[derive(Default)]
struct Watch {
    scans: u32,
    sensor_losses_seen: u32,
    step: Option<lms_core::device::coprocessor::Step>,
}

/// One poll of the application; switches a UART when it asks.
///
/// `scan_begin` opens every poll, `scan_end` closes only a poll that
/// processed a scan: an instruction counter that measures from the last
/// begin to each end sees exactly the polls that carried scans.
fn poll(app: &mut app::App, board: &mut board::Board, watch: &mut Watch) {
    board::scan_begin();
    let began = scan_cycles::ScanCycles::now();
    let outcome = match app.poll(&mut board.sensor, &mut board.host, clock::now_us()) {
        Ok(outcome) => outcome,
        Err(PollError::Sensor(never) | PollError::Host(never)) => match never {},
    };
    if outcome.scans > 0 {
        board::scan_end();
        board.scan_cycles.scan_poll(began);
        watch.scans = watch.scans.wrapping_add(outcome.scans);
    }
    if let Some(baud) = outcome.sensor_baud {
        defmt::info!("sensor line to {=u32} Bd", baud.bits_per_second());
        board.sensor.set_baud(Bd(baud.bits_per_second()));
    }
    if let Some(baud) = outcome.host_baud {
        defmt::info!("host line to {=u32} Bd", baud.bits_per_second());
        board.host.set_baud(Bd(baud.bits_per_second()));
    }
}

impl Watch {
    /// Count (once) bytes the sensor receive queue lost.
    fn sensor_queue(&mut self, app: &mut app::App, board: &board::Board) {
        let losses = board.sensor.rx_counts().lost();
        if losses != self.sensor_losses_seen {
            let new = losses.wrapping_sub(self.sensor_losses_seen);
            self.sensor_losses_seen = losses;
            defmt::warn!("sensor receive queue lost bytes ({=u32} so far)", losses);
            app.note_sensor_lost(new);
        }
    }

    /// Log each new sensor bring-up step.
    fn bring_up(&mut self, app: &app::App) {
        let now_step = app::step(app);
        if now_step != self.step {
            self.step = now_step;
            if let Some(s) = self.step {
                defmt::info!("sensor bring-up: {}", s);
            }
        }
    }
}

/// Answer a console command with the counters (and stop on `q`); with
/// `exit-after-scans`, report and stop after [`EXIT_AFTER_SCANS`] scans.
fn serve_console(app: &app::App, board: &mut board::Board, watch: &Watch) {
    let report = |board: &board::Board| {
        Report::collect(
            clock::now_us(),
            watch.scans,
            app.counters(),
            board.host.rx_counts(),
            board.sensor.rx_counts(),
            &board.boot,
            board.scan_cycles,
        )
    };
    if let Some(command) = serial::try_read(&mut board.control).and_then(Command::from_byte) {
        let r = report(board);
        log_report(&r);
        r.write_line(&mut board.control);
        if command == Command::Quit {
            defmt::info!("exit on console command");
            board::exit(EXIT_SUCCESS, &mut board.control);
        }
    }
    if cfg!(feature = "exit-after-scans") && watch.scans >= EXIT_AFTER_SCANS {
        let r = report(board);
        log_report(&r);
        r.write_line(&mut board.control);
        defmt::info!("exit after {=u32} scans", watch.scans);
        board::exit(EXIT_SUCCESS, &mut board.control);
    }
}

/// The report's headline into the log (the whole line goes to the console;
/// a `defmt::Format` of every field cost ~1 KiB of flash).
fn log_report(r: &Report) {
    defmt::info!(
        "Report {{ now_us: {=u64}, scans: {=u32}, scans_in: {=u32}, dropped: {=u32}, stack_peak: {=u32} }}",
        r.now_us,
        r.scans,
        r.counters.scans_in,
        r.counters.scans_dropped,
        r.stack.peak
    );
}

/// When the loop runs the application: not on every interrupt (a byte
/// from the sensor, a byte sent to the host), but once a read chunk of
/// sensor bytes waits, a host or console byte waits, a SysTick has passed
/// with sensor bytes waiting (a telegram's last bytes wait at most 1 ms),
/// or [`IDLE_POLL_MS`] have passed (the time-outs, the host line's
/// output, the watchdog). The sensor queue holds 20 ms of a 500 kBd
/// stream, the host queue 16 ms.
#[derive(Default)]
struct Pace {
    /// [`clock::ticks`] at the last poll.
    polled_at: u32,
}

/// Milliseconds between polls while no sensor byte waits: the
/// co-processor's time-outs are 50 ms and longer, and the host queue's
/// 16 ms of 500 kBd output is topped up twice before it can run dry.
const IDLE_POLL_MS: u32 = 8;

impl Pace {
    fn due(&self, board: &board::Board) -> bool {
        let sensor = board.sensor.rx_pending();
        let since = clock::ticks().wrapping_sub(self.polled_at);
        sensor >= READ_CHUNK
            || (sensor > 0 && since > 0)
            || since >= IDLE_POLL_MS
            || board.host.rx_pending() > 0
            || board.control.rx_pending() > 0
    }

    /// Sleep, interrupt after interrupt, until the application is due.
    /// Interrupts are masked while deciding, so one that arrives in between
    /// still wakes WFI.
    fn sleep_until_due(&self, board: &board::Board) {
        while critical_section::with(|_| {
            let due = self.due(board);
            if !due {
                cortex_m::asm::wfi();
            }
            !due
        }) {}
    }
}

/// Take the application out of its static and switch it on.
#[inline(never)]
fn init_app() -> &'static mut app::App {
    let app = APP.take();
    app::start(app, clock::now_us());
    app
}

/// Both panic handlers: interrupts off, the fault record (the caller's
/// return address into the panic machinery as PC, see
/// [`fault::link_register`]; `detail` the source line, if known).
#[inline(always)]
fn record_panic(detail: u32) {
    let lr = fault::link_register();
    cortex_m::interrupt::disable();
    fault::record(fault::FaultRecord {
        cause: fault::Cause::Panic,
        pc: lr,
        lr: 0,
        detail,
    });
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    record_panic(info.location().map_or(0, |l| l.line()));
    let message = info.message().as_str().unwrap_or("(formatted message)");
    match info.location() {
        Some(l) => defmt::error!(
            "panic at {=str}:{=u32}: {=str}",
            l.file(),
            l.line(),
            message
        ),
        None => defmt::error!("panic: {=str}", message),
    }
    board::fatal(EXIT_PANIC)
}

#[defmt::panic_handler]
fn defmt_panic() -> ! {
    record_panic(0);
    board::fatal(EXIT_PANIC)
}
