//! Recovery of the co-processor's sensor link, against the emulator on a
//! line that models the two UARTs' rates (virtual clock, 200 µs steps): a
//! byte sent at one rate and received at another arrives as noise (a
//! pseudo-random byte count and value, as a UART would frame it), so the
//! co-processor only hears the LMS when it has found its rate.
//!
//! Cases: the LMS switched off and on mid-stream (its `90` at 9600 Bd
//! while the co-processor listens at 500 kBd), the co-processor reset
//! mid-stream (the LMS keeps 500 kBd), the sensor cable pulled and put
//! back. Each must stream again within one second of the sensor being back,
//! and every restart returns the UART to 9600 Bd first.
//!
//! What the stand-in cannot show: a real LMS's boot time and answer delays
//! (the emulator answers at once; [`PROBE_GRACE_US`] leaves 150 ms per
//! rate for them) and a real UART's framing of mismatched rates (modelled
//! as noise; the framer's resynchronisation on noise is tested in
//! `faulty_line`).

use lms_core::device::coprocessor::sensor_link::{
    probe_wait_us, search_order, stream_wait_us, PROBE_GRACE_US, STREAM_SILENCE_US,
};
use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
use lms_core::device::emulator::{line_time_us, Emulator, Event as LmsEvent, FnSource, Settings};
use lms_core::telegram::{Baud, Direction, Event, Framer, Handshake, Request, MAX_TELEGRAM_LEN};
use lms_core::test_support::{Port, Rng};
use lms_core::{Unit, ValidParams, Variant};

mod common;

/// Simulated time per step (µs).
const STEP_US: u64 = 200;
/// The bound every recovery must meet (µs).
const ONE_SECOND_US: u64 = 1_000_000;

type Source = FnSource<Box<dyn FnMut(Variant, Unit, &mut [u16]) -> usize>>;

/// A room in mm, as the co-processor's other tests see it.
fn room_source() -> Source {
    FnSource(Box::new(
        |variant: Variant, _units: Unit, out: &mut [u16]| {
            let g = variant.geometry();
            for (j, v) in out.iter_mut().enumerate() {
                let d = common::room_distance_m(f64::from(g.bearing(j)));
                *v = ((d * 1000.0).round() as u32).min(8182) as u16;
            }
            out.len()
        },
    ))
}

/// The LMS, the co-processor, their line and the client's end.
struct Rig {
    lms: Emulator<Source>,
    cop: Box<CoProcessor>,
    sensor: Port,
    host: Port,
    /// The co-processor's sensor UART rate.
    uart: Baud,
    /// Every rate the co-processor switched its sensor UART to, with the time.
    switches: Vec<(u64, Baud)>,
    /// The sensor cable is in.
    connected: bool,
    /// Stream bytes still to be lost before the co-processor reads them,
    /// as a receive queue overflow loses them (and the board reports).
    lose: usize,
    /// `B0`s the LMS completed.
    lms_scans: u32,
    /// The LMS has power.
    powered: bool,
    noise: Rng,
    now: u64,
    /// Scans the co-processor processed, with the time of each poll that did.
    scans: Vec<u64>,
    /// `B0`s the client received, with the time.
    host_b0: Vec<u64>,
    client: Framer,
}

