#![allow(unsafe_code)]
//! Board bring-up for an STM32F405/407 board and QEMU's `netduinoplus2`
//! (one ELF, QEMU detected at run time by [`crate::rcc`]): clocks, pins,
//! the USART interrupt handlers, fault handlers and the stack report.
//!
//! `unsafe` lives here and in [`crate::rcc`], [`crate::fault`] and
//! [`crate::log`]; each block says why it holds.
//!
//! | port | USART | pins (silicon) | IRQ | QEMU | role |
//! |---|---|---|---|---|---|
//! | host | USART1 (APB2 84 MHz) | PB6 TX / PB7 RX, AF7 | 37 | 1st `-serial` | the robot's computer (LMS client) |
//! | sensor | USART2 (APB1 42 MHz) | PA2 TX / PA3 RX, AF7 | 38 | 2nd `-serial` | the LMS 2xx |
//! | control | USART3 (APB1 42 MHz) | PB10 TX / PB11 RX, AF7 | 39 | 3rd `-serial` | debug console: stats, exit |
//!
//! USART1 is on PB6/PB7, not PA9/PA10: on the STM32F4-Discovery PA9 is
//! the USB VBUS sense with a 4.7 µF capacitor, which a 500 kBd TX cannot
//! drive. QEMU does not model the pins (nor the clocks, the watchdog or the
//! option bytes); it ignores those writes.

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use crate::ring::{Consumer, Producer, Ring};
use cortex_m_rt::{exception, ExceptionFrame};
use critical_section::Mutex;
use static_cell::ConstStaticCell;
use stm32f4::stm32f405::{self as pac, interrupt, Interrupt};

use crate::clock;
use crate::fault::{self, Bor, Cause, FaultRecord, ResetCause};
use crate::rcc::{self, Clocks};
use crate::serial::{self, Bd, Line, RxStats, Serial};

/// Line speed of the host side at power-on (Bd): the co-processor looks like
/// an LMS 2xx to its client, which starts at 9600 and switches on request
/// ([`Serial::set_baud`]).
pub const HOST_BAUD: Bd = Bd(9_600);
/// Line speed of the sensor side at power-on (Bd): the LMS 2xx starts at 9600.
pub const SENSOR_BAUD: Bd = Bd(9_600);
/// Line speed of the control console (Bd).
pub const CONTROL_BAUD: Bd = Bd(115_200);

/// Slots of the host receive queue (holds one less byte): requests are
/// short (the longest, `77`, is 42 bytes) and a client waits for each
/// reply; a longer burst is held back by the receive backpressure
/// ([`crate::serial`]), not lost.
pub const HOST_RX_SLOTS: usize = 64;
/// Slots of the host transmit queue (holds one less byte, 831): the
/// co-processor never writes more than the queue has room for
/// ([`lms_core::device::coprocessor::WriteRoom`]), so the loop never waits
/// on the host line. It must hold an `ACK` and the largest telegram whole
/// ([`HOST_TX_MIN_ROOM`], 819 B: a 401-beam `B0`, a `30 01` reply; the
/// largest feature telegram is 749 B). More does not buy throughput: the
/// `B0` goes in before the pipeline runs and the features follow as room
/// frees, so a scan's `B0` + features of `T` bytes are all queued once the
/// line has carried `T − 831` of them; by the next scan (26.7 ms, 1333 B
/// at 500 kBd) that holds for every `T` up to 2.1 KB, more than the line
/// carries in a period (the host-line budget drops scans beyond that).
///
/// [`HOST_TX_MIN_ROOM`]: lms_core::device::coprocessor::HOST_TX_MIN_ROOM
pub const HOST_TX_SLOTS: usize = 832;
// The queue holds `HOST_TX_SLOTS - 1` bytes.
const _: () = assert!(HOST_TX_SLOTS > lms_core::device::coprocessor::HOST_TX_MIN_ROOM);
/// Slots of the sensor receive queue (holds one less byte, 1023): what a
/// 500 kBd stream brings while the loop does not read it. The host write
/// never waits, so the longest such time is one pipeline run: at the
/// defaults at most 2.3 M cycles by the upper-bound cycle estimate
/// (docs/DESIGN.md, Firmware), 13.5 ms at 168 MHz. Less than a scan period
/// (26.7 ms at 0.5°), so at most one `B0` and a little arrive meanwhile:
/// 732 B at 0.5°, 744–750 B at 1° (two 372-byte `B0`s 13.3 ms apart), 813 B for
/// 401 beams (53.3 ms apart); 1023 leaves 210 B (4.2 ms) to spare.
/// A full queue holds the line (backpressure, [`crate::serial`]): under
/// QEMU nothing is lost; on a board the overrun is counted (`ORE`, the
/// `D5` counters' lost sensor bytes). A console report (~0.7 KB at
/// 115 200 Bd through its 64-slot queue, ~61 ms) still waits: asked for
/// during a 500 kBd stream on a board it can overrun this queue (counted).
pub const SENSOR_RX_SLOTS: usize = 1024;
/// Slots of the sensor transmit queue: one bring-up request (≤ 42 bytes).
pub const SENSOR_TX_SLOTS: usize = 64;
/// Slots of the console receive queue (one-byte commands).
pub const CONTROL_RX_SLOTS: usize = 16;
/// Slots of the console transmit queue (the report line is ~700 bytes; a
/// report waits, asleep, for the rest: ~60 ms at 115 200 Bd).
pub const CONTROL_TX_SLOTS: usize = 64;

