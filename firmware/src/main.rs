//! Firmware for the LMS 2xx feature co-processor on an STM32F405, as QEMU's
//! `netduinoplus2` models it. Only glue: board bring-up ([`board`]), the
//! UARTs as `embedded-io` streams ([`serial`]), the time base ([`clock`]),
//! a control console ([`control`]) and the loop that feeds the core's
//! [`CoProcessor`](lms_core::device::coprocessor::CoProcessor) (or, with the
//! `standin` feature, a plain forwarder, [`standin`]).
//!
//! Exit codes (semihosting, become QEMU's exit status): see [`EXIT_SUCCESS`]
//! and the constants after it.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod board;
mod clock;
mod control;
mod serial;
#[cfg(feature = "standin")]
mod standin;

use core::panic::PanicInfo;

use cortex_m_rt::entry;
use defmt_semihosting as _; // the global defmt logger

use lms_core::device::coprocessor::PollError;

use crate::control::{Command, Report};

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

    /// The co-processor with the default parameters and sensor set-up
    /// (180°/0.5°, mm, 500 kBd), built at compile time into `.bss`/`.data`.
    pub const INITIAL: App = CoProcessor::new(PARAMS, SensorSetup::DEFAULT);

    /// The defaults of ALGORITHM.md v2 (split before reject, unshared
    /// corner points; the feature `split-before-reject` is now the
    /// default) with the passes of this build, validated at compile time
    /// (an invalid setting fails the build).
    const PARAMS: ValidParams = {
        let mut p = Params::DEFAULT;
        p.iterations = crate::ITERATIONS;
        match p.validate() {
            Ok(valid) => valid,
            Err(_) => panic!("the build's parameters are invalid (LMS_ITERATIONS?)"),
        }
    };

    /// Switch it on: its host side sends the LMS power-on telegram.
    pub fn start(app: &mut App, now_us: u64) {
        app.start(now_us);
    }

    pub fn step(app: &App) -> Option<Step> {
        Some(app.link().step())
    }
}

#[cfg(feature = "standin")]
mod app {
    pub type App = crate::standin::Forwarder;

    pub const INITIAL: App = App::new();

    pub fn start(_app: &mut App, _now_us: u64) {}

    pub fn step(_app: &App) -> Option<lms_core::device::coprocessor::Step> {
        None
    }
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
    // From here on the stack report covers the loop only.
    let boot_stack = board::repaint_stack();
    defmt::info!(
        "lms-firmware {=str} ready: host=USART1 (rx queue {=usize} B), sensor=USART2 (rx queue {=usize} B), control=USART3; start-up stack peak {=u32} B",
        env!("CARGO_PKG_VERSION"),
        board.host.rx_capacity(),
        board.sensor.rx_capacity(),
        boot_stack.peak
    );
    let mut watch = Watch::default();
    loop {
        poll(app, &mut board, &mut watch);
        watch.sensor_queue(app, &board);
        watch.bring_up(app);
        serve_console(app, &mut board, &watch);
        sleep_until_input(&board);
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
    let outcome = match app.poll(&mut board.sensor, &mut board.host, clock::now_us()) {
        Ok(outcome) => outcome,
        Err(PollError::Sensor(never) | PollError::Host(never)) => match never {},
    };
    if outcome.scans > 0 {
        board::scan_end();
        watch.scans = watch.scans.wrapping_add(outcome.scans);
    }
    if let Some(baud) = outcome.sensor_baud {
        defmt::info!("sensor line to {=u32} Bd", baud.bits_per_second());
        board.sensor.set_baud(baud.bits_per_second());
    }
    if let Some(baud) = outcome.host_baud {
        defmt::info!("host line to {=u32} Bd", baud.bits_per_second());
        board.host.set_baud(baud.bits_per_second());
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
        )
    };
    if let Some(command) = board.control.try_read().and_then(Command::from_byte) {
        let r = report(board);
        defmt::info!("{}", r);
        r.write_line(&mut board.control);
        if command == Command::Quit {
            defmt::info!("exit on console command");
            semihosting::process::exit(EXIT_SUCCESS);
        }
    }
    if cfg!(feature = "exit-after-scans") && watch.scans >= EXIT_AFTER_SCANS {
        let r = report(board);
        defmt::info!("{}", r);
        r.write_line(&mut board.control);
        defmt::info!("exit after {=u32} scans", watch.scans);
        semihosting::process::exit(EXIT_SUCCESS);
    }
}

/// Sleep until the next interrupt (at the latest the next SysTick, 1 ms)
/// unless bytes are already waiting. Interrupts are masked while deciding,
/// so one that arrives in between still wakes WFI.
fn sleep_until_input(board: &board::Board) {
    critical_section::with(|_| {
        if board.host.rx_pending() == 0 && board.sensor.rx_pending() == 0 {
            cortex_m::asm::wfi();
        }
    });
}

/// Take the application out of its static and switch it on.
#[inline(never)]
fn init_app() -> &'static mut app::App {
    let app = APP.take();
    app::start(app, clock::now_us());
    app
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
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
    semihosting::process::exit(EXIT_PANIC)
}

#[defmt::panic_handler]
fn defmt_panic() -> ! {
    semihosting::process::exit(EXIT_PANIC)
}
