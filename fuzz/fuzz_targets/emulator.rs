//! The LMS emulator fed arbitrary host bytes at arbitrary times (forwards,
//! backwards, huge jumps), its output taken in buffers of any size, its
//! events drained or left to overflow, power-cycled at any moment; scans
//! from a source with error codes, flag bits and short scans.
//!
//! Checks: no panic; everything it sends is well formed: a host-side framer
//! fed its output finds only complete telegrams with correct CRCs and
//! ACK/NAK bytes — nothing skipped, no bad header — unless a power cycle
//! cut a frame short.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::device::emulator::{Emulator, FnSource, Settings};
use lms_core::telegram::{Direction, Framer, Handshake};
use lms_core::Variant;
use lms_fuzz::{drain, op, pattern_words, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let seed = input.u8();
    let setup = input.u8();
    let mut scan = 0u32;
    let source = FnSource::new(move |_v: Variant, _u, out: &mut [u16]| {
        scan = scan.wrapping_add(1);
        pattern_words(seed, scan, out)
    });
    let settings = Settings {
        address: setup & 0x7F,
        variant: Variant::ALL[usize::from(setup % 5)],
        external_scans: setup & 0x80 != 0,
        ..Settings::DEFAULT
    };
    let mut now = u64::from(input.u16());
    let mut lms = Emulator::new(source, settings, now);
    let mut host = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut events = Vec::new();
    let mut cut = false;
    while !input.is_empty() {
        let code = input.u8();
        match code & 3 {
            op::INPUT => {
                let n = usize::from(input.u8());
                lms.receive(now, input.bytes(n));
            }
            op::ADVANCE => {
                let dt = u64::from(input.u16()) * 4;
                now = if code & op::BACKWARDS != 0 {
                    now.saturating_sub(dt)
                } else if code & 0x40 != 0 {
                    now.saturating_add(dt << 20) // a long silence
                } else {
                    now + dt
                };
            }
            op::OUTPUT => {
                let mut out = vec![0u8; (usize::from(input.u8()) + 1) * 8];
                let n = lms.transmit(now, &mut out);
                assert!(n <= out.len());
                drain(&mut host, &out[..n], &mut events);
            }
            _ => {
                if code & op::POWER_ON != 0 {
                    cut |= !lms.line_idle();
                    lms.power_on(now);
                } else {
                    while lms.next_event().is_some() {}
                }
            }
        }
        let _ = (lms.next_wakeup_us(), lms.status_fields(), lms.streaming());
    }
    let s = host.stats();
    if !cut {
        assert_eq!(
            (s.crc_errors, s.bad_headers, s.oversize, s.bytes_skipped),
            (0, 0, 0, 0),
            "the emulator sent a malformed frame: {s:?}"
        );
    }
});