/// The host port (USART1).
pub type HostPort = Serial<pac::USART1>;
/// The sensor port (USART2).
pub type SensorPort = Serial<pac::USART2>;
/// The control console (USART3).
pub type ControlPort = Serial<pac::USART3>;

/// One USART's queues and counters, and the interrupt's queue ends parked
/// until the interrupt takes them on first entry.
struct PortStatics<const RX: usize, const TX: usize> {
    rx: ConstStaticCell<Ring<RX>>,
    tx: ConstStaticCell<Ring<TX>>,
    parked: Mutex<RefCell<Ends>>,
    stats: RxStats,
}

impl<const RX: usize, const TX: usize> PortStatics<RX, TX> {
    const fn new() -> Self {
        PortStatics {
            rx: ConstStaticCell::new(Ring::new()),
            tx: ConstStaticCell::new(Ring::new()),
            parked: Mutex::new(RefCell::new(None)),
            stats: RxStats::new(),
        }
    }

    /// Split the queues: the interrupt's ends parked, the loop's returned.
    fn split(&'static self) -> (Consumer<'static>, Producer<'static>) {
        let (rx_in, rx_out) = self.rx.take().split();
        let (tx_in, tx_out) = self.tx.take().split();
        critical_section::with(|cs| {
            if let Ok(mut slot) = self.parked.borrow(cs).try_borrow_mut() {
                *slot = Some((rx_in, tx_out));
            }
        });
        (rx_out, tx_in)
    }

    /// The interrupt's ends, once (`None` before `split`).
    fn unpark(&self) -> Ends {
        critical_section::with(|cs| self.parked.borrow(cs).try_borrow_mut().ok()?.take())
    }
}

static HOST: PortStatics<HOST_RX_SLOTS, HOST_TX_SLOTS> = PortStatics::new();
static SENSOR: PortStatics<SENSOR_RX_SLOTS, SENSOR_TX_SLOTS> = PortStatics::new();
static CONTROL: PortStatics<CONTROL_RX_SLOTS, CONTROL_TX_SLOTS> = PortStatics::new();

/// True under QEMU (set once by [`init`]).
static EMULATOR: AtomicBool = AtomicBool::new(false);

/// True under QEMU: semihosting (log, exit, clock) may be used.
pub fn on_emulator() -> bool {
    EMULATOR.load(Ordering::Relaxed)
}

