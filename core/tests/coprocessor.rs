//! The co-processor end to end in memory: a simulated LMS 2xx (the core's
//! emulator) on the sensor port, a minimal client on the host port. The
//! co-processor must bring the sensor up, pass every scan through, send
//! nothing an LMS would not unless the client opts in (`56 01`), then send
//! features that are bit-identical to running the extractor on the scan the
//! client received; its status and configuration replies tell the truth
//! about the scans, and a client's variant and units are applied on the
//! sensor.

use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
use lms_core::device::emulator::{Emulator, FnSource, OperatingMode, Settings, ValueMode};
use lms_core::telegram::features::{
    Assembled, Counters, FeatureAssembler, CMD_COUNTERS, CMD_FEATURES, REQ_COUNTERS, REQ_FEATURES,
};
use lms_core::telegram::{
    emit_telegram, Baud, Direction, Event, Framer, Handshake, Head, MeasuredView, RangeBits, Reply,
    Request, Telegram, DEFAULT_PASSWORD,
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
    /// Every byte the sensor sent.
    sensor_wire: Vec<u8>,
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
            sensor_wire: Vec::new(),
        }
    }

    /// Advance `us` microseconds in steps of 200 µs.
    fn run(&mut self, us: u64) {
        self.run_in_steps(us, 200);
    }

    /// Advance `us` microseconds in steps of `step` µs (the co-processor
    /// polled once a step: a long step hands it several telegrams at once).
    fn run_in_steps(&mut self, us: u64, step: u64) {
        let end = self.now + us;
        while self.now < end {
            self.now += step;
            let wire = &mut self.sensor_wire;
            common::lms_step(&mut self.lms, &mut self.sensor, self.now, |b| {
                wire.extend(b)
            });
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

    /// Send a raw request, run `us`, return the reply telegram's bytes
    /// after the ACK (the host port is emptied first).
    fn ask(&mut self, command: u8, data: &[u8], us: u64) -> Vec<u8> {
        self.host.tx.clear();
        let mut buf = [0u8; 64];
        let n = emit_telegram(&mut buf, Head::to_sensor(command), data, None).unwrap();
        self.host.rx.extend(&buf[..n]);
        self.run(us);
        let reply = std::mem::take(&mut self.host.tx);
        assert_eq!(reply.first(), Some(&0x06), "ACK first: {reply:02X?}");
        reply[1..].to_vec()
    }

    /// Send `request`, run `us`, return the reply telegram's bytes after
    /// the ACK.
    fn request(&mut self, request: Request, us: u64) -> Vec<u8> {
        let mut buf = [0u8; 64];
        let n = request.emit(0, &mut buf).unwrap();
        let t = Telegram::new_checked(&buf[..n], Direction::HostToSensor).unwrap();
        let (command, data) = (t.command(), t.data().to_vec());
        self.ask(command, &data, us)
    }

    /// Installation mode (`20 00` with the default password, `A0 00`), then
    /// the configuration read (`74` → `F4`), as a client does before `77`.
    fn config_in_installation_mode(&mut self) -> lms_core::telegram::Config {
        let reply = self.request(
            Request::InstallationMode {
                password: DEFAULT_PASSWORD,
            },
            10_000,
        );
        assert_eq!(&reply[4..6], &[0xA0, 0x00]);
        let reply = self.request(Request::ReadConfig, 10_000);
        let t = Telegram::new_checked(&reply[..], Direction::SensorToHost).unwrap();
        let Ok(Reply::Config(c)) = Reply::parse(&t) else {
            panic!("{reply:02X?}")
        };
        c
    }

    /// The host line to 500 kBd (`20 48`), as a client would switch it.
    fn host_500k(&mut self) {
        let reply = self.request(Request::SetBaud(Baud::B500000), 10_000);
        assert_eq!(&reply[..7], &[0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10]);
        assert_eq!(self.cop.host_face().baud(), Baud::B500000);
    }
}

/// The telegrams (command codes) on `wire`, and the ACK count.
fn commands(wire: &[u8]) -> (Vec<u8>, usize) {
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let (mut codes, mut acks) = (Vec::new(), 0);
    let mut input = wire;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Ack) => acks += 1,
            Some(Event::Telegram(t)) => codes.push(t.command()),
            Some(Event::Nak | Event::Long { .. }) => panic!("no NAK expected"),
            None if input.is_empty() => break,
            None => {}
        }
    }
    assert_eq!(framer.stats().crc_errors, 0);
    (codes, acks)
}

