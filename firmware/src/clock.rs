//! The monotonic time base: SysTick at 1 kHz, read with sub-millisecond
//! resolution as microseconds since boot ([`now_us`]).
//!
//! SysTick counts the core clock ([`crate::board::CORE_HZ`]). The exception
//! adds one millisecond to a 64-bit count; [`now_us`] adds the part of the
//! current millisecond already counted down in `SYST_CVR`, and corrects for
//! a wrap whose exception is still pending, so the value never goes back.
//!
//! Under QEMU, SysTick runs on QEMU's virtual clock: without `-icount` that
//! is the host's clock (while the machine runs), so `now_us` follows wall
//! time; with `-icount shift=N` it follows the instruction count (2^N ns
//! per instruction) and runs are deterministic.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use critical_section::Mutex;

/// Milliseconds since [`start`].
static MILLIS: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));

/// SysTick ticks per second.
pub const TICK_HZ: u32 = 1_000;

/// Start SysTick at [`TICK_HZ`] from a core clock of `core_hz`.
pub fn start(mut syst: SYST, core_hz: u32) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(core_hz / TICK_HZ - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// The SysTick count's low 32 bits, read without a critical section.
static TICKS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    critical_section::with(|cs| {
        let ms = MILLIS.borrow(cs);
        ms.set(ms.get().wrapping_add(1));
    });
    TICKS.fetch_add(1, Ordering::Relaxed);
}

/// SysTicks since [`start`], modulo 2³² (milliseconds; compare with
/// `wrapping_sub`): one load, for the loop's check after every interrupt.
pub fn ticks() -> u32 {
    TICKS.load(Ordering::Relaxed)
}

/// Microseconds since [`start`] (monotonic, 1 µs resolution).
pub fn now_us() -> u64 {
    critical_section::with(|cs| {
        let mut ms = MILLIS.borrow(cs).get();
        let mut current = SYST::get_current();
        // A wrap whose exception cannot run inside this critical section:
        // read the counter again (it is now certainly after the wrap) and
        // count the millisecond ourselves.
        if SCB::is_pendst_pending() {
            current = SYST::get_current();
            ms += 1;
        }
        let reload = SYST::get_reload();
        let elapsed = u64::from(reload.saturating_sub(current));
        ms * 1_000
            + lms_core::maths::div_u64(
                elapsed * 1_000,
                lms_core::maths::divisor(u64::from(reload) + 1),
            )
    })
}