/// What the boot found and did: reported on the console and in `D5`.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct Boot {
    /// The clocks in force.
    pub clocks: Clocks,
    /// `RCC_CSR`'s reset flags (0 under QEMU).
    pub reset: ResetCause,
    /// The fault record the previous boot left, if any.
    pub last_fault: Option<FaultRecord>,
    /// The brown-out level programming.
    pub bor: Bor,
}

impl Boot {
    /// The reset flags and the previous boot's fault as the co-processor
    /// reports them (`D5`, the console): 0 where there is no fault record.
    pub fn record(&self) -> lms_core::telegram::features::BootRecord {
        let f = self.last_fault;
        lms_core::telegram::features::BootRecord {
            reset_flags: self.reset.0,
            fault_cause: f.map_or(0, |f| f.cause as u32),
            fault_pc: f.map_or(0, |f| f.pc),
            fault_lr: f.map_or(0, |f| f.lr),
        }
    }
}

/// What [`init`] hands to the main loop.
pub struct Board {
    /// USART1.
    pub host: HostPort,
    /// USART2.
    pub sensor: SensorPort,
    /// USART3.
    pub control: ControlPort,
    /// What the boot found.
    pub boot: Boot,
    /// The scans' cycles, by the core's cycle counter.
    pub scan_cycles: crate::scan_cycles::ScanCycles,
}

/// Bring the board up: clocks (or QEMU detected), the log, the fault
/// record and reset cause, brown-out level, pins, the three USARTs with
/// their queues and interrupts, SysTick, the watchdog. Call once; returns
/// `None` if called again.
pub fn init() -> Option<Board> {
    let cp = cortex_m::Peripherals::take()?;
    let dp = pac::Peripherals::take()?;

    let clocks = rcc::init(&dp.RCC, &dp.FLASH, &dp.PWR);
    EMULATOR.store(clocks.is_emulator(), Ordering::Relaxed);
    if clocks.is_emulator() {
        crate::log::use_semihosting();
    } else {
        crate::log::init_rtt();
    }
    let boot = Boot {
        clocks,
        reset: fault::reset_cause(&dp.RCC),
        last_fault: fault::take_last_fault(),
        bor: fault::program_bor_level(&dp.FLASH),
    };
    pins(&dp);

    // Receivers on as early as possible: QEMU drops what arrives before.
    let host = HOST.split();
    let sensor = SENSOR.split();
    let control = CONTROL.split();
    serial::configure(&dp.USART1, clocks.pclk2_hz, HOST_BAUD);
    serial::configure(&dp.USART2, clocks.pclk1_hz, SENSOR_BAUD);
    serial::configure(&dp.USART3, clocks.pclk1_hz, CONTROL_BAUD);

    clock::start(cp.SYST, clocks.sysclk_hz);
    let scan_cycles = crate::scan_cycles::ScanCycles::start(cp.DCB, cp.DWT);
    fault::start_watchdog(&dp.IWDG);

    // SAFETY: unmasking can break a critical section only if one is in
    // progress; none is (we are in thread mode outside `critical_section::with`),
    // and each handler only touches its own queue ends and counters.
    unsafe {
        cortex_m::peripheral::NVIC::unmask(Interrupt::USART1);
        cortex_m::peripheral::NVIC::unmask(Interrupt::USART2);
        cortex_m::peripheral::NVIC::unmask(Interrupt::USART3);
    }

    Some(Board {
        host: Serial::new(
            dp.USART1,
            host,
            &HOST.stats,
            Line {
                irq: Interrupt::USART1,
                pclk_hz: clocks.pclk2_hz,
                baud: HOST_BAUD,
            },
        ),
        sensor: Serial::new(
            dp.USART2,
            sensor,
            &SENSOR.stats,
            Line {
                irq: Interrupt::USART2,
                pclk_hz: clocks.pclk1_hz,
                baud: SENSOR_BAUD,
            },
        ),
        control: Serial::new(
            dp.USART3,
            control,
            &CONTROL.stats,
            Line {
                irq: Interrupt::USART3,
                pclk_hz: clocks.pclk1_hz,
                baud: CONTROL_BAUD,
            },
        ),
        boot,
        scan_cycles,
    })
}

