//! Sustained load: the co-processor in memory, fed the sensor's full rate.
//!
//! The core's LMS emulator streams 361-value scans at 500 kBd (one every
//! 26.7 ms, each 14.6 ms on the line: the sensor's own rate) into the
//! co-processor with the default parameters; a client on the
//! host side takes the pass-through and the features. Simulated time, so
//! the run is exact and repeatable.
//!
//! Checked: no scan dropped or skipped anywhere — the LMS sent every scan
//! its mirror produced, and scans sent = `scans_in` = `feature_scans_out`
//! = `B0`s the client got = feature groups it assembled, in order; no CRC
//! error, no resync, nothing rejected; and memory is constant: a counting
//! global allocator sees no allocation inside `poll` (the core has no
//! allocator; the ports here have their capacity reserved before).
//!
//! `sustained_load_short` (300 scans) runs with `cargo test`;
//! `sustained_load_10000_scans` is `#[ignore]`d and run in release by
//! `.ci/robustness.sh`:
//! `cargo test --release -p lms-core --test sustained_load -- --ignored --nocapture`.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
use lms_core::device::emulator::{Emulator, FnSource, Settings};
use lms_core::telegram::features::{Assembled, FeatureAssembler, REQ_FEATURES};
use lms_core::telegram::{
    emit_telegram, Baud, Direction, Event, Framer, Handshake, Head, MeasuredView, Request,
};
use lms_core::test_support::Port;
use lms_core::Unit;
use lms_core::{ValidParams, Variant};

mod common;

// ------------------------------------------------- the counting allocator --

/// Counts allocations made on a thread while its `MEASURING` flag is set.
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static MEASURING: Cell<bool> = const { Cell::new(false) };
}

