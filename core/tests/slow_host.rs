//! The host line as a board has it: a UART whose transmit queue holds
//! 1023 bytes and empties at the client's rate (9600 or 38400 Bd), while
//! the LMS streams at 500 kBd and the client has the features on. A `B0`
//! and its features (1.2–1.5 KB) do not fit that queue at once: a blocking
//! write would hold the loop for up to half a second and the sensor queue
//! would overrun.
//!
//! The co-processor must never write more than the port has room for (it
//! would wait), never lose anything silently (every `B0` the client gets
//! is followed by its whole, bit-identical features; every scan is passed
//! on or counted in `host_scans_dropped`), keep replies whole and in order,
//! and its counters must say what went out and what was dropped.

use std::collections::VecDeque;
use std::convert::Infallible;

use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step, WriteRoom};
use lms_core::device::emulator::{line_time_us, Emulator, FnSource, Settings};
use lms_core::telegram::features::{
    Assembled, Counters, FeatureAssembler, CMD_COUNTERS, CMD_FEATURES, REQ_COUNTERS, REQ_FEATURES,
};
use lms_core::telegram::{
    emit_telegram, Baud, Direction, Event, Framer, Handshake, Head, MeasuredView, RangeBits,
};
use lms_core::test_support::Port;
use lms_core::{Extractor, Unit, Variant};

mod common;

/// Slots of the modelled transmit queue (the firmware's 1024-slot queue
/// holds one less).
const QUEUE: usize = 1023;

/// A UART's transmit side: a queue of [`QUEUE`] bytes, one byte leaving
/// every 10 bit times at `baud`; what has left is the client's.
struct SlowLine {
    queue: VecDeque<u8>,
    /// Received from the client (the co-processor reads it).
    rx: VecDeque<u8>,
    /// Bytes on the client's side, in order.
    delivered: Vec<u8>,
    /// Line time not yet spent on a byte (µs).
    credit_us: u64,
    /// Writes that did not fit the queue (a board's write would have waited).
    overflows: usize,
    /// Most bytes ever queued.
    peak: usize,
}

impl SlowLine {
    fn new() -> Self {
        SlowLine {
            queue: VecDeque::new(),
            rx: VecDeque::new(),
            delivered: Vec::new(),
            credit_us: 0,
            overflows: 0,
            peak: 0,
        }
    }

    /// `us` of line time at `baud`: the bytes whose stop bit has passed
    /// reach the client.
    fn pass(&mut self, us: u64, baud: Baud) {
        let per_byte = line_time_us(1, baud);
        self.credit_us += us;
        while self.credit_us >= per_byte {
            match self.queue.pop_front() {
                Some(b) => self.delivered.push(b),
                None => {
                    self.credit_us = 0;
                    break;
                }
            }
            self.credit_us -= per_byte;
        }
    }
}

impl embedded_io::ErrorType for SlowLine {
    type Error = Infallible;
}

impl embedded_io::Read for SlowLine {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, v) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = v;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for SlowLine {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}

impl embedded_io::Write for SlowLine {
    /// Takes what fits; the rest is an overflow (counted: on a board the
    /// loop would have waited for it).
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let room = QUEUE.saturating_sub(self.queue.len());
        if buf.len() > room {
            self.overflows += 1;
        }
        self.queue.extend(buf);
        self.peak = self.peak.max(self.queue.len());
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl WriteRoom for SlowLine {
    fn write_room(&mut self) -> Result<usize, Infallible> {
        Ok(QUEUE.saturating_sub(self.queue.len()))
    }
}

/// The simulated LMS's scans: the test room with a little noise (mm).
type RoomSource = Box<dyn FnMut(Variant, Unit, &mut [u16]) -> usize>;

fn room_source() -> RoomSource {
    let mut seed = 7u64;
    Box::new(move |variant: Variant, _units: Unit, out: &mut [u16]| {
        let g = variant.geometry();
        for (j, v) in out.iter_mut().enumerate() {
            let phi = g.first_bearing as f64 + j as f64 * g.step as f64;
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let noise = ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.01;
            let d = common::room_distance_m(phi) + noise;
            *v = ((d * 1000.0).round() as u32).min(8183) as u16;
        }
        out.len()
    })
}

struct Bench {
    lms: Emulator<FnSource<RoomSource>>,
    cop: CoProcessor,
    sensor: Port,
    host: SlowLine,
    now: u64,
    /// Polls that left feature telegrams waiting for room.
    pumping_polls: usize,
}

impl Bench {
    fn new() -> Self {
        let mut cop = CoProcessor::new(lms_core::ValidParams::DEFAULT, SensorSetup::DEFAULT);
        cop.start(0);
        Bench {
            lms: Emulator::new(FnSource(room_source()), Settings::default(), 0),
            cop,
            sensor: Port::default(),
            host: SlowLine::new(),
            now: 0,
            pumping_polls: 0,
        }
    }

