#![allow(unsafe_code)]
//! The global `defmt` logger, with its sink chosen at run time: RTT on the
//! board (the embedded Rust convention: `probe-rs run` reads the up channel
//! while a debugger is attached; without one the frames are dropped when
//! the 256-byte buffer is full, never blocking), semihosting `SYS_WRITE` to
//! QEMU's stdout when [`crate::rcc`] has detected QEMU.
//!
//! Semihosting is never used on the board: a `BKPT 0xAB` without a
//! debugger escalates to HardFault. Until [`use_semihosting`] or
//! [`init_rtt`] is called, frames go nowhere.

use core::cell::{RefCell, UnsafeCell};
use core::sync::atomic::{AtomicU8, Ordering};

use critical_section::Mutex;
use rtt_target::UpChannel;
use semihosting::io::{Stdout, Write as _};

const SINK_NONE: u8 = 0;
const SINK_RTT: u8 = 1;
const SINK_SEMIHOSTING: u8 = 2;

static SINK: AtomicU8 = AtomicU8::new(SINK_NONE);
static RTT: Mutex<RefCell<Option<UpChannel>>> = Mutex::new(RefCell::new(None));
static STDOUT: Mutex<RefCell<Option<Stdout>>> = Mutex::new(RefCell::new(None));

/// Bytes of the RTT up buffer (channel 0, "defmt"): a frame is at most
/// ~40 bytes (rzcobs, the longest format with its arguments), the boot's
/// six lines ~0.2 KB; `probe-rs` empties it every few milliseconds.
pub const RTT_BUFFER: usize = 256;

/// Log through RTT from now on (the board).
pub fn init_rtt() {
    let channels = rtt_target::rtt_init! {
        up: {
            0: {
                size: RTT_BUFFER,
                name: "defmt"
            }
        }
    };
    critical_section::with(|cs| {
        if let Ok(mut slot) = RTT.borrow(cs).try_borrow_mut() {
            *slot = Some(channels.up.0);
        }
    });
    SINK.store(SINK_RTT, Ordering::SeqCst);
}

/// Log through semihosting from now on (QEMU only).
pub fn use_semihosting() {
    let out = semihosting::io::stdout().ok();
    critical_section::with(|cs| {
        if let Ok(mut slot) = STDOUT.borrow(cs).try_borrow_mut() {
            *slot = out;
        }
    });
    SINK.store(SINK_SEMIHOSTING, Ordering::SeqCst);
}

/// Hand encoded bytes to the sink (inside the logger's critical section).
fn emit(cs: critical_section::CriticalSection<'_>, bytes: &[u8]) {
    match SINK.load(Ordering::Relaxed) {
        SINK_RTT => {
            if let Some(ch) = RTT
                .borrow(cs)
                .try_borrow_mut()
                .ok()
                .as_deref_mut()
                .and_then(Option::as_mut)
            {
                ch.write(bytes);
            }
        }
        SINK_SEMIHOSTING => {
            if let Some(out) = STDOUT
                .borrow(cs)
                .try_borrow_mut()
                .ok()
                .as_deref_mut()
                .and_then(Option::as_mut)
            {
                let _ = out.write_all(bytes);
            }
        }
        _ => {}
    }
}

#[defmt::global_logger]
struct Logger;

/// The logger's state: frame nesting depth, the critical section the
/// outer frame holds, the encoder.
struct State {
    /// 0: no frame; 1: a frame is open; more: a log from inside a log
    /// (e.g. a fault while encoding), whose frame is dropped.
    depth: AtomicU8,
    restore: UnsafeCell<critical_section::RestoreState>,
    encoder: UnsafeCell<defmt::Encoder>,
}

// SAFETY: the cells are only accessed between `acquire` and `release`,
// inside one critical section (single core), with depth 1.
unsafe impl Sync for State {}

static STATE: State = State {
    depth: AtomicU8::new(0),
    restore: UnsafeCell::new(critical_section::RestoreState::invalid()),
    encoder: UnsafeCell::new(defmt::Encoder::new()),
};

/// A critical-section token for code that already holds one.
fn cs() -> critical_section::CriticalSection<'static> {
    // SAFETY: only called between `acquire` and `release`, which hold a
    // critical section for the whole frame.
    unsafe { critical_section::CriticalSection::new() }
}

// SAFETY: defmt's contract: acquire/release pair up, write/flush only in
// between. A nested frame (only possible from a fault inside a log: the
// critical section masks interrupts) is dropped instead of corrupting the
// outer one.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: paired with `release` below (or undone at once when nested).
        let restore = unsafe { critical_section::acquire() };
        if STATE.depth.fetch_add(1, Ordering::Relaxed) > 0 {
            // SAFETY: undo the nested acquire; the outer frame goes on.
            unsafe { critical_section::release(restore) };
            return;
        }
        // SAFETY: exclusive access inside the critical section.
        unsafe {
            STATE.restore.get().write(restore);
            (*STATE.encoder.get()).start_frame(|b| emit(cs(), b));
        }
    }

    unsafe fn flush() {}

    unsafe fn release() {
        match STATE.depth.load(Ordering::Relaxed) {
            0 => {}
            1 => {
                // SAFETY: exclusive access inside the critical section.
                unsafe {
                    (*STATE.encoder.get()).end_frame(|b| emit(cs(), b));
                    let restore = STATE.restore.get().read();
                    STATE.depth.store(0, Ordering::Relaxed);
                    critical_section::release(restore);
                }
            }
            _ => {
                STATE.depth.fetch_sub(1, Ordering::Relaxed);
            }
        }
    }

    unsafe fn write(bytes: &[u8]) {
        if STATE.depth.load(Ordering::Relaxed) != 1 {
            return;
        }
        // SAFETY: exclusive access inside the critical section.
        unsafe { (*STATE.encoder.get()).write(bytes, |b| emit(cs(), b)) };
    }
}
