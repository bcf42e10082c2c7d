#![allow(unsafe_code)]
//! The clock tree (RM0090 §6.3, §3.5.1): HSE → PLL → SYSCLK 168 MHz,
//! AHB /1, APB1 /4 (42 MHz: USART2, USART3), APB2 /2 (84 MHz: USART1),
//! 5 flash wait states with prefetch and both caches; and QEMU detected at
//! run time.
//!
//! **QEMU** (`netduinoplus2`) has no RCC model: its registers read 0 and
//! ignore writes, and the core runs at a fixed 168 MHz. Silicon always reads
//! `RCC_CR` ≠ 0 after any reset (`HSION`, `HSIRDY` and the `HSITRIM` reset
//! value 16 are set), so `RCC_CR == 0` means QEMU ([`init`] then writes
//! nothing and returns [`Clocks::QEMU`], whose bus clocks are the nominal
//! 42/84 MHz: the baud-rate registers hold the same values as on the board).
//!
//! **Every ready bit is waited for a bounded number of reads**
//! ([`READY_POLLS`]): HSE that does not start → the PLL runs from HSI
//! (16 MHz, still 168 MHz, ±1 % instead of the crystal's accuracy); a PLL
//! that does not lock, flash latency that does not read back or a clock
//! switch that does not happen → the chip stays on HSI 16 MHz with all
//! buses at 16 MHz. The baud-rate registers and SysTick are computed from
//! the [`Clocks`] actually set, so the lines keep their rates in every case.

use stm32f4::stm32f405 as pac;

use crate::serial::{brr, Bd};

/// Crystal on the board (Hz): `LMS_HSE_HZ` at build time, default 8 MHz
/// (STM32F4-Discovery; 25 MHz on a Netduino Plus 2).
pub const HSE_HZ: u32 = crate::HSE_HZ;
/// The internal RC oscillator (Hz).
pub const HSI_HZ: u32 = 16_000_000;
/// SYSCLK = HCLK (Hz), the Cortex-M4's clock and SysTick's.
pub const SYSCLK_HZ: u32 = 168_000_000;
/// APB1 (Hz): HCLK / 4 (≤ 42 MHz, RM0090 §6.2).
pub const PCLK1_HZ: u32 = SYSCLK_HZ / 4;
/// APB2 (Hz): HCLK / 2 (≤ 84 MHz).
pub const PCLK2_HZ: u32 = SYSCLK_HZ / 2;
/// Flash wait states for 168 MHz at 2.7–3.6 V (RM0090 Table 10).
pub const FLASH_LATENCY: u32 = 5;
/// Reads of a ready bit before giving up: ≥ 4 cycles each, so at least
/// 125 ms at 16 MHz (ST's HSE start-up time-out is 100 ms).
pub const READY_POLLS: u32 = 500_000;

/// Where SYSCLK comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Source {
    /// QEMU: no clock tree, a fixed 168 MHz.
    Emulator,
    /// PLL from the crystal (the intended configuration).
    HsePll,
    /// PLL from HSI: the crystal did not start.
    HsiPll,
    /// HSI directly: the PLL or the switch to it failed.
    Hsi,
}

/// The clocks in force (Hz).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Clocks {
    /// Where SYSCLK comes from.
    pub source: Source,
    /// SYSCLK = HCLK.
    pub sysclk_hz: u32,
    /// APB1 (USART2, USART3).
    pub pclk1_hz: u32,
    /// APB2 (USART1).
    pub pclk2_hz: u32,
}

impl Clocks {
    /// QEMU's fixed clock (bus clocks nominal, for the same `BRR` values).
    pub const QEMU: Clocks = Clocks::pll(Source::Emulator);
    /// HSI only, all buses undivided.
    pub const HSI: Clocks = Clocks {
        source: Source::Hsi,
        sysclk_hz: HSI_HZ,
        pclk1_hz: HSI_HZ,
        pclk2_hz: HSI_HZ,
    };

    const fn pll(source: Source) -> Clocks {
        Clocks {
            source,
            sysclk_hz: SYSCLK_HZ,
            pclk1_hz: PCLK1_HZ,
            pclk2_hz: PCLK2_HZ,
        }
    }

    /// True under QEMU.
    pub fn is_emulator(&self) -> bool {
        self.source == Source::Emulator
    }
}

/// PLL dividers (RM0090 §6.3.2): VCO in = in / M (1–2 MHz), VCO = in × N
/// (100–432 MHz), SYSCLK = VCO / P, USB = VCO / Q (48 MHz).
#[derive(Clone, Copy)]
struct Pll {
    m: u32,
    n: u32,
    p: u32,
    q: u32,
}

/// VCO frequency (Hz) for SYSCLK 168 MHz with P = 2, USB 48 MHz with Q = 7.
const VCO_HZ: u32 = 336_000_000;

/// The dividers for an input of `input_hz` (2 MHz VCO input if it divides,
/// else 1 MHz); checked at compile time for HSE and HSI below.
const fn pll_for(input_hz: u32) -> Pll {
    let vco_in = if input_hz % 2_000_000 == 0 {
        2_000_000
    } else {
        1_000_000
    };
    Pll {
        m: input_hz / vco_in,
        n: VCO_HZ / vco_in,
        p: 2,
        q: 7,
    }
}

