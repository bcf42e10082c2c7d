//! A USART as an `embedded-io` byte stream: interrupt-driven receive into a
//! fixed queue, blocking transmit.
//!
//! The receive interrupt ([`on_rx_interrupt`], called from the handlers in
//! [`crate::board`]) moves each byte from the data register into the
//! producer end of a `heapless::spsc::Queue`; the main loop reads from the
//! consumer end through [`Serial`]'s [`Read`] / [`ReadReady`]. Nothing here
//! blocks in the interrupt and nothing is lost silently: a byte that finds
//! the queue full is dropped and counted in [`RxStats::dropped_full`], a
//! byte the hardware lost because the interrupt came too late is counted in
//! [`RxStats::overrun`].
//!
//! Transmit writes the data register as soon as `TXE` says it is empty. In
//! QEMU `TXE` is always set and the byte leaves at once; on silicon the
//! caller waits one character time per byte.

use core::convert::Infallible;
use core::ops::Deref;
use core::sync::atomic::{AtomicU32, Ordering};

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use heapless::spsc::{Consumer, Producer};
use stm32f4::stm32f405::usart1::RegisterBlock;

/// Receive counters of one USART, written by its interrupt, read anywhere.
pub struct RxStats {
    /// Bytes put into the queue.
    pub received: AtomicU32,
    /// Bytes dropped because the queue was full.
    pub dropped_full: AtomicU32,
    /// Hardware overruns (`ORE`): at least one byte lost before the
    /// interrupt read the previous one.
    pub overrun: AtomicU32,
    /// Bytes received with a framing, noise or parity error (kept, counted).
    pub line_errors: AtomicU32,
    /// Most bytes ever waiting in the queue (its high-water mark).
    pub peak_queued: AtomicU32,
}

impl RxStats {
    /// All counters zero.
    pub const fn new() -> Self {
        RxStats {
            received: AtomicU32::new(0),
            dropped_full: AtomicU32::new(0),
            overrun: AtomicU32::new(0),
            line_errors: AtomicU32::new(0),
            peak_queued: AtomicU32::new(0),
        }
    }

    /// A snapshot of the counters.
    pub fn snapshot(&self) -> RxCounts {
        RxCounts {
            received: self.received.load(Ordering::Relaxed),
            dropped_full: self.dropped_full.load(Ordering::Relaxed),
            overrun: self.overrun.load(Ordering::Relaxed),
            line_errors: self.line_errors.load(Ordering::Relaxed),
            peak_queued: self.peak_queued.load(Ordering::Relaxed),
        }
    }
}

/// A copy of [`RxStats`] at one moment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct RxCounts {
    /// Bytes put into the queue.
    pub received: u32,
    /// Bytes dropped because the queue was full.
    pub dropped_full: u32,
    /// Hardware overruns.
    pub overrun: u32,
    /// Bytes with a framing, noise or parity error.
    pub line_errors: u32,
    /// High-water mark of the queue (bytes).
    pub peak_queued: u32,
}

impl RxCounts {
    /// Bytes lost before reaching the queue's reader: queue full or overrun.
    pub fn lost(&self) -> u32 {
        self.dropped_full.wrapping_add(self.overrun)
    }
}

/// Serial settings: 8 data bits, no parity, 1 stop bit, no flow control (the
/// LMS 2xx's 8N1), at `baud` from a peripheral clock of `pclk_hz`.
pub fn configure(usart: &RegisterBlock, pclk_hz: u32, baud: u32, rx_interrupt: bool) {
    usart.cr1().reset();
    usart.cr2().reset();
    usart.cr3().reset();
    write_brr(usart, brr(pclk_hz, baud));
    usart.cr1().write(|w| {
        w.ue().set_bit();
        w.te().set_bit();
        w.re().set_bit();
        // Only RXNEIE: QEMU's model raises the line for TXE/TC too if their
        // enables are set, and TXE is always set there.
        w.rxneie().bit(rx_interrupt)
    });
}

/// The `BRR` value for 16× oversampling: `USARTDIV = pclk / baud` in 12.4
/// fixed point, rounded to nearest (RM0090 §30.3.4).
pub const fn brr(pclk_hz: u32, baud: u32) -> u32 {
    if baud == 0 {
        return 0;
    }
    (pclk_hz + baud / 2) / baud
}

fn write_brr(usart: &RegisterBlock, div: u32) {
    usart.brr().write(|w| {
        w.div_mantissa().set(((div >> 4) & 0x0fff) as u16);
        w.div_fraction().set((div & 0x0f) as u8)
    });
}