#[test]
fn by_default_the_host_line_carries_only_what_an_lms_would() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    bench.send_host(Request::Continuous);
    bench.run(1_000_000);
    let (codes, acks) = commands(&std::mem::take(&mut bench.host.tx));
    assert_eq!(acks, 1);
    assert_eq!(codes[0], 0xA0);
    assert!(codes.len() > 30, "{codes:02X?}");
    assert!(
        codes[1..].iter().all(|&c| c == 0xB0),
        "only B0 after the A0: {codes:02X?}"
    );
    // A 30 01 gets one B0 and nothing after it.
    bench.send_host(Request::OnRequest);
    bench.run(50_000);
    bench.host.tx.clear();
    let reply = bench.request(Request::OneScan, 50_000);
    assert_eq!(commands(&reply).0, vec![0xB0]);
    let c = bench.cop.counters();
    assert_eq!((c.feature_scans_out, c.host_scans_dropped), (0, 0), "{c:?}");
}

#[test]
fn status_and_configuration_replies_tell_the_sensors_units() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    // The sensor was set to mm: F4 says so (units byte [6] = 1), as does B1.
    let reply = bench.request(Request::ReadConfig, 20_000);
    let t = Telegram::new_checked(&reply[..], Direction::SensorToHost).unwrap();
    let Ok(Reply::Config(c)) = Reply::parse(&t) else {
        panic!("{reply:02X?}")
    };
    assert_eq!(c.units(), Some(Unit::Millimetre));
    let reply = bench.request(Request::Status, 300_000);
    let t = Telegram::new_checked(&reply[..], Direction::SensorToHost).unwrap();
    let Ok(Reply::Status(s)) = Reply::parse(&t) else {
        panic!("{reply:02X?}")
    };
    let f = s.fields().unwrap();
    assert_eq!(
        (f.units_code, f.scan_angle_deg, f.resolution_centideg),
        (1, 180, 50)
    );
}

#[test]
fn the_clients_variant_and_units_are_applied_on_the_sensor() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    // 100°/0.25° (not what the co-processor brought up): BB 01 64 00 19 00.
    let reply = bench.request(Request::set_variant(Variant::Fov100Res25), 10_000);
    assert_eq!(&reply[4..10], &[0xBB, 0x01, 0x64, 0x00, 0x19, 0x00]);
    // cm: installation mode, read, write the units byte 0.
    let mut c = bench.config_in_installation_mode();
    c.set_units_code(0);
    let reply = bench.request(Request::WriteConfig(c), 10_000);
    assert_eq!(&reply[4..6], &[0xF7, 0x01]);
    bench.send_host(Request::Continuous);
    bench.run(2_000_000);
    let wire = std::mem::take(&mut bench.host.tx);
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut input = &wire[..];
    let mut scans = 0;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) if t.command() == 0xB0 => {
                let m = MeasuredView::parse(&t).unwrap();
                assert_eq!((m.count(), m.units()), (401, Unit::Centimetre));
                scans += 1;
            }
            Some(Event::Telegram(t)) => assert_eq!(t.command(), 0xA0),
            Some(_) => {}
            None if input.is_empty() => break,
            None => {}
        }
    }
    // 53.3 ms a scan at 0.25°: ~30 in the 2 s, less the sensor's new bring-up.
    assert!(scans >= 20, "{scans}");
    assert_eq!(bench.cop.link().setup().variant, Variant::Fov100Res25);
    assert_eq!(
        bench.lms.variant(),
        Variant::Fov100Res25,
        "the sensor itself"
    );
    assert_eq!(bench.lms.units(), Unit::Centimetre, "the sensor itself");
}