/// Peripheral clocks and pin functions (AF7 for all three USARTs).
fn pins(dp: &pac::Peripherals) {
    dp.RCC
        .ahb1enr()
        .modify(|_, w| w.gpioaen().set_bit().gpioben().set_bit());
    dp.RCC.apb2enr().modify(|_, w| w.usart1en().set_bit());
    dp.RCC
        .apb1enr()
        .modify(|_, w| w.usart2en().set_bit().usart3en().set_bit());
    dp.GPIOA.afrl().modify(|_, w| w.afrl2().af7().afrl3().af7());
    dp.GPIOA
        .moder()
        .modify(|_, w| w.moder2().alternate().moder3().alternate());
    dp.GPIOB.afrl().modify(|_, w| w.afrl6().af7().afrl7().af7());
    dp.GPIOB
        .afrh()
        .modify(|_, w| w.afrh10().af7().afrh11().af7());
    dp.GPIOB.moder().modify(|_, w| {
        w.moder6().alternate();
        w.moder7().alternate();
        w.moder10().alternate();
        w.moder11().alternate()
    });
    // Pull-ups on the receive pins: an unconnected line idles high
    // instead of floating into framing errors.
    dp.GPIOA.pupdr().modify(|_, w| w.pupdr3().pull_up());
    dp.GPIOB
        .pupdr()
        .modify(|_, w| w.pupdr7().pull_up().pupdr11().pull_up());
}

/// The interrupt's queue ends, taken on its first entry.
type Ends = Option<(Producer<'static>, Consumer<'static>)>;

fn serve<const RX: usize, const TX: usize>(
    usart: &pac::usart1::RegisterBlock,
    ends: &mut Ends,
    port: &PortStatics<RX, TX>,
    irq: Interrupt,
) {
    if ends.is_none() {
        *ends = port.unpark();
    }
    let (rx, tx) = match ends.as_mut() {
        Some((rx, tx)) => (Some(rx), Some(tx)),
        None => (None, None),
    };
    // A ring of RX slots holds RX − 1 bytes.
    serial::on_interrupt(usart, rx, RX - 1, tx, &port.stats, irq);
}

#[interrupt]
fn USART1() {
    static mut ENDS: Ends = None;
    // SAFETY: the handler reads SR/DR and writes DR and CR1.TXEIE; the main
    // loop's `Serial` writes BRR and sets TXEIE inside a critical section,
    // and never reads DR of an interrupt-driven port.
    let usart = unsafe { &*pac::USART1::ptr() };
    serve(usart, ENDS, &HOST, Interrupt::USART1);
}

#[interrupt]
fn USART2() {
    static mut ENDS: Ends = None;
    // SAFETY: as for USART1 (USART2 has the same register block).
    let usart = unsafe { &*pac::USART2::ptr() };
    serve(usart, ENDS, &SENSOR, Interrupt::USART2);
}

#[interrupt]
fn USART3() {
    static mut ENDS: Ends = None;
    // SAFETY: as for USART1.
    let usart = unsafe { &*pac::USART3::ptr() };
    serve(usart, ENDS, &CONTROL, Interrupt::USART3);
}

/// Stop for good with `code` after a fault (the record is already written):
/// under QEMU exit through semihosting with `code` (the tests read it), on
/// the board a system reset (the next boot reports the record).
pub fn fatal(code: i32) -> ! {
    if on_emulator() {
        semihosting::process::exit(code)
    }
    cortex_m::peripheral::SCB::sys_reset()
}

/// Stop on request (console `q`, `exit-after-scans`): under QEMU exit with
/// `code`; on the board a software reset after the console has drained.
pub fn exit(code: i32, control: &mut ControlPort) -> ! {
    control.drain();
    fatal(code)
}

