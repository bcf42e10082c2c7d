#![allow(unsafe_code)]
//! Board bring-up for the STM32F405 as QEMU's `netduinoplus2` models it,
//! the UART interrupt handlers, fault handlers and the stack report.
//!
//! This is the only module with `unsafe` code; each block says why it holds.
//!
//! | port | USART | pins (silicon) | IRQ | QEMU | role |
//! |---|---|---|---|---|---|
//! | host | USART1 | PA9 TX / PA10 RX, AF7 | 37 | 1st `-serial` | the robot's computer (LMS client) |
//! | sensor | USART2 | PA2 TX / PA3 RX, AF7 | 38 | 2nd `-serial` | the LMS 2xx |
//! | control | USART3 | PB10 TX / PB11 RX, AF7 | polled | 3rd `-serial` | debug console: stats, exit |
//!
//! Clocks: QEMU has no RCC model (its registers read 0 and ignore writes),
//! so nothing here waits for a ready bit. QEMU runs the core at a fixed
//! 168 MHz (`netduinoplus2`: `SYSCLK_FRQ`), SysTick's "processor clock"
//! source included; the serial rate is ignored. The peripheral clock
//! enables and the pin functions below are written anyway so that the same
//! code is right on silicon, where only the PLL set-up (HSE → 168 MHz,
//! APB1 42 MHz, APB2 84 MHz) is still missing.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::{exception, ExceptionFrame};
use critical_section::Mutex;
use heapless::spsc::{Producer, Queue};
use static_cell::ConstStaticCell;
use stm32f4::stm32f405::{self as pac, interrupt, Interrupt};

use crate::clock;
use crate::serial::{self, PolledSerial, RxStats, Serial};

/// Core clock (Hz): QEMU `netduinoplus2`'s fixed SYSCLK.
pub const CORE_HZ: u32 = 168_000_000;
/// APB2 clock (USART1) of the 168 MHz configuration (Hz).
pub const PCLK2_HZ: u32 = 84_000_000;
/// APB1 clock (USART2, USART3) of the 168 MHz configuration (Hz).
pub const PCLK1_HZ: u32 = 42_000_000;

/// Line speed of the host side at power-on (Bd): the co-processor looks like
/// an LMS 2xx to its client, which starts at 9600 and switches on request
/// ([`Serial::set_baud`]).
pub const HOST_BAUD: u32 = 9_600;
/// Line speed of the sensor side at power-on (Bd): the LMS 2xx starts at 9600.
pub const SENSOR_BAUD: u32 = 9_600;
/// Line speed of the control console (Bd).
pub const CONTROL_BAUD: u32 = 115_200;

/// Slots of the host receive queue (holds one less byte): requests are short.
pub const HOST_RX_SLOTS: usize = 1024;
/// Slots of the sensor receive queue (holds one less byte): five 732-byte
/// scans, i.e. ~80 ms of a 500 kBd stream (50 kB/s), for a loop that is
/// busy with one scan for ~20–30 ms (3.3 M instructions at 168 MHz).
pub const SENSOR_RX_SLOTS: usize = 4096;

/// The host port (USART1).
pub type HostPort = Serial<pac::USART1>;
/// The sensor port (USART2).
pub type SensorPort = Serial<pac::USART2>;
/// The control console (USART3).
pub type ControlPort = PolledSerial<pac::USART3>;

static HOST_RX: ConstStaticCell<Queue<u8, HOST_RX_SLOTS>> = ConstStaticCell::new(Queue::new());
static SENSOR_RX: ConstStaticCell<Queue<u8, SENSOR_RX_SLOTS>> = ConstStaticCell::new(Queue::new());

/// Producer ends, parked here until each interrupt takes its own on first entry.
static HOST_RX_PRODUCER: Mutex<RefCell<Option<Producer<'static, u8>>>> =
    Mutex::new(RefCell::new(None));
static SENSOR_RX_PRODUCER: Mutex<RefCell<Option<Producer<'static, u8>>>> =
    Mutex::new(RefCell::new(None));

static HOST_RX_STATS: RxStats = RxStats::new();
static SENSOR_RX_STATS: RxStats = RxStats::new();

/// What [`init`] hands to the main loop.
pub struct Board {
    /// USART1.
    pub host: HostPort,
    /// USART2.
    pub sensor: SensorPort,
    /// USART3.
    pub control: ControlPort,
}

