//! Where the emulator's scans come from.

use crate::frame::Variant;
use crate::Unit;

/// Where the scans come from: raw value words for the current variant and
/// units.
pub trait ScanSource {
    /// Write the next scan's value words (range in the low 13 bits, flags
    /// above; error codes 8183…8191, PROTOCOL.md §3) in `units` into `out`,
    /// which is exactly `variant.beams()` long; return how many were
    /// written. Values not written are sent as "not valid" (8191).
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize;

    /// Value word `index` of the scan the next `B0` carries, for an
    /// emulator that streams its `B0`s (a transmit buffer below
    /// [`TX_CAPACITY`](super::TX_CAPACITY)): such a source keeps its scan
    /// (the co-processor's latest) and the emulator reads it word by word
    /// while the telegram goes out, instead of calling
    /// [`next_scan`](ScanSource::next_scan). `None`: "not valid" (8191).
    /// `None` by default.
    fn word(&self, variant: Variant, units: Unit, index: usize) -> Option<u16> {
        let _ = (variant, units, index);
        None
    }

    /// The real-time scan index of the scan [`word`](ScanSource::word)
    /// reads (the co-processor's latest, as its sensor sent it), if the
    /// source knows it; `None` (the default): the emulator counts its own.
    fn real_time_index(&self) -> Option<u8> {
        None
    }

    /// `false` if this source cannot produce `variant` (the sensor then
    /// refuses a `3B` for it with `BB 00`). Every variant by default.
    fn supports(&self, variant: Variant) -> bool {
        let _ = variant;
        true
    }

    /// A command the LMS 2xx does not know (it would answer `92`): the
    /// source may answer it instead by writing a reply's data into `reply`
    /// (at most [`EXTRA_REPLY_CAPACITY`] bytes) and returning the reply's
    /// command code and data length; the emulator sends `ACK` and that
    /// reply. `None` (the default) keeps the `92`. The co-processor uses it
    /// for its counters request.
    fn extra_command(&mut self, command: u8, data: &[u8], reply: &mut [u8]) -> Option<(u8, usize)> {
        let _ = (command, data, reply);
        None
    }

    /// A request (`command`, `data`) the sensor behind this source is to
    /// answer (the co-processor's face relays it): `true` takes it; the
    /// emulator sends `ACK` at once and then the telegram
    /// [`relayed_reply`](ScanSource::relayed_reply) gives. `false` (the
    /// default) answers it here.
    fn relay(&mut self, command: u8, data: &[u8]) -> bool {
        let _ = (command, data);
        false
    }

    /// The relayed request's reply, whole (`STX` … `CRC`), written into
    /// `out`: `Some(n)` bytes (`Some(0)`: none will come, send nothing),
    /// `None`: not yet (the replies behind it wait, as at a real LMS).
    fn relayed_reply(&mut self, out: &mut [u8]) -> Option<usize> {
        let _ = out;
        Some(0)
    }

    /// The request the source took with [`relay`](ScanSource::relay) will
    /// not be answered (the emulator powered on again and dropped its
    /// queue): let it go, so that the next one can be taken.
    fn relay_dropped(&mut self) {}

    /// A new client session begins (a rate request `20 4x`, a reset `10`,
    /// power-on): whatever the last client switched on for itself ends.
    fn new_session(&mut self) {}
}

/// Largest reply data a [`ScanSource::extra_command`] may write.
pub const EXTRA_REPLY_CAPACITY: usize = 80;

/// A [`ScanSource`] from a closure `(variant, units, out) -> written`.
#[derive(Clone, Copy, Debug)]
pub struct FnSource<F>(pub F);

impl<F: FnMut(Variant, Unit, &mut [u16]) -> usize> FnSource<F> {
    /// Wrap a closure (this constructor lets the compiler infer the
    /// closure's argument types).
    pub const fn new(f: F) -> Self {
        FnSource(f)
    }
}

impl<F: FnMut(Variant, Unit, &mut [u16]) -> usize> ScanSource for FnSource<F> {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        (self.0)(variant, units, out)
    }
}