    /// Advance `us`, polling every millisecond (the firmware's SysTick).
    fn run(&mut self, us: u64) {
        const STEP: u64 = 1_000;
        let end = self.now + us;
        while self.now < end {
            self.now += STEP;
            common::lms_step(&mut self.lms, &mut self.sensor, self.now, |_| {});
            self.host.pass(STEP, self.cop.host_face().baud());
            self.cop
                .poll(&mut self.sensor, &mut self.host, self.now)
                .unwrap();
            // The poll took every sensor byte there was: it never waited.
            assert!(self.sensor.rx.is_empty());
            self.pumping_polls += usize::from(self.cop.features_pending());
        }
    }

    /// A request from the client (into the co-processor's receive side).
    fn send(&mut self, command: u8, data: &[u8]) {
        let mut buf = [0u8; 128];
        let n = emit_telegram(&mut buf, Head::to_sensor(command), data, None).unwrap();
        self.host.rx.extend(&buf[..n]);
    }

    /// Let the host line empty (the sensor keeps streaming).
    fn settle(&mut self) {
        for _ in 0..20 {
            self.run(500_000);
            if !self.cop.features_pending() && self.host.queue.is_empty() {
                return;
            }
        }
        panic!("the host line never emptied");
    }
}

/// What the client saw: telegram commands in order, and the `B0`s each
/// with the features that followed it.
struct Seen {
    commands: Vec<u8>,
    /// Scans whose complete features followed their `B0`, bit-identical.
    checked: usize,
    b0s: usize,
    counters: Option<Counters>,
}

/// Parse the client's bytes: every feature set must follow its `B0` whole
/// and equal the extractor's result on that `B0`.
fn client_view(wire: &[u8]) -> Seen {
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut asm = FeatureAssembler::new();
    let mut extractor = Extractor::new();
    let mut seen = Seen {
        commands: Vec::new(),
        checked: 0,
        b0s: 0,
        counters: None,
    };
    let mut awaiting = false;
    let mut input = wire;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        let t = match fed.event {
            Some(Event::Telegram(t)) => t,
            Some(Event::Ack) => {
                seen.commands.push(0x06);
                continue;
            }
            Some(Event::Nak | Event::Long { .. }) => panic!("no NAK"),
            None if input.is_empty() => break,
            None => continue,
        };
        seen.commands.push(t.command());
        match t.command() {
            0xB0 => {
                assert!(!awaiting, "a B0 before the last one's features ended");
                let frame = MeasuredView::parse(&t)
                    .unwrap()
                    .to_frame(RangeBits::Bits13)
                    .unwrap();
                extractor.run(&frame, &lms_core::ValidParams::DEFAULT);
                seen.b0s += 1;
                awaiting = true;
            }
            CMD_COUNTERS => {
                assert!(!awaiting, "a reply inside a scan's features");
                seen.counters = Some(Counters::decode(t.data()).unwrap());
            }
            0xD0..=0xD4 => {
                assert!(awaiting, "features without their B0");
                if let Assembled::Complete(_, got) = asm.push(&t).unwrap() {
                    let want = extractor.features();
                    assert_eq!(got.segments(), want.segments());
                    assert_eq!(got.edges(), want.edges());
                    assert_eq!(got.stats(), want.stats());
                    assert_eq!(got.lines().len(), want.lines().len());
                    for (a, b) in got.lines().iter().zip(want.lines()) {
                        assert_eq!(a.alpha.to_bits(), b.alpha.to_bits());
                        assert_eq!(a.r.to_bits(), b.r.to_bits());
                        assert_eq!(a.cov.c.to_bits(), b.cov.c.to_bits());
                    }
                    assert_eq!(got.corners().len(), want.corners().len());
                    seen.checked += 1;
                    awaiting = false;
                }
            }
            _ => assert!(!awaiting, "a reply inside a scan's features"),
        }
    }
    seen
}

