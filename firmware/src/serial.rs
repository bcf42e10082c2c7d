//! A USART as an `embedded-io` byte stream: interrupt-driven receive into a
//! fixed queue, interrupt-driven transmit from a fixed queue.
//!
//! The interrupt ([`on_interrupt`], called from the handlers in
//! [`crate::board`]) moves each received byte from the data register into
//! the producer end of a [`crate::ring::Ring`], and, while the transmit
//! queue holds bytes (`TXEIE` on), the next byte to send into the data
//! register. The main loop reads from the receive queue's consumer end and
//! writes into the transmit queue's producer end through [`Serial`]'s
//! [`Read`] / [`ReadReady`] / [`Write`]: a write returns as soon as its
//! bytes are queued, and the line sends them while the loop computes.
//! Only a write that finds the transmit queue full waits, asleep in `WFI`
//! until the interrupt has made room: the console's report and the
//! sensor's short requests; the co-processor writes to the host port only
//! what its free space (`WriteRoom`) says fits, so it never waits there. Nothing here blocks in the
//! interrupt and nothing is lost silently. Receive has backpressure: when
//! the queue is full the interrupt leaves the byte in the data register and
//! switches `RXNEIE` off; the loop's next read makes room and switches it
//! back on ([`resume_rx`]). Under QEMU the character device then simply
//! waits (it delivers a byte only while `RXNE` is clear), so nothing is
//! lost; on a board the bytes that arrive meanwhile overrun the data
//! register and are counted in [`RxStats::overrun`] (`ORE`: at least one
//! byte lost), as is a byte the hardware lost because the interrupt came
//! too late. [`RxStats::dropped_full`] counts the bytes read before the
//! queue was handed over (none after start-up).
//!
//! Each entry moves one byte each way, as on silicon, where `TXE` clears
//! with each write. QEMU 7.2 keeps `TXE` set and raises a USART's line only
//! for received bytes, so the writer pends the interrupt to start sending
//! ([`Serial`]'s `start_tx`) and the interrupt pends itself again after
//! each byte while `TXE` stays set: under QEMU, too, every byte sent is one
//! interrupt entry, and the cycle estimate counts the board's interrupts.

use core::convert::Infallible;
use core::ops::Deref;
use core::sync::atomic::{AtomicU32, Ordering};

use crate::ring::{Consumer, Producer};
use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use lms_core::maths::{div_u64, divisor};
use stm32f4::stm32f405::usart1::RegisterBlock;
use stm32f4::stm32f405::Interrupt;