fn note_allocation() {
    if MEASURING.try_with(Cell::get).unwrap_or(false) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards every call to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

// ------------------------------------------------------------------ ports --

/// Bytes each port buffer holds without allocating (reserved before the run).
const PORT_BYTES: usize = 1 << 16;

// ---------------------------------------------------------------- the run --

/// A room with a box, mm, a little deterministic noise, a few no-echo beams.
fn room(seed: &mut u64, out: &mut [u16]) -> usize {
    let g = Variant::Fov180Res50.geometry();
    for (j, v) in out.iter_mut().enumerate() {
        let phi = f64::from(g.bearing(j));
        let d = common::room_distance_m(phi);
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        let noise = ((*seed >> 40) as f64 / (1u64 << 24) as f64 - 0.5) * 0.01;
        *v = if (*seed >> 20) % 97 == 0 {
            8191
        } else {
            (((d + noise) * 1000.0).round() as u32).min(8182) as u16
        };
    }
    out.len()
}

struct Report {
    scans: u32,
    simulated_s: f64,
    allocations_in_poll: usize,
    polls: u64,
    poll_time: Duration,
    scan_poll_max: Duration,
    sensor_peak: usize,
    host_peak: usize,
}

/// Stream `scans` scans through the co-processor; assert everything above.
fn sustained(scans: u32) -> Report {
    const STEP_US: u64 = 500;
    let mut seed = 0x1234_5678_9ABC_DEF1u64;
    let source = FnSource::new(move |_: Variant, _: Unit, out: &mut [u16]| room(&mut seed, out));
    let mut lms = Emulator::new(source, Settings::default(), 0);
    let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT));
    cop.start(0);
    let (mut sensor, mut host) = (
        Port::with_capacity(PORT_BYTES),
        Port::with_capacity(PORT_BYTES),
    );
    let (mut sensor_peak, mut host_peak) = (0usize, 0usize);
    let mut client = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut asm = FeatureAssembler::new();
    let mut line = [0u8; 4096];
    let mut chunk = [0u8; 4096];
    let mut now = 0u64;

    let mut client_b0 = 0u32;
    let mut groups = 0u32;
    let mut last_counter = 0u32;
    // The client asks for the stream at once: every scan the co-processor
    // takes is then passed on with its features.
    // The client switches its line to 500 kBd, opts in to the features
    // (`56 01`) and asks for the stream at once: every scan the
    // co-processor takes is then passed on with its features.
    let mut buf = [0u8; 16];
    for request in [Request::SetBaud(Baud::B500000), Request::Continuous] {
        let n = request.emit(0, &mut buf).unwrap();
        host.rx.extend(&buf[..n]);
        if request == Request::Continuous {
            break;
        }
        let n = emit_telegram(&mut buf, Head::to_sensor(REQ_FEATURES), &[1], None).unwrap();
        host.rx.extend(&buf[..n]);
    }
    let (mut polls, mut poll_time, mut scan_poll_max) = (0u64, Duration::ZERO, Duration::ZERO);
    // The counter counts (a self-check of the test).
    ALLOCATIONS.store(0, Ordering::Relaxed);
    MEASURING.with(|m| m.set(true));
    drop(std::hint::black_box(vec![0u8; 16]));
    MEASURING.with(|m| m.set(false));
    assert_eq!(
        ALLOCATIONS.swap(0, Ordering::Relaxed),
        1,
        "allocation counter"
    );
    loop {
        now += STEP_US;
        // Co-processor → LMS.
        let n = sensor.pop_tx(&mut chunk);
        lms.receive(now, &chunk[..n]);
        // LMS → co-processor.
        loop {
            let n = lms.transmit(now, &mut line);
            if n == 0 {
                break;
            }
            sensor.rx.extend(&line[..n]);
            sensor_peak = sensor_peak.max(sensor.rx.len());
        }
        while lms.next_event().is_some() {}

        // The co-processor, measured.
        MEASURING.with(|m| m.set(true));
        let t0 = Instant::now();
        let outcome = cop.poll(&mut sensor, &mut host, now).unwrap();
        let dt = t0.elapsed();
        MEASURING.with(|m| m.set(false));
        host_peak = host_peak.max(host.tx.len());
        polls += 1;
        poll_time += dt;
        if outcome.scans > 0 {
            scan_poll_max = scan_poll_max.max(dt);
        }

        // The client.
        loop {
            let n = host.pop_tx(&mut chunk);
            if n == 0 {
                break;
            }
            let mut input = &chunk[..n];
            loop {
                let fed = client.feed(input);
                input = fed.remaining;
                match fed.event {
                    Some(Event::Telegram(t)) => {
                        if t.command() == 0xB0 {
                            client_b0 += 1;
                        }
                        if let Assembled::Complete(summary, features) = asm.push(&t).unwrap() {
                            groups += 1;
                            if last_counter != 0 {
                                assert_eq!(
                                    summary.scan_counter,
                                    last_counter + 1,
                                    "scans in order"
                                );
                            }
                            last_counter = summary.scan_counter;
                            assert!(!features.lines().is_empty(), "the room has lines");
                        }
                    }
                    Some(_) => {}
                    None => break,
                }
            }
        }
        if groups >= scans {
            break;
        }
        assert!(
            now < 1_000_000 + u64::from(scans) * 30_000,
            "stalled: {groups} groups"
        );
    }
    let c = cop.counters();
    let stats = *lms.stats();
    assert_eq!(cop.link().step(), Step::Streaming);
    assert_eq!(stats.scans_skipped, 0, "the LMS never had to skip a scan");
    assert_eq!(stats.scans_sent, c.scans_in, "{c:?}");
    assert_eq!(c.scans_in, c.feature_scans_out, "{c:?}");
    assert_eq!(c.feature_scans_out, client_b0, "{c:?}");
    assert_eq!(client_b0, groups, "every B0 followed by its features");
    assert_eq!(
        (
            c.scans_dropped,
            c.scans_rejected,
            c.sensor_crc_errors,
            c.sensor_resyncs
        ),
        (0, 0, 0, 0),
        "{c:?}"
    );
    assert_eq!(client.stats().crc_errors, 0);
    assert_eq!(asm.discarded(), 0);
    let allocations = ALLOCATIONS.load(Ordering::Relaxed);
    assert_eq!(allocations, 0, "allocations inside poll");
    assert!(
        sensor_peak <= PORT_BYTES && host_peak <= PORT_BYTES,
        "port full: {sensor_peak} / {host_peak} B"
    );
    Report {
        scans: groups,
        simulated_s: now as f64 / 1e6,
        allocations_in_poll: allocations,
        polls,
        poll_time,
        scan_poll_max,
        sensor_peak,
        host_peak,
    }
}

