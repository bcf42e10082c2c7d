//! The co-processor's memory: the size of every part that a firmware
//! `static` holds (`core::mem::size_of`, bytes), printed with
//! `cargo test -p lms-core --test memory -- --nocapture` and held under a
//! bound, so that a buffer added by mistake fails here before it fails the
//! firmware's RAM budget.

use lms_core::device::client::Client;
use lms_core::device::coprocessor::{CoProcessor, LatestScan, SensorLink};
use lms_core::device::emulator::{Emulator, MIN_TX_CAPACITY, REQUEST_CAPACITY, TX_CAPACITY};
use lms_core::telegram::Framer;
use lms_core::{Beam, Extractor, Features, Frame};
use std::mem::size_of;

/// The co-processor's LMS face.
type Face = Emulator<LatestScan, MIN_TX_CAPACITY>;

#[test]
fn coprocessor_parts_sizes() {
    let parts = [
        ("CoProcessor", size_of::<CoProcessor>()),
        ("  SensorLink", size_of::<SensorLink>()),
        ("    Client", size_of::<Client>()),
        ("      Framer", size_of::<Framer>()),
        ("  Extractor", size_of::<Extractor>()),
        ("    Features", size_of::<Features>()),
        ("  the LMS face", size_of::<Face>()),
        ("    request framer", size_of::<Framer<REQUEST_CAPACITY>>()),
        ("    LatestScan", size_of::<LatestScan>()),
        ("  Frame", size_of::<Frame>()),
    ];
    for (name, bytes) in parts {
        println!("{name:<24} {bytes:>6} B");
    }
    // The extractor: its features and the smoothed ranges (public
    // outputs, f32 each), a two-level bearing table of 336 B (it held two
    // full tables, 3 208 B) and a 52-byte bitset of usable windows (it
    // held 399 bools), and little more. No `D`: the last pass's `D` is
    // segmented as the pass computes it (it held 399 f32, 1 596 B; a tool
    // keeps `D` in a `Trace`).
    let bearings = size_of::<lms_core::pipeline::bearings::TwoLevelBearings>();
    assert_eq!(bearings, 336);
    let outputs = size_of::<Features>() + 4 * lms_core::MAX_BEAMS;
    assert!(size_of::<Extractor>() <= outputs + bearings + 52 + 32);
    assert!(size_of::<lms_core::Trace>() >= 4 * (lms_core::MAX_BEAMS - 2));
    // The edge points are a bitset of 401 bits and two counts (56 B; they
    // were a list of up to 401 u16, 806 B).
    assert!(size_of::<lms_core::Edges>() <= 56);
    // One copy of a scan in the sensor link: the client reads replies and
    // scans in place in its framer (it held a second 818-byte copy).
    assert!(size_of::<Client>() < size_of::<Framer>() + 256);
    // A beam's status is two bytes (`Invalid::OtherCode(u8)`), so a frame
    // is its ranges (4 B a beam) and statuses (2 B a beam) and little more.
    assert_eq!(size_of::<Beam>(), 2);
    assert!(size_of::<Frame>() <= 6 * lms_core::MAX_BEAMS + 32);
    // The host face stages no scan: its source writes a `30 01`'s values
    // straight into the telegram (it held an 802-byte copy); and it keeps
    // no transmit image of it: the `B0` is streamed from the latest scan
    // through a 161-byte buffer (it held an 819-byte one).
    assert_eq!((MIN_TX_CAPACITY, TX_CAPACITY), (161, 819));
    // (Less up to 7 B of alignment padding: the sizes round to 8 B.)
    assert!(size_of::<Emulator<LatestScan>>() >= size_of::<Face>() + 819 - 161 - 7);
    // Its request framer keeps 64 bytes of a request (it held 818): a
    // longer one's CRC is checked as it passes.
    assert_eq!(REQUEST_CAPACITY, 64);
    assert!(size_of::<Framer<REQUEST_CAPACITY>>() <= REQUEST_CAPACITY + 80);
    assert!(size_of::<Framer>() <= lms_core::telegram::MAX_TELEGRAM_LEN + 80);
    let request_framer = size_of::<Framer<REQUEST_CAPACITY>>();
    assert!(size_of::<Face>() < size_of::<LatestScan>() + request_framer + 161 + 1_400);
    // The whole co-processor (x86-64 layout; on the MCU a little smaller):
    // its extractor, the face with the latest scan, the sensor link's
    // framer, two copies of the parameters and counters, and its typed
    // state. docs/DESIGN.md (memory) gives how each part was made small.
    assert!(
        size_of::<CoProcessor>() <= 13_696,
        "{}",
        size_of::<CoProcessor>()
    );
}