impl Rig {
    /// Both switched on at 0; the client asks for the stream and gets it.
    fn streaming() -> Rig {
        let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT));
        cop.start(0);
        let mut rig = Rig {
            lms: Emulator::new(room_source(), Settings::default(), 0),
            cop,
            sensor: Port::default(),
            host: Port::default(),
            uart: Baud::B9600,
            switches: Vec::new(),
            connected: true,
            lose: 0,
            lms_scans: 0,
            powered: true,
            noise: Rng(7),
            now: 0,
            scans: Vec::new(),
            host_b0: Vec::new(),
            client: Framer::new(Direction::SensorToHost, Handshake::Expected),
        };
        rig.ask_for_stream();
        rig.run(1_500_000);
        assert_eq!(rig.cop.link().step(), Step::Streaming, "first bring-up");
        assert_eq!(rig.uart, Baud::B500000);
        assert!(rig.host_b0.len() > 20, "{} B0s", rig.host_b0.len());
        rig
    }

    /// The client's `20 24`.
    fn ask_for_stream(&mut self) {
        let mut buf = [0u8; 16];
        let n = Request::Continuous.emit(0, &mut buf).unwrap();
        self.host.rx.extend(&buf[..n]);
    }

    /// `bytes` sent at `sent`, as a receiver at `heard` frames them: the
    /// same bytes if the rates agree, else noise (more bytes than sent when
    /// the receiver is faster, fewer when it is slower).
    fn over_line(&mut self, bytes: &[u8], sent: Baud, heard: Baud) -> Vec<u8> {
        if sent == heard {
            return bytes.to_vec();
        }
        let ratio = f64::from(heard.bits_per_second()) / f64::from(sent.bits_per_second());
        let n = (bytes.len() as f64 * ratio * (0.5 + self.noise.unit())).round() as usize;
        (0..n).map(|_| self.noise.next_u64() as u8).collect()
    }

    /// Advance `us` microseconds.
    fn run(&mut self, us: u64) {
        let end = self.now + us;
        let mut buf = [0u8; 4096];
        while self.now < end {
            self.now += STEP_US;
            let to_lms = std::mem::take(&mut self.sensor.tx);
            if self.connected && self.powered {
                let heard = self.over_line(&to_lms, self.uart, self.lms.baud());
                self.lms.receive(self.now, &heard);
            }
            if self.powered {
                loop {
                    let rate = self.lms.baud();
                    let n = self.lms.transmit(self.now, &mut buf);
                    if n == 0 {
                        break;
                    }
                    if self.connected {
                        let heard = self.over_line(&buf[..n], rate, self.uart);
                        let lost = heard.len().min(self.lose);
                        self.lose -= lost;
                        if lost > 0 {
                            self.cop.note_sensor_lost(lost as u32);
                        }
                        self.sensor.rx.extend(&heard[lost..]);
                    }
                }
                while let Some(e) = self.lms.next_event() {
                    if let LmsEvent::ScanSent { .. } = e {
                        self.lms_scans += 1;
                    }
                }
            }
            let outcome = self
                .cop
                .poll(&mut self.sensor, &mut self.host, self.now)
                .unwrap();
            if outcome.scans > 0 {
                self.scans.push(self.now);
            }
            if let Some(b) = outcome.sensor_baud {
                self.uart = b;
                self.switches.push((self.now, b));
            }
            self.read_host();
        }
    }

    /// The client's framer over what the co-processor sent it.
    fn read_host(&mut self) {
        let bytes = std::mem::take(&mut self.host.tx);
        let mut input = &bytes[..];
        loop {
            let fed = self.client.feed(input);
            input = fed.remaining;
            match fed.event {
                Some(Event::Telegram(t)) if t.command() == 0xB0 => self.host_b0.push(self.now),
                None if input.is_empty() => break,
                _ => {}
            }
        }
    }

    /// The first scan the co-processor processed after `t`.
    fn first_scan_after(&self, t: u64) -> Option<u64> {
        self.scans.iter().copied().find(|&s| s > t)
    }

    /// The first `B0` the client got after `t`.
    fn first_b0_after(&self, t: u64) -> Option<u64> {
        self.host_b0.iter().copied().find(|&s| s > t)
    }

    /// The rate switches after `t`.
    fn switches_after(&self, t: u64) -> Vec<Baud> {
        self.switches
            .iter()
            .filter(|(at, _)| *at > t)
            .map(|&(_, b)| b)
            .collect()
    }
}