#[test]
fn the_feature_opt_in_request_is_answered_and_refuses_other_values() {
    let mut bench = Bench::new();
    bench.run(1_000_000);
    // 56 01 → D6 01; 56 00 → D6 00; 56 02 → 92 (unknown), state kept.
    let on = bench.ask(REQ_FEATURES, &[1], 10_000);
    assert_eq!(
        &on[..7],
        &[0x02, 0x80, 0x03, 0x00, CMD_FEATURES, 0x01, 0x10]
    );
    assert!(bench.cop.features_on());
    let bad = bench.ask(REQ_FEATURES, &[2], 10_000);
    assert_eq!(bad[4], 0x92);
    assert!(bench.cop.features_on());
    let off = bench.ask(REQ_FEATURES, &[0], 10_000);
    assert_eq!(&off[4..6], &[CMD_FEATURES, 0x00]);
    assert!(!bench.cop.features_on());
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

    // The client opts in to the features, at 500 kBd, and asks for the stream.
    bench.host_500k();
    let on = bench.ask(REQ_FEATURES, &[1], 10_000);
    assert_eq!(on[4], CMD_FEATURES);
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
            Some(Event::Nak | Event::Long { .. }) => {
                panic!("the co-processor never NAKs the client's replies")
            }
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
    let n = emit_telegram(&mut buf, Head::to_sensor(REQ_COUNTERS), &[], None).unwrap();
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
        (
            c.sensor_crc_errors,
            c.scans_dropped,
            c.scans_rejected,
            c.host_scans_dropped
        ),
        (0, 0, 0, 0)
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

#[test]
fn a_variant_chosen_during_the_bring_up_is_applied_after_it() {
    // At every moment of the bring-up (9600 Bd, then the switch to
    // 500 kBd), a client's 3B must end with the sensor streaming that variant.
    for at_ms in (20..400).step_by(20) {
        let mut bench = Bench::new();
        bench.run(at_ms * 1000);
        bench.send_host(Request::set_variant(Variant::Fov100Res100));
        bench.run(3_000_000);
        assert_eq!(bench.cop.link().step(), Step::Streaming, "at {at_ms} ms");
        assert_eq!(bench.lms.variant(), Variant::Fov100Res100, "at {at_ms} ms");
        assert_eq!(bench.lms.baud(), Baud::B500000, "at {at_ms} ms");
    }
}

/// The telegrams on `wire` (STX … CRC), in order.
fn telegrams(wire: &[u8]) -> Vec<Vec<u8>> {
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut out = Vec::new();
    let mut input = wire;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => out.push(t.as_bytes().to_vec()),
            Some(_) => {}
            None if input.is_empty() => break,
            None => {}
        }
    }
    assert_eq!(framer.stats().crc_errors, 0);
    out
}

/// `true` if `telegram` went out of the sensor byte for byte.
fn from_sensor(bench: &Bench, telegram: &[u8]) -> bool {
    bench
        .sensor_wire
        .windows(telegram.len())
        .any(|w| w == telegram)
}