/// Stack use measured against the paint the reset handler applied
/// (cortex-m-rt `paint-stack`: every word between `_stack_end` and
/// `_stack_start` set to `0xCCCC_CCCC` before `main`).
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct StackUsage {
    /// Bytes from the top of RAM down to the lowest word ever written.
    pub peak: u32,
    /// Bytes available to the stack (RAM not taken by statics).
    pub size: u32,
}

/// The painted stack region: `(bottom, top)` addresses.
fn stack_region() -> (usize, usize) {
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    // Only the addresses of the linker symbols are taken, never their values.
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let bottom = core::ptr::addr_of!(_stack_end) as usize;
    (bottom, top)
}

/// Scan the painted stack region from its bottom for the first overwritten
/// word: an upper bound of the deepest the stack has been since it was last
/// painted (a frame may have written the paint value itself; unlikely, and
/// then reported low by at most those words).
pub fn stack_usage() -> StackUsage {
    let (bottom, top) = stack_region();
    let mut p = bottom;
    while p < top {
        // SAFETY: `bottom..top` is RAM reserved for the stack by link.x,
        // 4-byte aligned (`_stack_end` is aligned to 4, `_stack_start` to 8);
        // a volatile read of a word there has no side effect.
        let word = unsafe { core::ptr::read_volatile(p as *const u32) };
        if word != cortex_m_rt::STACK_PAINT_VALUE {
            break;
        }
        p += 4;
    }
    StackUsage {
        peak: (top - p) as u32,
        size: (top - bottom) as u32,
    }
}

/// Paint the unused stack again, so that [`stack_usage`] measures from now
/// on (e.g. the main loop without the start-up). Returns the use so far.
pub fn repaint_stack() -> StackUsage {
    /// Room left below the stack pointer for this function's own calls.
    const MARGIN: usize = 256;
    let before = stack_usage();
    let (bottom, _) = stack_region();
    critical_section::with(|_| {
        let sp = cortex_m::register::msp::read() as usize;
        let mut p = bottom;
        while p + MARGIN < sp {
            // SAFETY: `p` is below the stack pointer by more than MARGIN and
            // above the statics: memory no frame uses. Interrupts are masked,
            // so no exception frame is pushed there meanwhile, and the loop
            // makes no calls.
            unsafe { core::ptr::write_volatile(p as *mut u32, cortex_m_rt::STACK_PAINT_VALUE) };
            p += 4;
        }
    });
    before
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    // SAFETY: a read of SCB_CFSR (what faulted), no side effect.
    let cfsr = unsafe { (*cortex_m::peripheral::SCB::PTR).cfsr.read() };
    fault::record(FaultRecord {
        cause: Cause::HardFault,
        pc: frame.pc(),
        lr: frame.lr(),
        detail: cfsr,
    });
    defmt::error!(
        "hard fault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x} cfsr={=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr(),
        cfsr
    );
    fatal(crate::EXIT_HARD_FAULT)
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    fault::record(FaultRecord {
        cause: Cause::UnexpectedIrq,
        pc: 0,
        lr: 0,
        detail: irqn as u32,
    });
    defmt::error!("unexpected exception or interrupt {=i16}", irqn);
    fatal(crate::EXIT_UNEXPECTED_IRQ)
}

/// Which side of a scan marker the program last passed (1 = inside a scan).
/// The markers write different values, through `black_box`, so that the
/// compiler can neither drop their calls nor merge the two functions.
static IN_SCAN: AtomicU32 = AtomicU32::new(0);

/// Marker called just before a scan is processed. Never inlined and kept
/// under its own symbol, so that an emulator plugin can count the
/// instructions executed between this and [`scan_end`].
#[inline(never)]
#[no_mangle]
pub extern "C" fn scan_begin() {
    core::hint::black_box(&IN_SCAN).store(1, Ordering::SeqCst);
}

/// Marker called just after a scan has been processed (see [`scan_begin`]).
#[inline(never)]
#[no_mangle]
pub extern "C" fn scan_end() {
    core::hint::black_box(&IN_SCAN).store(0, Ordering::SeqCst);
}