fn print(r: &Report) {
    println!(
        "\nsustained load: {} scans in {:.1} s simulated ({:.2} scans/s), 0 dropped, 0 skipped, \
         0 rejected; {} allocations in {} polls; poll time {:.3} s in total ({:.2} ms per scan, \
         longest poll with a scan {:.2} ms, real-time factor {:.1}); port peaks: sensor rx {} B, host tx {} B; \
         CoProcessor {} B",
        r.scans,
        r.simulated_s,
        f64::from(r.scans) / r.simulated_s,
        r.allocations_in_poll,
        r.polls,
        r.poll_time.as_secs_f64(),
        r.poll_time.as_secs_f64() * 1e3 / f64::from(r.scans),
        r.scan_poll_max.as_secs_f64() * 1e3,
        r.simulated_s / r.poll_time.as_secs_f64(),
        r.sensor_peak,
        r.host_peak,
        std::mem::size_of::<CoProcessor>(),
    );
}

#[test]
fn sustained_load_short() {
    let r = sustained(300);
    print(&r);
}

#[test]
#[ignore = "10 000 scans: run in release (.ci/robustness.sh)"]
fn sustained_load_10000_scans() {
    let r = sustained(10_000);
    print(&r);
    assert!(r.scans >= 10_000);
}

// ------------------------------------------------------ host-line budget --

/// What the paced client of [`host_budget`] saw.
#[derive(Debug)]
struct Budget {
    /// Scans the co-processor took while the client streamed.
    sensor_scans: u32,
    /// `B0`s the client got (whole: framed, CRC checked).
    delivered: u32,
    /// The co-processor's count of scans it did not send (`D5`).
    dropped: u32,
    /// Scans the client missed: gaps in the scan numbers it got, and the
    /// scans after its last one.
    missed: u32,
    /// Longest time from a scan's arrival at the co-processor to its first
    /// byte leaving on the host line (µs).
    max_age_us: u64,
    /// Longest wait of written bytes for the line (µs).
    max_backlog_us: u64,
}

/// The sensor's scans with their number (1000 + k) in the first value.
fn numbered_source() -> impl FnMut(Variant, Unit, &mut [u16]) -> usize {
    let mut seed = 0x00DD_BA11_u64;
    let mut k = 0u16;
    move |_: Variant, _: Unit, out: &mut [u16]| {
        let n = room(&mut seed, out);
        out[0] = 1000 + k;
        k = k.wrapping_add(1);
        n
    }
}

/// The number of every `B0` in `bytes`, with the offset of its first byte.
fn numbered_b0s(framer: &mut Framer, bytes: &[u8]) -> Vec<(u16, usize)> {
    let mut found = Vec::new();
    let mut input = bytes;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) if t.command() == 0xB0 => {
                let len = usize::from(t.length()) + 6;
                let m = MeasuredView::parse(&t).expect("a whole B0");
                let at = (bytes.len() - input.len()).saturating_sub(len);
                found.push((m.word(0).unwrap(), at));
            }
            Some(_) => {}
            None => break,
        }
    }
    found
}

/// The client's requests: its rate, the features, the stream.
fn client_requests(baud: Baud, features: bool) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; 16];
    if baud != Baud::B9600 {
        let n = Request::SetBaud(baud).emit(0, &mut buf).unwrap();
        out.extend_from_slice(&buf[..n]);
    }
    if features {
        let n = emit_telegram(&mut buf, Head::to_sensor(REQ_FEATURES), &[1], None).unwrap();
        out.extend_from_slice(&buf[..n]);
    }
    let n = Request::Continuous.emit(0, &mut buf).unwrap();
    out.extend_from_slice(&buf[..n]);
    out
}