#[test]
fn the_search_waits_are_what_the_docs_say() {
    let setup = SensorSetup::DEFAULT;
    assert_eq!(
        search_order(setup.baud),
        [Baud::B9600, Baud::B500000, Baud::B38400, Baud::B19200]
    );
    // 19 bytes on the line plus the grace; at the stream's rate a B0 too.
    assert_eq!(
        probe_wait_us(Baud::B9600, setup.baud),
        PROBE_GRACE_US + 19_792
    );
    assert_eq!(
        probe_wait_us(Baud::B500000, setup.baud),
        PROBE_GRACE_US + 380 + line_time_us(MAX_TELEGRAM_LEN, Baud::B500000)
    );
    assert_eq!(line_time_us(MAX_TELEGRAM_LEN, Baud::B500000), 16_360);
    // Two scan periods of 26 667 µs plus 300 ms.
    assert_eq!(stream_wait_us(&setup), 353_334);
    let slow = SensorSetup {
        baud: Baud::B9600,
        ..setup
    };
    assert_eq!(stream_wait_us(&slow), 2_004_168);
}

#[test]
fn lms_power_cycle_mid_stream_recovers_within_a_second() {
    let mut worst = 0;
    // The LMS is off for 0.2 .. 1.6 s: its `90` then falls at every phase
    // of the co-processor's search round (~0.65 s).
    for off_ms in (200..=1_600).step_by(100) {
        let mut rig = Rig::streaming();
        let restarts = rig.cop.link().restarts();
        let cut = rig.now;
        let last_scan = *rig.scans.last().unwrap();
        rig.powered = false;
        rig.run(off_ms * 1000);
        rig.powered = true;
        let on = rig.now;
        rig.lms.power_on(on);
        rig.run(2_000_000);

        // One time-out, the UART back to 9600 first: once the 90's noise
        // has come (within its 30 ms at 9600 Bd) and the stream has been
        // without a good scan for stream_wait_us.
        assert_eq!(rig.cop.link().scan_timeouts(), 1, "off {off_ms} ms");
        assert!(rig.cop.link().restarts() > restarts);
        let after = rig.switches_after(cut);
        assert_eq!(
            after.first(),
            Some(&Baud::B9600),
            "off {off_ms} ms: {after:?}"
        );
        let timeout_at = rig.switches.iter().find(|(t, _)| *t > cut).unwrap().0;
        let due = (last_scan + stream_wait_us(&SensorSetup::DEFAULT)).max(on);
        assert!(
            timeout_at >= due && timeout_at < due + 31_000,
            "off {off_ms} ms: time-out at {timeout_at}, last scan {last_scan}, on at {on}"
        );
        assert_eq!(after.last(), Some(&Baud::B500000), "{after:?}");
        assert_eq!(rig.cop.link().step(), Step::Streaming);

        // Scans again, to the client too (its stream stayed on).
        let back = rig.first_b0_after(on).expect("the client gets scans again");
        assert!(rig.first_scan_after(on).unwrap() <= back);
        let took = back - on;
        assert!(
            took < ONE_SECOND_US,
            "off {off_ms} ms: first B0 {took} µs after the LMS came back"
        );
        worst = worst.max(took);
        assert_eq!(rig.cop.counters().scans_rejected, 0);
    }
    println!("LMS power cycle: the client has scans again at most {worst} µs after the 90");
}

