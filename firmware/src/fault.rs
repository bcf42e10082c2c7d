#![allow(unsafe_code)]
//! The field fault policy: an independent watchdog fed by the main loop, a
//! fault record that survives the reset a fault ends in, the reset cause,
//! and the brown-out level.
//!
//! - **Watchdog** (IWDG, RM0090 §19): LSI (32 kHz nominal, 17–47 kHz) / 64,
//!   reload 1000 → 2 s nominal (1.4–3.8 s). Fed by the main loop once per
//!   round ([`feed`]) and by a transmit that waits for room while bytes are
//!   still leaving ([`crate::serial`]). Once started it cannot be stopped.
//! - **Fault record**: a panic or a HardFault (or an unexpected interrupt)
//!   writes [`FaultRecord`] into `.uninit` RAM (neither zeroed nor painted
//!   by cortex-m-rt's reset handler, kept by the SRAM across a system
//!   reset) and resets the chip ([`crate::board::fatal`]); the next boot
//!   takes it ([`take_last_fault`]) and reports it.
//! - **Reset cause**: `RCC_CSR`'s flags, read once and cleared ([`reset_cause`]).
//! - **Brown-out**: option byte `BOR_LEV` = level 3 (reset below 2.70 V,
//!   the lowest supply 5 wait states at 168 MHz are specified for, RM0090
//!   Table 10), programmed once if it is not already ([`program_bor_level`]).
//!
//! Under QEMU the watchdog, `RCC_CSR` and the option bytes are not modelled
//! (reads 0, writes ignored): the same code runs and changes nothing.

use core::mem::MaybeUninit;

use stm32f4::stm32f405 as pac;

/// Why the firmware stopped, as stored in the fault record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
#[repr(u32)]
pub enum Cause {
    /// `panic!` (the record's `pc` is the panic handler's return address).
    Panic = 1,
    /// HardFault (`pc`, `lr` from the exception frame).
    HardFault = 2,
    /// An exception or interrupt without a handler (`pc` from the frame is
    /// not available: the IRQ number is stored in `detail`).
    UnexpectedIrq = 3,
}

impl Cause {
    fn from_u32(v: u32) -> Option<Cause> {
        match v {
            1 => Some(Cause::Panic),
            2 => Some(Cause::HardFault),
            3 => Some(Cause::UnexpectedIrq),
            _ => None,
        }
    }
}

/// What the last boot left behind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct FaultRecord {
    /// What happened.
    pub cause: Cause,
    /// Program counter at the fault (address).
    pub pc: u32,
    /// Link register at the fault.
    pub lr: u32,
    /// Panic: source line; HardFault: `SCB_CFSR`; unexpected: IRQ number.
    pub detail: u32,
}

/// The record as stored: a magic word and a check word around it, so that
/// RAM contents after power-up are not mistaken for a record.
#[repr(C)]
struct Stored {
    magic: u32,
    cause: u32,
    pc: u32,
    lr: u32,
    detail: u32,
    check: u32,
}

const MAGIC: u32 = 0x4C4D_5346; // "LMSF"

fn check_word(s: &Stored) -> u32 {
    !(s.magic ^ s.cause.rotate_left(8) ^ s.pc.rotate_left(16) ^ s.lr.rotate_left(24) ^ s.detail)
}

#[link_section = ".uninit.lms_fault_record"]
static mut RECORD: MaybeUninit<Stored> = MaybeUninit::uninit();

/// Store a fault record (called from the fault paths, interrupts masked).
pub fn record(rec: FaultRecord) {
    let mut s = Stored {
        magic: MAGIC,
        cause: rec.cause as u32,
        pc: rec.pc,
        lr: rec.lr,
        detail: rec.detail,
        check: 0,
    };
    s.check = check_word(&s);
    // SAFETY: RECORD is only touched here and in `take_last_fault` (at boot,
    // before interrupts are enabled); the fault paths run with interrupts
    // masked, so there is no concurrent access. A volatile write of a plain
    // `repr(C)` struct of words.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(RECORD).cast::<Stored>(), s) };
}

/// The record the previous boot left, if any, and clear it.
pub fn take_last_fault() -> Option<FaultRecord> {
    let p = core::ptr::addr_of_mut!(RECORD).cast::<Stored>();
    // SAFETY: any bit pattern is a valid `Stored` (six u32); read once at
    // boot before interrupts are on (see `record`).
    let s = unsafe { core::ptr::read_volatile(p) };
    // SAFETY: as above; clears the magic so a record is reported once.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!((*p).magic), 0) };
    if s.magic != MAGIC || s.check != check_word(&s) {
        return None;
    }
    Some(FaultRecord {
        cause: Cause::from_u32(s.cause)?,
        pc: s.pc,
        lr: s.lr,
        detail: s.detail,
    })
}