/// The co-processor with its client at `baud` (features on or off) for
/// `seconds` of simulated time after the bring-up; the host line is paced
/// at its real byte rate (a byte leaves 10 bit times after the previous
/// one, or when written if the line is idle).
fn host_budget(baud: Baud, features: bool, seconds: u64) -> Budget {
    const STEP_US: u64 = 500;
    let mut lms = Emulator::new(FnSource::new(numbered_source()), Settings::default(), 0);
    let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT));
    cop.start(0);
    let (mut sensor, mut host) = (Port::default(), Port::default());
    let mut sensor_view = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut client = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut arrived = std::collections::HashMap::new();
    let (mut line, mut chunk) = ([0u8; 4096], [0u8; 8192]);
    let (mut now, mut line_free) = (0u64, 0u64);
    let mut started: Option<(u64, u32)> = None;
    let byte_us = 10_000_000.0 / f64::from(baud.bits_per_second());
    let (mut got, mut max_age, mut max_backlog) = (Vec::new(), 0u64, 0u64);
    loop {
        now += STEP_US;
        if started.is_some_and(|(t, _)| now > t + seconds * 1_000_000) {
            break;
        }
        let n = sensor.pop_tx(&mut chunk);
        lms.receive(now, &chunk[..n]);
        loop {
            let n = lms.transmit(now, &mut line);
            if n == 0 {
                break;
            }
            sensor.rx.extend(&line[..n]);
            for (tag, _) in numbered_b0s(&mut sensor_view, &line[..n]) {
                arrived.insert(tag, now);
            }
        }
        while lms.next_event().is_some() {}
        cop.poll(&mut sensor, &mut host, now).unwrap();
        if started.is_none() && cop.link().step() == Step::Streaming {
            host.rx.extend(client_requests(baud, features));
            started = Some((now, cop.counters().scans_in));
        }
        // Written now: queued behind what is still on the line.
        let n = host.pop_tx(&mut chunk);
        if n == 0 {
            continue;
        }
        let start = line_free.max(now);
        max_backlog = max_backlog.max(start - now);
        line_free = start + (n as f64 * byte_us).ceil() as u64;
        for (tag, at) in numbered_b0s(&mut client, &chunk[..n]) {
            let first_byte = start + (at as f64 * byte_us) as u64;
            max_age = max_age.max(first_byte.saturating_sub(arrived[&tag]));
            got.push(tag);
        }
    }
    let c = cop.counters();
    let (_, scans_before) = started.expect("the client started");
    assert_eq!(client.stats().crc_errors, 0);
    assert_eq!(client.stats().bytes_skipped, 0, "only whole telegrams");
    let (first, last) = (got[0], *arrived.keys().max().unwrap());
    let missed = u32::from(last - first + 1) - got.len() as u32;
    Budget {
        sensor_scans: c.scans_in - scans_before,
        delivered: got.len() as u32,
        dropped: c.host_scans_dropped,
        missed,
        max_age_us: max_age,
        max_backlog_us: max_backlog,
    }
}

/// Assert the budget's promises and print the figures.
fn check_budget(baud: Baud, features: bool, seconds: u64) {
    let b = host_budget(baud, features, seconds);
    let period = lms_core::device::emulator::scan_period_us(Variant::Fov180Res50);
    println!(
        "host line {} Bd, features {}: {} s simulated, {} scans from the sensor, {} delivered \
         ({:.2}/s), {} dropped (counted) = {} missed; oldest scan at its first byte {:.1} ms \
         (period {:.1} ms); longest backlog {:.1} ms",
        baud.bits_per_second(),
        if features { "on" } else { "off" },
        seconds,
        b.sensor_scans,
        b.delivered,
        f64::from(b.delivered) / seconds as f64,
        b.dropped,
        b.missed,
        b.max_age_us as f64 / 1e3,
        period as f64 / 1e3,
        b.max_backlog_us as f64 / 1e3,
    );
    assert_eq!(b.sensor_scans, b.delivered + b.dropped, "{b:?}");
    assert_eq!(
        b.dropped, b.missed,
        "every scan the client missed is counted: {b:?}"
    );
    // One poll step of slack: the co-processor sees a scan at the first
    // poll after its last byte.
    assert!(b.max_age_us <= period + 500, "{b:?}");
    assert!(b.max_backlog_us <= period + 500, "no backlog: {b:?}");
    assert!(b.delivered > 0, "{b:?}");
}

#[test]
fn host_line_budget_38400_for_60_s() {
    check_budget(Baud::B38400, true, 60);
}

#[test]
fn host_line_budget_every_speed() {
    for baud in [Baud::B9600, Baud::B19200, Baud::B38400, Baud::B500000] {
        for features in [false, true] {
            check_budget(baud, features, 10);
        }
    }
}
