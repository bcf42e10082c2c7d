//! A byte queue between one interrupt and the main loop: a ring of `N`
//! slots that holds `N − 1` bytes, written at one end ([`Producer`]) and read
//! at the other ([`Consumer`]) without a lock.
//!
//! It stands in for `heapless::spsc` for one measured reason: heapless
//! erases the capacity and wraps its indices with `%`, a division (`UDIV`,
//! up to 12 cycles on the M4) on every byte queued, taken or counted, two
//! or three a byte through the co-processor and 0.03 M cycles a 361-beam
//! scan by the cycle bound (docs/DESIGN.md, Firmware). Here an index wraps by a
//! comparison. Each slot is an `AtomicU8`, so nothing here is `unsafe`: the
//! producer stores the byte, then publishes the new tail (`Release`); the
//! consumer loads the tail (`Acquire`), then the byte; the head the other
//! way round. The API is heapless's, for `u8`.

use core::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

/// The queue's storage: `N` slots (`N ≥ 2`), one always left free.
pub type Ring<const N: usize> = Slots<[AtomicU8; N]>;

/// A ring's indices and slots; `Slots<[AtomicU8]>` is what both ends see
/// (the capacity erased, as in heapless: one pointer and a length).
pub struct Slots<S: ?Sized> {
    /// The next slot to read; written by the consumer only.
    head: AtomicUsize,
    /// The next slot to write; written by the producer only.
    tail: AtomicUsize,
    slots: S,
}

impl<const N: usize> Slots<[AtomicU8; N]> {
    /// An empty ring.
    pub const fn new() -> Self {
        const { assert!(N >= 2, "a ring needs two slots to hold a byte") };
        Slots {
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
            slots: [const { AtomicU8::new(0) }; N],
        }
    }

    /// Its two ends; `&mut` so that each exists once.
    pub fn split(&mut self) -> (Producer<'_>, Consumer<'_>) {
        let ring: &Slots<[AtomicU8]> = self;
        (Producer { ring }, Consumer { ring })
    }
}

impl Slots<[AtomicU8]> {
    /// The slot after `i`.
    fn next(&self, i: usize) -> usize {
        if i + 1 >= self.slots.len() {
            0
        } else {
            i + 1
        }
    }

    /// Bytes queued.
    fn len(&self) -> usize {
        let (head, tail) = (
            self.head.load(Ordering::Relaxed),
            self.tail.load(Ordering::Relaxed),
        );
        if tail >= head {
            tail - head
        } else {
            tail + self.slots.len() - head
        }
    }

    /// Bytes it holds at most.
    fn capacity(&self) -> usize {
        self.slots.len() - 1
    }
}

/// The writing end.
pub struct Producer<'a> {
    ring: &'a Slots<[AtomicU8]>,
}

impl Producer<'_> {
    /// Queue `byte`, or hand it back if the ring is full.
    pub fn enqueue(&mut self, byte: u8) -> Result<(), u8> {
        let tail = self.ring.tail.load(Ordering::Relaxed);
        let next = self.ring.next(tail);
        if next == self.ring.head.load(Ordering::Acquire) {
            return Err(byte);
        }
        if let Some(slot) = self.ring.slots.get(tail) {
            slot.store(byte, Ordering::Relaxed);
        }
        self.ring.tail.store(next, Ordering::Release);
        Ok(())
    }

    /// Whether a byte fits.
    pub fn ready(&self) -> bool {
        self.ring.next(self.ring.tail.load(Ordering::Relaxed))
            != self.ring.head.load(Ordering::Acquire)
    }

    /// Bytes queued.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// Whether no byte is queued.
    pub fn is_empty(&self) -> bool {
        self.ring.head.load(Ordering::Relaxed) == self.ring.tail.load(Ordering::Relaxed)
    }

    /// Bytes the ring holds at most (`N − 1`).
    pub fn capacity(&self) -> usize {
        self.ring.capacity()
    }
}

/// The reading end.
pub struct Consumer<'a> {
    ring: &'a Slots<[AtomicU8]>,
}

impl Consumer<'_> {
    /// The oldest byte, if any.
    pub fn dequeue(&mut self) -> Option<u8> {
        let head = self.ring.head.load(Ordering::Relaxed);
        if head == self.ring.tail.load(Ordering::Acquire) {
            return None;
        }
        let byte = self
            .ring
            .slots
            .get(head)
            .map_or(0, |s| s.load(Ordering::Relaxed));
        self.ring
            .head
            .store(self.ring.next(head), Ordering::Release);
        Some(byte)
    }

    /// Whether a byte waits.
    pub fn ready(&self) -> bool {
        self.ring.head.load(Ordering::Relaxed) != self.ring.tail.load(Ordering::Acquire)
    }

    /// Bytes queued.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// Bytes the ring holds at most (`N − 1`).
    pub fn capacity(&self) -> usize {
        self.ring.capacity()
    }
}
