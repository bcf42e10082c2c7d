//! The whole co-processor (`CoProcessor::poll`): arbitrary bytes from the
//! sensor and from the host, arbitrary times, queue overflows. Seeds are
//! recorded sessions (bring-up, stream, host requests), so mutations reach
//! the streaming state.
//!
//! Checks: no panic; whatever the sensor line carries, the host line
//! carries only well-formed telegrams (a client framer skips nothing and
//! finds no bad CRC); every `B0` the host gets carries the values of a
//! `B0` the sensor sent (or, before the first scan or for another variant,
//! "not valid" throughout).
#![no_main]

use std::collections::HashSet;

use libfuzzer_sys::fuzz_target;
use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
use lms_core::telegram::{Direction, Framer, Handshake};
use lms_core::Params;
use lms_fuzz::{drain, op, Ev, Input, Port};

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let params = Params::DEFAULT.with_iterations(1 + u16::from(input.u8() % 4));
    let params = params.validate().expect("1..=4 passes are valid");
    let mut cop = CoProcessor::new(params, SensorSetup::DEFAULT);
    let mut now = 0u64;
    cop.start(now);
    let (mut sensor, mut host) = (Port::default(), Port::default());
    let mut client = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut sensor_side = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut sent_b0 = HashSet::new();
    let mut events = Vec::new();
    while !input.is_empty() {
        let code = input.u8();
        match code & 3 {
            op::INPUT => {
                let n = usize::from(input.u16()) % 1024;
                let bytes = input.bytes(n);
                // What the sensor sent, as a framer sees it (for the B0 check).
                let mut seen = Vec::new();
                drain(&mut sensor_side, bytes, &mut seen);
                for e in seen {
                    if let Ev::Telegram(t) = e {
                        if t.get(4) == Some(&0xB0) {
                            sent_b0.insert(values(&t).to_vec());
                        }
                    }
                }
                sensor.rx.extend(bytes);
            }
            op::ADVANCE => {
                let dt = u64::from(input.u16()) * 4;
                now = if code & op::BACKWARDS != 0 {
                    now.saturating_sub(dt)
                } else {
                    now + dt
                };
                let _ = cop.poll(&mut sensor, &mut host, now).unwrap();
                sensor.tx.clear();
                let out = std::mem::take(&mut host.tx);
                drain(&mut client, &out, &mut events);
            }
            op::OUTPUT => {
                let n = usize::from(input.u8());
                host.rx.extend(input.bytes(n));
            }
            _ => cop.note_sensor_overflow(),
        }
    }
    let s = client.stats();
    assert_eq!(
        (s.crc_errors, s.bad_headers, s.oversize, s.bytes_skipped),
        (0, 0, 0, 0),
        "the host line carried a malformed frame: {s:?}"
    );
    for e in &events {
        if let Ev::Telegram(t) = e {
            if t.get(4) == Some(&0xB0) {
                let v = values(t);
                let none = v.chunks(2).all(|w| w == [0xFF, 0x1F]);
                assert!(
                    none || sent_b0.contains(v),
                    "a B0 the sensor never sent reached the host"
                );
            }
        }
    }
    let _ = cop.counters();
});

/// The value words of a `B0` telegram (after the count word, before the
/// status byte and CRC).
fn values(t: &[u8]) -> &[u8] {
    t.get(7..t.len().saturating_sub(3)).unwrap_or_default()
}