/// The link register of the caller (for the panic record: a return
/// address inside the panic machinery that called the handler).
#[inline(always)]
pub fn link_register() -> u32 {
    let lr: u32;
    // SAFETY: reads LR into a register; no memory access, no side effect.
    unsafe {
        core::arch::asm!("mov {}, lr", out(reg) lr, options(nomem, nostack, preserves_flags))
    };
    lr
}

/// Reset flags of `RCC_CSR` (bits 25–31 shifted down: BOR, PIN, POR,
/// software, IWDG, WWDG, low-power), 0 under QEMU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct ResetCause(pub u32);

impl ResetCause {
    /// The most telling flag's name (a power-on also sets PIN and BOR).
    pub fn name(self) -> &'static str {
        const NAMES: [(u32, &str); 7] = [
            (1 << 4, "watchdog"),
            (1 << 5, "window-watchdog"),
            (1 << 3, "software"),
            (1 << 6, "low-power"),
            (1 << 2, "power-on"),
            (1 << 0, "brown-out"),
            (1 << 1, "pin"),
        ];
        for (bit, name) in NAMES {
            if self.0 & bit != 0 {
                return name;
            }
        }
        "unknown"
    }
}

/// Read and clear the reset flags (`RMVF`).
pub fn reset_cause(rcc: &pac::RCC) -> ResetCause {
    let csr = rcc.csr().read().bits();
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    ResetCause(csr >> 25)
}

/// IWDG prescaler code 4: LSI / 64.
const IWDG_PR_DIV64: u8 = 4;
/// IWDG reload: 1000 ticks of LSI / 64 = 2 s at 32 kHz.
pub const IWDG_RELOAD: u16 = 1000;

/// Start the independent watchdog (cannot be stopped afterwards).
pub fn start_watchdog(iwdg: &pac::IWDG) {
    iwdg.kr().write(|w| w.key().unlock()); // 0x5555: PR and RLR writable
    iwdg.pr().write(|w| w.pr().set(IWDG_PR_DIV64));
    iwdg.rlr().write(|w| w.rl().set(IWDG_RELOAD));
    iwdg.kr().write(|w| w.key().start()); // 0xCCCC
    feed();
}

/// Reload the watchdog (key 0xAAAA).
pub fn feed() {
    // SAFETY: a write of the reload key to IWDG_KR, which has no other
    // effect; IWDG is otherwise only written once by `start_watchdog`.
    let iwdg = unsafe { &*pac::IWDG::ptr() };
    iwdg.kr().write(|w| w.key().feed());
}

/// `BOR_LEV` code of level 3 (2.70 V) in `FLASH_OPTCR`.
const BOR_LEVEL_3: u32 = 0b00;
/// Option byte unlock keys (RM0090 §3.7.2).
const OPTKEY1: u32 = 0x0819_2A3B;
const OPTKEY2: u32 = 0x4C5D_6E7F;
/// Reads of `FLASH_SR.BSY` before giving up (option byte programming takes
/// milliseconds; this is well over 100 ms at 16 MHz).
const BSY_POLLS: u32 = 2_000_000;

/// What [`program_bor_level`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Bor {
    /// Level 3 was already set.
    AlreadySet,
    /// Programmed now (effective from the next reset).
    Programmed,
    /// The flash interface stayed busy: not programmed.
    Failed,
}

/// Set the brown-out reset level to 3 if it is not (a one-time write of the
/// option bytes; the CPU stalls on flash reads meanwhile).
pub fn program_bor_level(flash: &pac::FLASH) -> Bor {
    let level = |f: &pac::FLASH| (f.optcr().read().bits() >> 2) & 0b11;
    if level(flash) == BOR_LEVEL_3 {
        return Bor::AlreadySet;
    }
    let idle = |f: &pac::FLASH| (0..BSY_POLLS).any(|_| f.sr().read().bsy().bit_is_clear());
    if !idle(flash) {
        return Bor::Failed;
    }
    // SAFETY: the documented unlock sequence, then BOR_LEV cleared (level 3)
    // with every other option bit kept, then OPTSTRT; then locked again.
    unsafe {
        flash.optkeyr().write(|w| w.bits(OPTKEY1));
        flash.optkeyr().write(|w| w.bits(OPTKEY2));
        flash
            .optcr()
            .modify(|r, w| w.bits(r.bits() & !(0b11 << 2) | BOR_LEVEL_3 << 2));
        flash.optcr().modify(|r, w| w.bits(r.bits() | 1 << 1)); // OPTSTRT
    }
    let ok = idle(flash);
    // SAFETY: OPTLOCK (bit 0) set: option bytes locked again.
    unsafe { flash.optcr().modify(|r, w| w.bits(r.bits() | 1)) };
    if ok && level(flash) == BOR_LEVEL_3 {
        Bor::Programmed
    } else {
        Bor::Failed
    }
}