#[test]
fn coprocessor_reset_mid_stream_finds_the_lms_at_500k() {
    let mut rig = Rig::streaming();
    assert_eq!(rig.lms.baud(), Baud::B500000);
    // The MCU resets: a new co-processor, its UART at 9600 Bd; the LMS
    // streams on at 500 kBd.
    let reset = rig.now;
    *rig.cop = CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT);
    rig.cop.start(reset);
    rig.uart = Baud::B9600;
    rig.sensor = Port::default();
    rig.run(300_000);
    // The client, seeing the co-processor's 90, asks for the stream again.
    rig.ask_for_stream();
    rig.run(1_700_000);

    assert_eq!(rig.cop.link().step(), Step::Streaming);
    // 9600 unanswered, then 500 k: found; no restart, no time-out.
    let after = rig.switches_after(reset);
    assert_eq!(after.first(), Some(&Baud::B500000), "{after:?}");
    assert_eq!(rig.cop.link().restarts(), 0);
    assert_eq!(rig.cop.link().scan_timeouts(), 0);
    let first = rig.first_scan_after(reset).expect("scans again");
    assert!(
        first - reset < ONE_SECOND_US,
        "first scan {} µs after the reset",
        first - reset
    );
    println!(
        "co-processor reset: first scan {} µs after it (probe at 9600 unanswered: {} µs)",
        first - reset,
        probe_wait_us(Baud::B9600, Baud::B500000)
    );
    assert!(rig.first_b0_after(reset + 300_000).is_some());
    assert_eq!(rig.cop.counters().scans_rejected, 0);
}

#[test]
fn cable_pulled_and_put_back_streams_again_within_a_second() {
    let mut rig = Rig::streaming();
    let pulled = rig.now;
    let last_scan = *rig.scans.last().unwrap();
    rig.connected = false;
    rig.run(4_000_000);
    // A silent line: the time-out after STREAM_SILENCE_US, then round and
    // round the search; never streaming.
    let during = rig.switches_after(pulled);
    assert_eq!(during.first(), Some(&Baud::B9600));
    let timeout_at = rig.switches.iter().find(|(t, _)| *t > pulled).unwrap().0;
    assert!(
        timeout_at >= last_scan + STREAM_SILENCE_US
            && timeout_at < last_scan + STREAM_SILENCE_US + 2 * STEP_US,
        "time-out at {timeout_at}, last scan {last_scan}"
    );
    assert!(during.len() >= 8, "{during:?}");
    assert_eq!(rig.cop.link().scan_timeouts(), 1);
    assert_ne!(rig.cop.link().step(), Step::Streaming);

    // Back: the LMS still streams at 500 kBd.
    let back = rig.now;
    rig.connected = true;
    rig.run(1_500_000);
    assert_eq!(rig.cop.link().step(), Step::Streaming);
    let first = rig.first_b0_after(back).expect("scans to the client again");
    assert!(
        first - back < ONE_SECOND_US,
        "first B0 {} µs after the cable came back",
        first - back
    );
    println!(
        "cable back: the client has scans again {} µs later",
        first - back
    );
}

#[test]
fn scans_dropped_counts_every_scan_a_queue_overflow_cuts() {
    for seed in 1..=8 {
        let mut rig = Rig::streaming();
        let mut rng = Rng(seed);
        let (sent_before, in_before) = (rig.lms_scans, rig.cop.counters().scans_in);
        assert_eq!(rig.cop.counters().scans_dropped, 0);
        // 40 losses of 1 B .. 3 kB (up to 4 whole scans), at random places,
        // far enough apart for good scans between them (no time-out).
        let mut lost_bytes = 0;
        for _ in 0..40 {
            rig.run(150_000 + rng.below(100_000) as u64);
            rig.lose = 1 + rng.below(3_000);
            lost_bytes += rig.lose;
        }
        rig.run(200_000);
        assert_eq!(rig.lose, 0);
        let c = rig.cop.counters();
        let sent = rig.lms_scans - sent_before;
        let got = c.scans_in - in_before;
        assert!(sent - got > 40, "{sent} sent, {got} in");
        // Every scan the LMS sent is either processed or counted as dropped.
        assert_eq!(
            c.scans_dropped,
            sent - got,
            "seed {seed}, {lost_bytes} B lost: {c:?}"
        );
        assert_eq!(rig.cop.link().scan_timeouts(), 0);
        println!(
            "seed {seed}: {lost_bytes} bytes lost in 40 bursts: {} of {sent} scans dropped, all counted",
            sent - got
        );
    }
}