/// Bring the board up: clocks for the peripherals, pins, the three USARTs,
/// their receive queues and interrupts, SysTick. Call once; returns `None`
/// if called again.
pub fn init() -> Option<Board> {
    let cp = cortex_m::Peripherals::take()?;
    let dp = pac::Peripherals::take()?;

    // Peripheral clocks and pins (no effect in QEMU, needed on silicon).
    dp.RCC
        .ahb1enr()
        .modify(|_, w| w.gpioaen().set_bit().gpioben().set_bit());
    dp.RCC.apb2enr().modify(|_, w| w.usart1en().set_bit());
    dp.RCC
        .apb1enr()
        .modify(|_, w| w.usart2en().set_bit().usart3en().set_bit());
    dp.GPIOA.afrl().modify(|_, w| w.afrl2().af7().afrl3().af7());
    dp.GPIOA
        .afrh()
        .modify(|_, w| w.afrh9().af7().afrh10().af7());
    dp.GPIOA.moder().modify(|_, w| {
        w.moder2().alternate();
        w.moder3().alternate();
        w.moder9().alternate();
        w.moder10().alternate()
    });
    dp.GPIOB
        .afrh()
        .modify(|_, w| w.afrh10().af7().afrh11().af7());
    dp.GPIOB
        .moder()
        .modify(|_, w| w.moder10().alternate().moder11().alternate());

    // Receive queues: the consumer ends go to the ports, the producer ends
    // to the interrupts (taken before the interrupts are unmasked).
    let (host_tx, host_rx) = HOST_RX.take().split();
    let (sensor_tx, sensor_rx) = SENSOR_RX.take().split();
    critical_section::with(|cs| {
        HOST_RX_PRODUCER.borrow_ref_mut(cs).replace(host_tx);
        SENSOR_RX_PRODUCER.borrow_ref_mut(cs).replace(sensor_tx);
    });

    // Receivers on as early as possible: QEMU drops what arrives before.
    serial::configure(&dp.USART1, PCLK2_HZ, HOST_BAUD, true);
    serial::configure(&dp.USART2, PCLK1_HZ, SENSOR_BAUD, true);
    serial::configure(&dp.USART3, PCLK1_HZ, CONTROL_BAUD, false);

    clock::start(cp.SYST, CORE_HZ);

    // SAFETY: unmasking can break a critical section only if one is in
    // progress; none is (we are in thread mode outside `critical_section::with`),
    // and both handlers only touch their own queue end and counters.
    unsafe {
        cortex_m::peripheral::NVIC::unmask(Interrupt::USART1);
        cortex_m::peripheral::NVIC::unmask(Interrupt::USART2);
    }

    Some(Board {
        host: Serial::new(dp.USART1, host_rx, &HOST_RX_STATS, PCLK2_HZ),
        sensor: Serial::new(dp.USART2, sensor_rx, &SENSOR_RX_STATS, PCLK1_HZ),
        control: PolledSerial::new(dp.USART3),
    })
}

#[interrupt]
fn USART1() {
    static mut PRODUCER: Option<Producer<'static, u8>> = None;
    if PRODUCER.is_none() {
        *PRODUCER = critical_section::with(|cs| HOST_RX_PRODUCER.borrow_ref_mut(cs).take());
    }
    // SAFETY: the handler reads only SR and DR; the main loop's `Serial`
    // writes DR/BRR and reads SR, which has no side effect on this path
    // (a SR read followed by a DR read clears the error flags; the main loop
    // never reads DR of an interrupt-driven port).
    let usart = unsafe { pac::USART1::steal() };
    serial::on_rx_interrupt(&usart, PRODUCER.as_mut(), &HOST_RX_STATS);
}

#[interrupt]
fn USART2() {
    static mut PRODUCER: Option<Producer<'static, u8>> = None;
    if PRODUCER.is_none() {
        *PRODUCER = critical_section::with(|cs| SENSOR_RX_PRODUCER.borrow_ref_mut(cs).take());
    }
    // SAFETY: as for USART1.
    let usart = unsafe { pac::USART2::steal() };
    serial::on_rx_interrupt(&usart, PRODUCER.as_mut(), &SENSOR_RX_STATS);
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
    defmt::error!(
        "hard fault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    semihosting::process::exit(crate::EXIT_HARD_FAULT)
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    defmt::error!("unexpected exception or interrupt {=i16}", irqn);
    semihosting::process::exit(crate::EXIT_UNEXPECTED_IRQ)
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