#[test]
fn value_modes_are_applied_on_the_sensor_and_its_telegrams_passed_through() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    bench.send_host(Request::Continuous);
    bench.run(200_000);
    // Mean of 4 scans: the sensor's A0 00, then its B6 telegrams as sent.
    let reply = bench.ask(0x20, &[0x26, 4], 1_000_000);
    let t = telegrams(&reply);
    assert_eq!(&t[0][4..6], &[0xA0, 0x00], "{:02X?}", t[0]);
    assert!(from_sensor(&bench, &t[0]), "the sensor's own A0");
    let mode = ValueMode::Mean { samples: 4 };
    assert_eq!(bench.lms.operating_mode(), OperatingMode::Values(mode));
    let b6: Vec<_> = t[1..].iter().filter(|t| t[4] == 0xB6).collect();
    // 180°/0.5°: 26.7 ms a scan, 107 ms a mean: ~9 in 1 s (B0s of the
    // switch-over aside: no B0 passed after the A0).
    assert!(b6.len() >= 7, "{}", b6.len());
    assert!(t[1..]
        .iter()
        .skip_while(|t| t[4] == 0xB0)
        .all(|t| t[4] == 0xB6));
    assert!(
        b6.iter().all(|t| from_sensor(&bench, t)),
        "passed unchanged"
    );
    // Subrange 10…20 (B7, 11 values); a bad one (first > last): A0 02.
    let reply = bench.ask(0x20, &[0x27, 10, 0, 20, 0], 300_000);
    let t = telegrams(&reply);
    assert_eq!(&t[0][4..6], &[0xA0, 0x00]);
    let b7: Vec<_> = t.iter().filter(|t| t[4] == 0xB7).collect();
    assert!(b7.len() >= 5 && b7.iter().all(|t| from_sensor(&bench, t)));
    let reply = bench.ask(0x20, &[0x27, 20, 0, 10, 0], 100_000);
    let t = telegrams(&reply);
    assert_eq!(&t[0][4..6], &[0xA0, 0x02], "the sensor's refusal");
    // Mean subrange: BF.
    let reply = bench.ask(0x20, &[0x28, 2, 1, 0, 181, 0], 500_000);
    let t = telegrams(&reply);
    assert_eq!(&t[0][4..6], &[0xA0, 0x00]);
    let bf: Vec<_> = t.iter().filter(|t| t[4] == 0xBF).collect();
    assert!(bf.len() >= 5 && bf.iter().all(|t| from_sensor(&bench, t)));
    // Back to 20 24: the sensor streams B0s again, and so does the client.
    let reply = bench.ask(0x20, &[0x24], 500_000);
    assert_eq!(bench.lms.operating_mode(), OperatingMode::Continuous);
    let t = telegrams(&reply);
    let codes: Vec<u8> = t.iter().map(|t| t[4]).collect();
    assert_eq!(codes[0], 0xA0);
    let tail: Vec<u8> = codes.iter().copied().skip_while(|&c| c != 0xB0).collect();
    assert!(
        tail.len() >= 10 && tail.iter().all(|&c| c == 0xB0),
        "{codes:02X?}"
    );
    let c = bench.cop.counters();
    assert_eq!(c.host_scans_dropped, 0, "{c:?}");
}

#[test]
fn features_pause_in_a_value_mode_and_come_back_with_b0s() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    let reply = bench.request(
        Request::Unknown {
            command: REQ_FEATURES,
            data: &[1],
        },
        10_000,
    );
    assert_eq!(reply[4], CMD_FEATURES);
    let reply = bench.ask(0x20, &[0x26, 2], 600_000);
    let codes: Vec<u8> = telegrams(&reply).iter().map(|t| t[4]).collect();
    assert_eq!(codes[0], 0xA0);
    let after: Vec<u8> = codes[1..]
        .iter()
        .copied()
        .skip_while(|&c| c != 0xB6)
        .collect();
    assert!(
        after.len() >= 5 && after.iter().all(|&c| c == 0xB6),
        "{codes:02X?}"
    );
    let reply = bench.ask(0x20, &[0x24], 600_000);
    let codes: Vec<u8> = telegrams(&reply).iter().map(|t| t[4]).collect();
    assert!(
        codes.contains(&0xB0) && codes.contains(&0xD0),
        "{codes:02X?}"
    );
    assert!(!codes.contains(&0xB6), "{codes:02X?}");
}

#[test]
fn sensor_type_is_the_sensors_answer() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    let before = bench.lms.stats().requests;
    let reply = bench.request(Request::SensorType, 50_000);
    assert_eq!(
        bench.lms.stats().requests,
        before + 1,
        "asked of the sensor"
    );
    let t = telegrams(&reply);
    assert_eq!(t[0][4], 0xBA);
    assert!(
        from_sensor(&bench, &t[0]),
        "the sensor's bytes: {:02X?}",
        t[0]
    );
}

