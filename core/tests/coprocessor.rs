//! The co-processor end to end in memory: a simulated LMS 2xx (the core's
//! emulator) on the sensor port, a minimal client on the host port. The
//! co-processor must bring the sensor up, pass every scan through, and send
//! features that are bit-identical to running the extractor on the scan the
//! client received.

use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
use lms_core::device::emulator::{Emulator, FnSource, Settings};
use lms_core::telegram::features::{
    Assembled, Counters, FeatureAssembler, CMD_COUNTERS, REQ_COUNTERS,
};
use lms_core::telegram::{
    emit_telegram, Direction, Event, Framer, Handshake, MeasuredView, RangeBits, Request,
};
use lms_core::test_support::Port;
use lms_core::Unit;
use lms_core::{Extractor, Variant};

mod common;

/// A room: a wall 3 m ahead, side walls 2 m away, a box; mm values with a
/// little deterministic noise and some no-echo beams.
fn room_scan(seed: &mut u64, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
    let g = variant.geometry();
    for (j, v) in out.iter_mut().enumerate() {
        let phi = g.first_bearing as f64 + j as f64 * g.step as f64;
        let d = common::room_distance_m(phi);
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let noise = ((*seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.01;
        let scale = if units == Unit::Millimetre {
            1000.0
        } else {
            100.0
        };
        *v = if (*seed >> 20) % 97 == 0 {
            8191
        } else {
            (((d + noise) * scale).round() as u32).min(8183) as u16
        };
    }
    out.len()
}

/// The simulated sensor's scan source.
type RoomSource = Box<dyn FnMut(Variant, Unit, &mut [u16]) -> usize>;

struct Bench {
    lms: Emulator<FnSource<RoomSource>>,
    cop: CoProcessor,
    sensor: Port,
    host: Port,
    now: u64,
}

impl Bench {
    fn new() -> Self {
        let mut seed = 1u64;
        let source: RoomSource = Box::new(move |v, u, out| room_scan(&mut seed, v, u, out));
        Bench {
            lms: Emulator::new(FnSource(source), Settings::default(), 0),
            cop: {
                let mut cop =
                    CoProcessor::new(lms_core::ValidParams::DEFAULT, SensorSetup::DEFAULT);
                cop.start(0);
                cop
            },
            sensor: Port::default(),
            host: Port::default(),
            now: 0,
        }
    }

    /// Advance `us` microseconds in steps of 200 µs.
    fn run(&mut self, us: u64) {
        let end = self.now + us;
        let mut buf = [0u8; 4096];
        while self.now < end {
            self.now += 200;
            // Co-processor → sensor.
            let to_sensor = std::mem::take(&mut self.sensor.tx);
            self.lms.receive(self.now, &to_sensor);
            loop {
                let n = self.lms.transmit(self.now, &mut buf);
                if n == 0 {
                    break;
                }
                self.sensor.rx.extend(&buf[..n]);
            }
            while self.lms.next_event().is_some() {}
            self.cop
                .poll(&mut self.sensor, &mut self.host, self.now)
                .unwrap();
        }
    }

    fn send_host(&mut self, request: Request) {
        let mut buf = [0u8; 64];
        let n = request.emit(0, &mut buf).unwrap();
        self.host.rx.extend(&buf[..n]);
    }
}

#[test]
fn brings_the_sensor_up_and_streams_bit_identical_features() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    assert_eq!(
        bench.cop.link().step(),
        Step::Streaming,
        "bring-up finished"
    );
    assert!(
        bench.cop.counters().scans_in > 20,
        "{:?}",
        bench.cop.counters()
    );
    // Like an LMS at power-on, the client got the 90 telegram, and nothing
    // else since it asked for nothing.
    let boot = std::mem::take(&mut bench.host.tx);
    assert_eq!(boot.len(), 29, "{boot:02X?}");
    assert_eq!(&boot[..5], &[0x02, 0x80, 0x17, 0x00, 0x90]);

    // The client asks for the stream.
    bench.send_host(Request::Continuous);
    bench.run(1_000_000);
    let wire = std::mem::take(&mut bench.host.tx);

    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut asm = FeatureAssembler::new();
    let mut extractor = Extractor::new();
    let (mut scans, mut checked, mut acks, mut a0) = (0, 0, 0, 0);
    let mut input = &wire[..];
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Ack) => acks += 1,
            Some(Event::Telegram(t)) if t.command() == 0xA0 => a0 += 1,
            Some(Event::Telegram(t)) if t.command() == 0xB0 => {
                let frame = MeasuredView::parse(&t)
                    .unwrap()
                    .to_frame(RangeBits::Bits13)
                    .unwrap();
                extractor.run(&frame, &lms_core::ValidParams::DEFAULT);
                scans += 1;
            }
            Some(Event::Telegram(t)) => {
                if let Assembled::Complete(summary, got) = asm.push(&t).unwrap() {
                    let want = extractor.features();
                    assert_eq!(summary.beams, 361);
                    assert_eq!(got.segments(), want.segments());
                    assert_eq!(got.edges(), want.edges());
                    assert_eq!(got.stats(), want.stats());
                    let bits = |l: &lms_core::Line| {
                        [
                            l.alpha,
                            l.r,
                            l.cov.a,
                            l.cov.b,
                            l.cov.c,
                            l.chi2,
                            l.endpoints[0][0],
                            l.endpoints[1][1],
                        ]
                        .map(f32::to_bits)
                    };
                    assert_eq!(got.lines().len(), want.lines().len());
                    for (a, b) in got.lines().iter().zip(want.lines().iter()) {
                        assert_eq!(bits(a), bits(b));
                    }
                    assert_eq!(got.corners().len(), want.corners().len());
                    checked += 1;
                }
            }
            Some(Event::Nak) => panic!("the co-processor never NAKs the client's replies"),
            None if input.is_empty() => break,
            None => {}
        }
    }
    assert_eq!((acks, a0), (1, 1), "ACK and A0 for the 20 24");
    assert!(
        scans >= 30,
        "{scans} scans in a second at 500 kBd (37.5/s expected)"
    );
    assert_eq!(checked, scans, "every scan is followed by its features");
    assert!(
        !bench.cop.features().lines().is_empty(),
        "the room has lines"
    );
    assert_eq!(framer.stats().crc_errors, 0);

    // Counters on request: ACK + D5.
    bench.send_host(Request::OnRequest);
    bench.run(100_000);
    bench.host.tx.clear();
    let mut buf = [0u8; 16];
    let n = emit_telegram(&mut buf, 0, REQ_COUNTERS, &[], None).unwrap();
    bench.host.rx.extend(&buf[..n]);
    bench.run(10_000);
    let reply = std::mem::take(&mut bench.host.tx);
    assert_eq!(reply[0], 0x06, "ACK");
    let t =
        lms_core::telegram::Telegram::new_checked(&reply[1..], Direction::SensorToHost).unwrap();
    assert_eq!(t.command(), CMD_COUNTERS);
    let c = Counters::decode(t.data()).unwrap();
    assert!(c.scans_in >= 55, "{c:?}");
    assert_eq!(c.feature_scans_out, checked as u32);
    assert_eq!(
        (c.sensor_crc_errors, c.scans_dropped, c.scans_rejected),
        (0, 0, 0)
    );
}

#[test]
fn answers_like_an_lms_and_nak_on_a_bad_checksum() {
    let mut bench = Bench::new();
    bench.run(1_000_000);
    bench.host.tx.clear();
    // Sensor type.
    bench.send_host(Request::SensorType);
    bench.run(5_000);
    let reply = std::mem::take(&mut bench.host.tx);
    assert_eq!(reply[0], 0x06);
    assert!(
        reply.windows(12).any(|w| w == b"LMS200;30106"),
        "{reply:02X?}"
    );
    // A corrupted status request: NAK.
    bench
        .host
        .rx
        .extend([0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x13]);
    bench.run(5_000);
    assert_eq!(std::mem::take(&mut bench.host.tx), vec![0x15]);
    assert_eq!(bench.cop.counters().host_crc_errors, 1);
}