/// At `baud` with features on: stream `seconds`, ask for the counters in
/// the middle of a scan's features, and account for every scan.
fn stream_over_a_slow_line(baud: Baud, seconds: u64) {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    assert_eq!(bench.cop.link().step(), Step::Streaming);
    if baud != Baud::B9600 {
        bench.send(0x20, &[baud.mode_byte()]);
        bench.run(100_000);
        assert_eq!(bench.cop.host_face().baud(), baud);
    }
    bench.send(REQ_FEATURES, &[1]);
    bench.send(0x20, &[0x24]);
    bench.run(500_000);
    let start = bench.cop.counters();
    bench.run(seconds * 1_000_000);
    // A request while features wait for room: its reply comes after them.
    for _ in 0..2_000 {
        if bench.cop.features_pending() {
            break;
        }
        bench.run(1_000);
    }
    assert!(
        bench.cop.features_pending(),
        "features never waited for room"
    );
    bench.send(REQ_COUNTERS, &[]);
    bench.run(3_000_000);
    bench.send(0x20, &[0x25]);
    bench.settle();
    let end = bench.cop.counters();

    let seen = client_view(&bench.host.delivered);
    assert_eq!(bench.host.overflows, 0, "a write that would have waited");
    assert!(bench.host.peak <= QUEUE);
    assert!(
        bench.pumping_polls > 100,
        "features waited for room in {} polls: the line is not slow",
        bench.pumping_polls
    );
    // Replies whole and in order: ACK + power-on 90 is first, the 20 24's
    // ACK + A0 comes before the first B0, the 55's ACK + D5 once.
    let first_b0 = seen.commands.iter().position(|&c| c == 0xB0).unwrap();
    assert!(seen.commands[..first_b0].ends_with(&[0x06, 0xA0]));
    assert!(seen.commands[..first_b0].contains(&CMD_FEATURES));
    let c = seen.counters.expect("the counters reply came");
    // Every B0 the client got was followed by its whole features.
    assert_eq!(seen.checked, seen.b0s, "{baud:?}");
    assert_eq!(end.scans_out as usize, seen.b0s);
    assert_eq!(end.feature_scans_out as usize, seen.checked);
    assert!(c.feature_scans_out <= end.feature_scans_out);
    // Every scan that came while streaming went out or was counted.
    let taken = end.scans_in - start.scans_in;
    let out = end.scans_out - start.scans_out;
    let dropped = end.host_scans_dropped - start.host_scans_dropped;
    assert!(out >= 1 && dropped > out, "{out} out, {dropped} dropped");
    // The last scans after the 20 25 are neither (the client stopped).
    let after_stop = taken - out - dropped;
    assert!(after_stop < 40, "{taken} in, {out} out, {dropped} dropped");
    assert_eq!(
        (
            end.scans_rejected,
            end.scans_other_setting,
            end.scans_dropped
        ),
        (0, 0, 0)
    );
    eprintln!(
        "{baud:?}, while streaming: {taken} scans in, {out} out, {dropped} dropped (counted); \
         in all {} B0s with their {} feature sets; {} polls with features waiting; queue peak {} B",
        seen.b0s, seen.checked, bench.pumping_polls, bench.host.peak
    );
}

#[test]
fn features_at_9600_bd_never_block_the_loop_and_nothing_is_lost_silently() {
    stream_over_a_slow_line(Baud::B9600, 6);
}

#[test]
fn features_at_38400_bd_never_block_the_loop_and_nothing_is_lost_silently() {
    stream_over_a_slow_line(Baud::B38400, 3);
}

#[test]
fn a_request_longer_than_the_face_keeps_is_answered_and_counted() {
    // The face keeps 64 bytes of a request: a longer one with a correct
    // checksum is answered `92`, a corrupted one `NAK` (counted in
    // `host_crc_errors`), and the next request is answered.
    let mut bench = Bench::new();
    bench.run(2_000_000);
    let start = bench.host.delivered.len();
    let data = [0x5Au8; 100];
    bench.send(0x77, &data);
    bench.run(100_000);
    let mut buf = [0u8; 128];
    let n = emit_telegram(&mut buf, Head::to_sensor(0x68), &data, None).unwrap();
    buf[80] ^= 0x10;
    bench.host.rx.extend(&buf[..n]);
    bench.send(REQ_COUNTERS, &[]);
    bench.run(300_000);
    let wire = bench.host.delivered[start..].to_vec();
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut got = Vec::new();
    let mut input = &wire[..];
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => got.push(t.command()),
            Some(Event::Ack) => got.push(0x06),
            Some(Event::Nak) => got.push(0x15),
            Some(Event::Long { .. }) => unreachable!(),
            None => break,
        }
    }
    assert_eq!(got, [0x06, 0x92, 0x15, 0x06, CMD_COUNTERS]);
    assert_eq!(bench.cop.counters().host_crc_errors, 1);
    assert_eq!(bench.cop.host_face().stats().requests, 2);
}