/// Receive counters of one USART, written by its interrupt, read anywhere.
pub struct RxStats {
    /// Bytes put into the queue.
    pub received: AtomicU32,
    /// Bytes dropped because there was no queue to put them in (before
    /// start-up handed it over; a full queue holds the line instead).
    pub dropped_full: AtomicU32,
    /// Hardware overruns (`ORE`): at least one byte lost before the
    /// interrupt read the previous one, or while a full queue held the
    /// line (backpressure).
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

/// A line rate (Bd: bits per second on the line).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bd(pub u32);

/// Serial settings: 8 data bits, no parity, 1 stop bit, no flow control (the
/// LMS 2xx's 8N1), at `baud` from a peripheral clock of `pclk_hz` (Hz);
/// receive interrupt on (the transmit interrupt is switched on while bytes
/// wait).
pub fn configure(usart: &RegisterBlock, pclk_hz: u32, baud: Bd) {
    usart.cr1().reset();
    usart.cr2().reset();
    usart.cr3().reset();
    write_brr(usart, brr(pclk_hz, baud));
    usart.cr1().write(|w| {
        w.ue().set_bit();
        w.te().set_bit();
        w.re().set_bit();
        // Not TXEIE yet: QEMU's model raises the line whenever TXE (always
        // set there) and TXEIE are both set; it is on only while bytes wait.
        w.rxneie().set_bit()
    });
}

/// The `BRR` value for 16× oversampling: `USARTDIV = pclk / baud` in 12.4
/// fixed point, rounded to nearest (RM0090 §30.3.4); `pclk_hz` in Hz.
pub const fn brr(pclk_hz: u32, baud: Bd) -> u32 {
    let Bd(baud) = baud;
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

/// The interrupt of one USART: move the received byte from the data
/// register into the receive queue, count what is lost, and send the next
/// byte of the transmit queue (switching `TXEIE` off when it is empty). One
/// byte each way per entry, from one read of the control and status
/// registers: at 500 kBd a byte takes 3 360 core cycles and the line stays
/// raised while another waits, so a second look would only cost register
/// reads. `producer` is `None` only if the interrupt fires before the queue
/// has been handed over; the byte is then counted as dropped (the data
/// register must be read or the interrupt repeats). `rx_room` is the bytes
/// the receive queue holds: when it is full, `RXNEIE` goes off
/// (backpressure, see the module docs). Inlined into each handler: it runs
/// once per byte each way.
#[inline(always)]
pub fn on_interrupt(
    usart: &RegisterBlock,
    producer: Option<&mut Producer<'static>>,
    rx_room: usize,
    tx: Option<&mut Consumer<'static>>,
    stats: &RxStats,
    irq: Interrupt,
) {
    let cr1 = usart.cr1().read();
    // Reading SR then DR clears RXNE and the error flags (ORE, NF, FE, PE).
    let sr = usart.sr().read();
    // With `RXNEIE` off the queue was full: the byte waits in DR until the
    // loop has made room (`resume_rx`); a transmit entry must not take it.
    if cr1.rxneie().bit_is_set() && (sr.rxne().bit_is_set() || sr.ore().bit_is_set()) {
        on_receive(usart, sr.rxne().bit_is_set(), producer, rx_room, stats);
        count_errors(
            sr.ore().bit_is_set(),
            sr.fe().bit_is_set() || sr.nf().bit_is_set() || sr.pe().bit_is_set(),
            stats,
        );
    }
    if cr1.txeie().bit_is_clear() || sr.txe().bit_is_clear() {
        return;
    }
    match tx.and_then(|c| c.dequeue()) {
        Some(b) => {
            usart.dr().write(|w| w.dr().set(u16::from(b)));
        }
        None => {
            usart.cr1().modify(|_, w| w.txeie().clear_bit());
            return;
        }
    }
    // On silicon `TXE` clears with the write and the level interrupt
    // (`TXE` & `TXEIE`) brings the next entry when the shifter takes the
    // byte. QEMU keeps `TXE` set and raises the line only for received
    // bytes, so while `TXE` is still set the interrupt is pended again:
    // under QEMU, as on a board, every byte sent costs one entry, and the
    // cycle estimate (tools/qemu-icount) sees the board's interrupts.
    if usart.sr().read().txe().bit_is_set() {
        cortex_m::peripheral::NVIC::pend(irq);
    }
}

/// Add one to a counter only this interrupt writes (a load and a store: no
/// exclusive-access loop).
fn bump(counter: &AtomicU32) {
    counter.store(
        counter.load(Ordering::Relaxed).wrapping_add(1),
        Ordering::Relaxed,
    );
}

/// Count an overrun (`ORE`) and a framing, noise or parity error.
fn count_errors(overrun: bool, line_error: bool, stats: &RxStats) {
    if overrun {
        bump(&stats.overrun);
    }
    if line_error {
        bump(&stats.line_errors);
    }
}

/// Read the data register (clearing `RXNE` or `ORE`) and queue the byte if
/// one was received (`rxne`).
fn on_receive(
    usart: &RegisterBlock,
    rxne: bool,
    producer: Option<&mut Producer<'static>>,
    room: usize,
    stats: &RxStats,
) {
    let queued = producer.as_deref().map(|p| p.len());
    // The byte that fills the queue: `RXNEIE` off *before* DR is read, so
    // that the next byte, held in DR, never raises the line (QEMU 7.2
    // lowers it only on a DR read: a raised line with the byte left in DR
    // would re-enter this interrupt for ever).
    let fills = rxne && queued.is_some_and(|len| len.saturating_add(1) >= room);
    if fills {
        usart.cr1().modify(|_, w| w.rxneie().clear_bit());
    }
    let byte = usart.dr().read().dr().bits() as u8;
    if !rxne {
        // ORE without a new byte: the DR read above only cleared the flag.
        return;
    }
    match (producer.and_then(|p| p.enqueue(byte).ok()), queued) {
        (Some(()), Some(before)) => {
            bump(&stats.received);
            let len = before.saturating_add(1) as u32;
            if len > stats.peak_queued.load(Ordering::Relaxed) {
                stats.peak_queued.store(len, Ordering::Relaxed);
            }
        }
        _ => bump(&stats.dropped_full),
    }
}

/// Switch the receive interrupt back on if a full queue had switched it off
/// (the caller has just taken bytes out), and pend it for the byte that
/// waits in the data register.
fn resume_rx(usart: &RegisterBlock, irq: Interrupt) {
    critical_section::with(|_| {
        if usart.cr1().read().rxneie().bit_is_clear() {
            usart.cr1().modify(|_, w| w.rxneie().set_bit());
            cortex_m::peripheral::NVIC::pend(irq);
        }
    });
}

/// [`Serial`]'s `read`: waits (asleep) for a byte, takes what is queued up
/// to `buf.len()`, then lets the line go on ([`resume_rx`]). One function
/// for every port (not generic, not inlined): the firmware's one copy.
#[inline(never)]
fn read_into(
    usart: &RegisterBlock,
    rx: &mut Consumer<'static>,
    irq: Interrupt,
    buf: &mut [u8],
) -> usize {
    if buf.is_empty() {
        return 0;
    }
    while !rx.ready() {
        cortex_m::asm::wfi();
    }
    let mut n = 0;
    for slot in buf.iter_mut() {
        match rx.dequeue() {
            Some(b) => *slot = b,
            None => break,
        }
        n += 1;
    }
    resume_rx(usart, irq);
    n
}

/// One USART as a byte stream for the main loop: the consumer end of its
/// receive queue and the producer end of its transmit queue.
///
/// `U` is the owned peripheral (`pac::USART1`, …), which gives access to
/// the registers.
pub struct Serial<U> {
    usart: U,
    rx: Consumer<'static>,
    tx: Producer<'static>,
    stats: &'static RxStats,
    line: Line,
}

/// What a [`Serial`] needs of its USART beyond the registers: its
/// interrupt, the clock of its bus and its line rate.
#[derive(Clone, Copy)]
pub struct Line {
    /// The USART's interrupt (masked while the main loop changes what the
    /// handler shares).
    pub irq: Interrupt,
    /// The peripheral clock of the USART's bus (Hz).
    pub pclk_hz: u32,
    /// The line rate.
    pub baud: Bd,
}

impl<U: Deref<Target = RegisterBlock>> Serial<U> {
    /// Wrap a USART configured at `baud` and its queue ends.
    pub fn new(
        usart: U,
        (rx, tx): (Consumer<'static>, Producer<'static>),
        stats: &'static RxStats,
        line: Line,
    ) -> Self {
        Serial {
            usart,
            rx,
            tx,
            stats,
            line,
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

    /// Room of the transmit queue in bytes.
    pub fn tx_capacity(&self) -> usize {
        self.tx.capacity()
    }

    /// Change the line speed (e.g. after the sensor has acknowledged `20 4x`).
    /// Lets what is queued leave at the old rate first ([`Self::drain`]).
    /// QEMU ignores the rate.
    pub fn set_baud(&mut self, baud: Bd) {
        self.drain();
        self.line.baud = baud;
        write_brr(&self.usart, brr(self.line.pclk_hz, baud));
    }

    /// Wait until the transmit queue is empty and the last byte has left
    /// the shift register (`TC`), asleep between interrupts; bounded: gives
    /// up after twice the time the queued bytes need at the current rate
    /// plus 2 ms (then the rate changes under a byte, which the peer sees
    /// as one bad telegram).
    pub fn drain(&mut self) {
        let bits = (self.tx.len() as u64 + 2) * 10;
        let deadline = crate::clock::now_us()
            + div_u64(2 * bits * 1_000_000, divisor(u64::from(self.line.baud.0)))
            + 2_000;
        let mut queued = self.tx.len();
        while crate::clock::now_us() < deadline {
            let done = critical_section::with(|_| {
                let empty = self.tx.is_empty();
                if !empty {
                    cortex_m::asm::wfi();
                }
                empty
            });
            if done && self.usart.sr().read().tc().bit_is_set() {
                return;
            }
            // Bytes are leaving: not stuck (a 1 KiB queue at 9600 Bd takes 1 s).
            if self.tx.len() < queued {
                crate::fault::feed();
            }
            queued = self.tx.len();
        }
    }

    /// Switch the transmit interrupt on (the queue has bytes) and pend it.
    fn start_tx(&mut self) {
        start_tx(&self.usart, self.line.irq);
    }

    /// Sleep until the transmit queue has room (see [`wait_for_room`]).
    fn wait_for_room(&mut self) {
        wait_for_room(&self.tx);
    }
}

/// Switch the transmit interrupt on (the queue has bytes) and pend the
/// interrupt once: QEMU 7.2 raises a USART's line only for a received byte,
/// not for `TXE` & `TXEIE`; on silicon the pended run just sends the first
/// byte a little earlier.
fn start_tx(usart: &RegisterBlock, irq: Interrupt) {
    critical_section::with(|_| usart.cr1().modify(|_, w| w.txeie().set_bit()));
    cortex_m::peripheral::NVIC::pend(irq);
}

/// Sleep until the transmit queue has room; feeds the watchdog while bytes
/// are still leaving (a line stuck for good ends in its reset).
fn wait_for_room(tx: &Producer<'static>) {
    let mut queued = tx.len();
    while !tx.ready() {
        critical_section::with(|_| {
            if !tx.ready() {
                cortex_m::asm::wfi();
            }
        });
        let now = tx.len();
        if now < queued {
            crate::fault::feed();
        }
        queued = now;
    }
}

/// Queue every byte of `buf`, waiting for room (asleep) whenever the queue
/// is full. One function for every port (not generic, not inlined): the
/// firmware's one copy.
#[inline(never)]
fn queue_all(usart: &RegisterBlock, tx: &mut Producer<'static>, irq: Interrupt, buf: &[u8]) {
    for chunk in buf.chunks(64) {
        for &b in chunk {
            if tx.enqueue(b).is_err() {
                start_tx(usart, irq);
                wait_for_room(tx);
                // Room now (the wait returns only when there is some; one producer).
                let _ = tx.enqueue(b);
            }
        }
        start_tx(usart, irq);
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
    /// there, then returns what is queued, up to `buf.len()`. The
    /// co-processor reads only after `read_ready`, so it never sleeps here.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        Ok(read_into(&self.usart, &mut self.rx, self.line.irq, buf))
    }
}

impl<U: Deref<Target = RegisterBlock>> Write for Serial<U> {
    /// Queues what fits (at least one byte: waits for room if the queue is
    /// full) and returns; the interrupt sends it.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.wait_for_room();
        let mut n = 0;
        for &b in buf {
            if self.tx.enqueue(b).is_err() {
                break;
            }
            n += 1;
        }
        self.start_tx();
        Ok(n)
    }

    /// Queues every byte, waiting for room (asleep) whenever the queue is
    /// full ([`queue_all`]). Overrides the provided method, which has a
    /// panic path for a `write` that returns 0 (this one never does).
    fn write_all(&mut self, buf: &[u8]) -> Result<(), Infallible> {
        queue_all(&self.usart, &mut self.tx, self.line.irq, buf);
        Ok(())
    }

    /// Waits (bounded) until every queued byte has left ([`Serial::drain`]).
    fn flush(&mut self) -> Result<(), Infallible> {
        self.drain();
        Ok(())
    }
}

impl<U: Deref<Target = RegisterBlock>> WriteReady for Serial<U> {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.tx.ready())
    }
}

impl<U: Deref<Target = RegisterBlock>> lms_core::device::coprocessor::WriteRoom for Serial<U> {
    /// The transmit queue's free slots: a `write_all` of at most this many
    /// returns at once (the co-processor writes no more, so the loop never
    /// waits on the host line).
    fn write_room(&mut self) -> Result<usize, Infallible> {
        Ok(tx_room(&self.tx))
    }
}

/// Free slots of a transmit queue (one copy for every port).
#[inline(never)]
fn tx_room(tx: &Producer<'static>) -> usize {
    tx.capacity().saturating_sub(tx.len())
}

/// The next received byte of a port, if one is there (the console).
pub fn try_read<U: Deref<Target = RegisterBlock>>(port: &mut Serial<U>) -> Option<u8> {
    let byte = port.rx.dequeue()?;
    resume_rx(&port.usart, port.line.irq);
    Some(byte)
}