const fn pll_ok(input_hz: u32) -> bool {
    let pll = pll_for(input_hz);
    let vco_in = input_hz / pll.m;
    input_hz % pll.m == 0
        && pll.m >= 2
        && pll.m <= 63
        && pll.n >= 50
        && pll.n <= 432
        && vco_in >= 1_000_000
        && vco_in <= 2_000_000
        && vco_in * pll.n == VCO_HZ
        && VCO_HZ / pll.p == SYSCLK_HZ
        && VCO_HZ / pll.q == 48_000_000
}

const PLL_HSE: Pll = pll_for(HSE_HZ);
const PLL_HSI: Pll = pll_for(HSI_HZ);
const _: () = assert!(pll_ok(HSE_HZ), "LMS_HSE_HZ gives no exact 168 MHz PLL");
const _: () = assert!(pll_ok(HSI_HZ));

/// Relative error of the line rate `pclk_hz / brr(pclk_hz, baud)` in ppm
/// (`pclk_hz` in Hz).
pub const fn baud_error_ppm(pclk_hz: u32, baud: Bd) -> u32 {
    let div = brr(pclk_hz, baud);
    let Bd(baud) = baud;
    if div < 16 {
        return u32::MAX; // USARTDIV < 1: not possible
    }
    let actual = pclk_hz as u64 * 1_000_000 / div as u64;
    let want = baud as u64 * 1_000_000;
    let diff = actual.abs_diff(want);
    (diff * 1_000_000 / want) as u32
}

/// Every rate the LMS 2xx and its clients use, on both bus clocks, and the
/// console's 115 200 on APB1: within 1 % (at 42 and 84 MHz 500 kBd is
/// exact), checked at compile time.
const _: () = {
    let rates = [9_600, 19_200, 38_400, 500_000];
    let mut i = 0;
    while i < rates.len() {
        assert!(baud_error_ppm(PCLK1_HZ, Bd(rates[i])) < 10_000);
        assert!(baud_error_ppm(PCLK2_HZ, Bd(rates[i])) < 10_000);
        assert!(baud_error_ppm(HSI_HZ, Bd(rates[i])) < 10_000);
        i += 1;
    }
    assert!(baud_error_ppm(PCLK1_HZ, Bd(500_000)) == 0);
    assert!(baud_error_ppm(PCLK2_HZ, Bd(500_000)) == 0);
    assert!(baud_error_ppm(PCLK1_HZ, Bd(115_200)) < 10_000);
    assert!(baud_error_ppm(HSI_HZ, Bd(115_200)) < 10_000);
};

/// True once `ready` returned true within [`READY_POLLS`] reads.
fn wait(mut ready: impl FnMut() -> bool) -> bool {
    for _ in 0..READY_POLLS {
        if ready() {
            return true;
        }
    }
    false
}

/// Detect QEMU; on silicon set the clock tree up. Call once, first thing.
pub fn init(rcc: &pac::RCC, flash: &pac::FLASH, pwr: &pac::PWR) -> Clocks {
    if rcc.cr().read().bits() == 0 {
        return Clocks::QEMU;
    }
    // Voltage scale 1 (the reset value; needed for 168 MHz).
    rcc.apb1enr().modify(|_, w| w.pwren().set_bit());
    pwr.cr().modify(|_, w| w.vos().set_bit());

    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let (source, pll, pllsrc) = if wait(|| rcc.cr().read().hserdy().bit_is_set()) {
        (Source::HsePll, PLL_HSE, 1)
    } else {
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
        (Source::HsiPll, PLL_HSI, 0)
    };
    let cfg = pll.m | pll.n << 6 | (pll.p / 2 - 1) << 16 | pllsrc << 22 | pll.q << 24;
    // SAFETY: every field of PLLCFGR is written with a value checked
    // against its range above (`pll_ok`); the PLL is off.
    rcc.pllcfgr().write(|w| unsafe { w.bits(cfg) });
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    if !wait(|| rcc.cr().read().pllrdy().bit_is_set()) {
        rcc.cr().modify(|_, w| w.pllon().clear_bit());
        return Clocks::HSI;
    }
    set_flash_latency(flash);
    if !wait(|| flash.acr().read().latency().bits() == FLASH_LATENCY as u8) {
        return Clocks::HSI;
    }
    rcc.cfgr()
        .modify(|_, w| w.hpre().div1().ppre1().div4().ppre2().div2());
    rcc.cfgr().modify(|_, w| w.sw().pll());
    if !wait(|| rcc.cfgr().read().sws().is_pll()) {
        rcc.cfgr()
            .modify(|_, w| w.sw().hsi().ppre1().div1().ppre2().div1());
        return Clocks::HSI;
    }
    Clocks::pll(source)
}

/// 5 wait states, prefetch, instruction and data caches (reset first, as
/// RM0090 §3.5.2 asks, while they are off).
fn set_flash_latency(flash: &pac::FLASH) {
    flash
        .acr()
        .modify(|_, w| w.icen().clear_bit().dcen().clear_bit());
    flash
        .acr()
        .modify(|_, w| w.icrst().set_bit().dcrst().set_bit());
    flash
        .acr()
        .modify(|_, w| w.icrst().clear_bit().dcrst().clear_bit());
    flash.acr().write(|w| {
        w.latency().ws5();
        w.prften().set_bit();
        w.icen().set_bit();
        w.dcen().set_bit()
    });
}