#[test]
fn every_byte_of_a_clients_configuration_is_written_to_the_sensor() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    let mut c = bench.config_in_installation_mode();
    // Units unchanged (mm): only other bytes differ.
    assert_eq!(c.units(), Some(Unit::Millimetre));
    c.set_blanking(0x0123);
    c.set_availability(0x02);
    c.set_measuring_mode(0x04);
    assert_ne!(*bench.lms.config(), c);
    let reply = bench.request(Request::WriteConfig(c), 10_000);
    assert_eq!(&reply[4..6], &[0xF7, 0x01]);
    bench.send_host(Request::Continuous);
    bench.run(2_000_000);
    assert_eq!(*bench.lms.config(), c, "the sensor has the client's bytes");
    assert_eq!(bench.cop.link().step(), Step::Streaming);
    let reply = bench.request(Request::ReadConfig, 20_000);
    let reply_tail = telegrams(&reply);
    let t = Telegram::new_checked(&reply_tail[0][..], Direction::SensorToHost).unwrap();
    assert_eq!(Reply::parse(&t).ok(), Some(Reply::Config(c)), "F4 tells it");
}

#[test]
fn requests_the_face_does_not_interpret_are_the_sensors_to_answer() {
    let mut bench = Bench::new();
    // The sensor's status byte differs from the face's (0x10), so a `92`
    // tells whose it is.
    bench.lms.set_settings(Settings {
        status: 0x30,
        ..Settings::default()
    });
    bench.run(20_000);
    assert_ne!(bench.cop.link().step(), Step::Streaming);
    // Before the sensor streams, the face answers itself.
    let early = bench.ask(0x36, &[0x01], 50_000);
    assert_eq!(
        &early[..6],
        &[0x02, 0x80, 0x02, 0x00, 0x92, 0x10],
        "{early:02X?}"
    );
    bench.run(2_000_000);
    assert_eq!(bench.cop.link().step(), Step::Streaming);
    for (command, data) in [(0x36u8, &[0x01u8, 0x02][..]), (0x63, &[]), (0x3F, &[7; 8])] {
        let before = bench.lms.stats().requests;
        let reply = bench.ask(command, data, 100_000);
        assert_eq!(
            bench.lms.stats().requests,
            before + 1,
            "{command:02X} asked of the sensor"
        );
        let t = telegrams(&reply);
        assert_eq!(t.len(), 1, "one reply: {reply:02X?}");
        assert_eq!(&t[0][4..6], &[0x92, 0x30], "the sensor's 92: {:02X?}", t[0]);
        assert!(from_sensor(&bench, &t[0]));
    }
    // Not relayed: a request too long for the relay (9 data bytes), a
    // malformed request of a command the face knows, the co-processor's own.
    for (command, data) in [(0x36u8, &[0u8; 9][..]), (0x31, &[0x01]), (0x56, &[0x02])] {
        let before = bench.lms.stats().requests;
        let reply = bench.ask(command, data, 100_000);
        assert_eq!(bench.lms.stats().requests, before, "{command:02X}");
        assert_eq!(&reply[4..6], &[0x92, 0x10], "the face's 92: {reply:02X?}");
    }
    // The stream goes on after the relayed requests.
    let scans = bench.cop.counters().scans_in;
    bench.run(200_000);
    assert!(bench.cop.counters().scans_in > scans + 5);
}

#[test]
fn a_relayed_reply_goes_out_before_the_stream_it_starts() {
    let mut bench = Bench::new();
    bench.run(2_000_000);
    bench.host_500k();
    // Polled every 20 ms: the sensor's A0 and its first B7s come in one
    // chunk (found under load: a B7 reached the client before the A0).
    bench.host.tx.clear();
    let mut buf = [0u8; 64];
    let n = emit_telegram(&mut buf, Head::to_sensor(0x20), &[0x27, 10, 0, 60, 0], None).unwrap();
    bench.host.rx.extend(&buf[..n]);
    bench.run_in_steps(400_000, 20_000);
    let (codes, acks) = commands(&std::mem::take(&mut bench.host.tx));
    assert_eq!(acks, 1);
    assert!(codes.len() > 3, "{codes:02X?}");
    assert_eq!(codes[0], 0xA0, "{codes:02X?}");
    assert!(codes[1..].iter().all(|&c| c == 0xB7), "{codes:02X?}");
}