/// The receive interrupt of one USART: drain the data register into the
/// queue, count what is lost. `producer` is `None` only if the interrupt
/// fires before the queue has been handed over; the byte is then counted
/// as dropped (the data register must be read or the interrupt repeats).
pub fn on_rx_interrupt(
    usart: &RegisterBlock,
    producer: Option<&mut Producer<'static, u8>>,
    stats: &RxStats,
) {
    let mut producer = producer;
    loop {
        // Reading SR then DR clears RXNE and the error flags (ORE, NF, FE, PE).
        let sr = usart.sr().read();
        if !(sr.rxne().bit_is_set() || sr.ore().bit_is_set()) {
            return;
        }
        let byte = usart.dr().read().dr().bits() as u8;
        if sr.ore().bit_is_set() {
            stats.overrun.fetch_add(1, Ordering::Relaxed);
        }
        if sr.fe().bit_is_set() || sr.nf().bit_is_set() || sr.pe().bit_is_set() {
            stats.line_errors.fetch_add(1, Ordering::Relaxed);
        }
        if !sr.rxne().bit_is_set() {
            // ORE without a new byte: the DR read above only cleared the flag.
            continue;
        }
        let queued = producer
            .as_deref_mut()
            .and_then(|p| p.enqueue(byte).ok().map(|()| p.len()));
        match queued {
            Some(len) => {
                stats.received.fetch_add(1, Ordering::Relaxed);
                stats.peak_queued.fetch_max(len as u32, Ordering::Relaxed);
            }
            None => {
                stats.dropped_full.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// One USART as a byte stream for the main loop: the consumer end of its
/// receive queue and its transmitter.
///
/// `U` is the owned peripheral (`pac::USART1`, …), which gives access to
/// the registers.
pub struct Serial<U> {
    usart: U,
    rx: Consumer<'static, u8>,
    stats: &'static RxStats,
    pclk_hz: u32,
}

impl<U: Deref<Target = RegisterBlock>> Serial<U> {
    /// Wrap a configured USART and the consumer end of its receive queue.
    pub fn new(usart: U, rx: Consumer<'static, u8>, stats: &'static RxStats, pclk_hz: u32) -> Self {
        Serial {
            usart,
            rx,
            stats,
            pclk_hz,
        }
    }

    /// The receive counters.
    pub fn rx_counts(&self) -> RxCounts {
        self.stats.snapshot()
    }

    /// Bytes waiting in the receive queue.
    pub fn rx_pending(&self) -> usize {
        self.rx.len()
    }

    /// Room of the receive queue in bytes.
    pub fn rx_capacity(&self) -> usize {
        self.rx.capacity()
    }

    /// Change the line speed (e.g. after the sensor has acknowledged `20 4x`).
    /// Waits for the last byte to leave first. QEMU ignores the rate.
    pub fn set_baud(&mut self, baud: u32) {
        while self.usart.sr().read().tc().bit_is_clear() {}
        write_brr(&self.usart, brr(self.pclk_hz, baud));
    }

    fn write_byte(&mut self, byte: u8) {
        while self.usart.sr().read().txe().bit_is_clear() {}
        self.usart.dr().write(|w| w.dr().set(u16::from(byte)));
    }
}

impl<U> ErrorType for Serial<U> {
    type Error = Infallible;
}

impl<U: Deref<Target = RegisterBlock>> ReadReady for Serial<U> {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.rx.ready())
    }
}

impl<U: Deref<Target = RegisterBlock>> Read for Serial<U> {
    /// Blocks (sleeping between interrupts) until at least one byte is
    /// there, then returns what is queued, up to `buf.len()`.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        while !self.rx.ready() {
            cortex_m::asm::wfi();
        }
        let mut n = 0;
        for slot in buf.iter_mut() {
            match self.rx.dequeue() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        Ok(n)
    }
}

impl<U: Deref<Target = RegisterBlock>> Write for Serial<U> {
    /// Blocking: returns when every byte has been handed to the transmitter.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            self.write_byte(b);
        }
        Ok(buf.len())
    }

    /// Waits until the last byte has left the shift register.
    fn flush(&mut self) -> Result<(), Infallible> {
        while self.usart.sr().read().tc().bit_is_clear() {}
        Ok(())
    }
}

impl<U: Deref<Target = RegisterBlock>> WriteReady for Serial<U> {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.usart.sr().read().txe().bit_is_set())
    }
}

/// A USART without a receive interrupt, polled by the main loop (the
/// control console): nothing is queued, QEMU holds the next byte until the
/// data register is read.
pub struct PolledSerial<U> {
    usart: U,
}

impl<U: Deref<Target = RegisterBlock>> PolledSerial<U> {
    /// Wrap a configured USART.
    pub fn new(usart: U) -> Self {
        PolledSerial { usart }
    }

    /// The next received byte, if one is there.
    pub fn try_read(&mut self) -> Option<u8> {
        let sr = self.usart.sr().read();
        if sr.rxne().bit_is_set() || sr.ore().bit_is_set() {
            let byte = self.usart.dr().read().dr().bits() as u8;
            sr.rxne().bit_is_set().then_some(byte)
        } else {
            None
        }
    }

    /// Blocking transmit.
    pub fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while self.usart.sr().read().txe().bit_is_clear() {}
            self.usart.dr().write(|w| w.dr().set(u16::from(b)));
        }
    }
}
