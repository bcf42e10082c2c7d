//! Every LMS mode through real pseudo-terminals, and nothing wedged:
//! `host-bridge simulate` streams partial scans (`20 2A`) and real-time
//! indices; through `host-bridge coprocessor` (and the firmware under QEMU)
//! a burst of requests leaves the relay working, every bad telegram gets
//! its `NAK`, and an unmodified client after an opted-in one reads plain
//! scans. The client here frames replies with the core's codec (the
//! driver-like clients are `lms_clients.rs`).

use std::fs::File;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lms_core::telegram::features::Counters;
use lms_core::telegram::{
    emit_telegram, Direction, Event, Framer, Handshake, Head, MeasuredView, Telegram,
};
use nix::fcntl::{open, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::stat::Mode;
use nix::sys::termios::{cfmakeraw, cfsetspeed, tcgetattr, tcsetattr, BaudRate, SetArg};

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_host-bridge");

/// A child process stopped (SIGINT, then killed) when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(pid) = i32::try_from(self.0.id()) {
            let pid = nix::unistd::Pid::from_raw(pid);
            let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT);
            let until = Instant::now() + Duration::from_secs(5);
            while Instant::now() < until && matches!(self.0.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A client's end of a pseudo-terminal, framing what comes back.
struct Port {
    fd: OwnedFd,
    framer: Framer,
    /// Bytes read, not yet framed.
    pending: Vec<u8>,
}

/// What came back: telegrams (whole), ACKs and NAKs.
#[derive(Default, Debug)]
struct Got {
    telegrams: Vec<Vec<u8>>,
    acks: usize,
    naks: usize,
}

impl Got {
    fn codes(&self) -> Vec<u8> {
        self.telegrams.iter().map(|t| t[4]).collect()
    }
}

impl Port {
    fn open(path: &Path) -> Port {
        let fd = open(
            path,
            OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK,
            Mode::empty(),
        )
        .unwrap_or_else(|e| panic!("cannot open {}: {e}", path.display()));
        let port = Port {
            fd,
            framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
            pending: Vec::new(),
        };
        port.set_speed(BaudRate::B9600);
        port
    }

    fn set_speed(&self, rate: BaudRate) {
        let mut t = tcgetattr(self.fd.as_fd()).unwrap();
        cfmakeraw(&mut t);
        cfsetspeed(&mut t, rate).unwrap();
        tcsetattr(self.fd.as_fd(), SetArg::TCSANOW, &t).unwrap();
    }

    fn send(&self, bytes: &[u8]) {
        let mut rest = bytes;
        while !rest.is_empty() {
            match nix::unistd::write(&self.fd, rest) {
                Ok(n) => rest = &rest[n..],
                Err(nix::errno::Errno::EAGAIN) => std::thread::sleep(Duration::from_millis(1)),
                Err(e) => panic!("write: {e}"),
            }
        }
    }

    /// Everything that comes within `wait`, framed.
    fn collect(&mut self, wait: Duration) -> Got {
        let until = Instant::now() + wait;
        let mut got = Got::default();
        let mut buf = [0u8; 4096];
        while Instant::now() < until {
            let mut fds = [PollFd::new(self.fd.as_fd(), PollFlags::POLLIN)];
            let _ = poll(&mut fds, PollTimeout::from(20u16));
            loop {
                match nix::unistd::read(&self.fd, &mut buf) {
                    Ok(0) | Err(nix::errno::Errno::EAGAIN) | Err(nix::errno::Errno::EIO) => break,
                    Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                    Err(e) => panic!("read: {e}"),
                }
            }
            let mut input = &self.pending[..];
            loop {
                let fed = self.framer.feed(input);
                input = fed.remaining;
                match fed.event {
                    Some(Event::Ack) => got.acks += 1,
                    Some(Event::Nak) => got.naks += 1,
                    Some(Event::Telegram(t)) => got.telegrams.push(t.as_bytes().to_vec()),
                    Some(Event::Long { .. }) | None => {}
                }
                if fed.event.is_none() && input.is_empty() {
                    break;
                }
            }
            self.pending.clear();
        }
        got
    }

    /// Send `payload` as a request and collect for `wait`.
    fn ask(&mut self, payload: &[u8], wait: Duration) -> Got {
        self.send(&telegram(payload));
        self.collect(wait)
    }

    /// Ask until a telegram with `code` comes back (at most `tries` times,
    /// each waiting `wait`): a chain still coming up.
    fn ask_until(&mut self, payload: &[u8], code: u8, tries: usize, wait: Duration) -> Got {
        for _ in 0..tries {
            let got = self.ask(payload, wait);
            if got.codes().contains(&code) {
                return got;
            }
        }
        panic!("no {code:02X} for {payload:02X?}");
    }
}

/// `payload` (command + data) as a host telegram.
fn telegram(payload: &[u8]) -> Vec<u8> {
    let mut buf = [0u8; 64];
    let n = emit_telegram(&mut buf, Head::to_sensor(payload[0]), &payload[1..], None).unwrap();
    buf[..n].to_vec()
}

fn measured(t: &[u8]) -> MeasuredView<'_> {
    let t = Telegram::new_checked(t, Direction::SensorToHost).unwrap();
    MeasuredView::parse(&t).unwrap()
}

/// Wait until `path` exists (a `--link`).
fn await_path(path: &Path, what: &str) {
    let until = Instant::now() + Duration::from_secs(60);
    while std::fs::symlink_metadata(path).is_err() {
        assert!(Instant::now() < until, "{what}: no {}", path.display());
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn simulate(dir: &Path) -> (Proc, PathBuf) {
    let link = dir.join("sensor");
    let sim = Command::new(BIN)
        .args(["simulate", "--verbose", "--link"])
        .arg(&link)
        .stdout(Stdio::null())
        .stderr(File::create(dir.join("simulate.log")).unwrap())
        .spawn()
        .expect("simulate");
    await_path(&link, "simulate");
    (Proc(sim), link)
}

/// `simulate` and `coprocessor` (with `cop_args`, e.g. `--qemu ELF`); the
/// client's link.
fn chain(dir: &Path, cop_args: &[&str]) -> (Proc, Proc, PathBuf) {
    let (sim, sensor) = simulate(dir);
    let client = dir.join("client");
    let cop = Command::new(BIN)
        .args(["coprocessor", "--status-every", "1"])
        .args(cop_args)
        .arg("--sensor")
        .arg(&sensor)
        .arg("--link")
        .arg(&client)
        .stdout(Stdio::null())
        .stderr(File::create(dir.join("coprocessor.log")).unwrap())
        .spawn()
        .expect("coprocessor");
    await_path(&client, "coprocessor");
    (sim, Proc(cop), client)
}

const SHORT: Duration = Duration::from_millis(400);

/// The client's line to 500 kBd.
fn to_500k(port: &mut Port) {
    let got = port.ask_until(&[0x20, 0x48], 0xA0, 100, SHORT);
    let a0 = got.telegrams.iter().find(|t| t[4] == 0xA0).unwrap();
    assert_eq!(a0[5], 0x00, "20 48 taken");
    port.set_speed(BaudRate::B500000);
}

#[test]
fn simulate_streams_partial_scans_and_real_time_indices() {
    let dir = common::scratch("lms-modes", "simulate");
    let (_sim, link) = simulate(&dir);
    let mut port = Port::open(&link);
    to_500k(&mut port);
    // 100°/0.25°, then the partial scans: offsets 0, 1, 2, 3 × 0.25°.
    let got = port.ask(&[0x3B, 0x64, 0x00, 0x19, 0x00], SHORT);
    assert_eq!(got.telegrams[0][4..6], [0xBB, 0x01]);
    let got = port.ask(&[0x20, 0x2A], Duration::from_millis(600));
    assert_eq!(got.telegrams[0][4..6], [0xA0, 0x00]);
    let offsets: Vec<u8> = got.telegrams[1..]
        .iter()
        .map(|t| measured(t).partial_offset().expect("a partial scan"))
        .collect();
    assert!(offsets.len() >= 16, "{}", offsets.len());
    for w in offsets.windows(2) {
        assert_eq!(w[1], (w[0] + 1) % 4, "{offsets:?}");
    }
    for t in &got.telegrams[1..] {
        let m = measured(t);
        let want = if m.partial_offset() == Some(0) {
            101
        } else {
            100
        };
        assert_eq!(m.count(), want);
    }
    // Real-time indices on (installation mode, 74, 77 with [4] bit 1).
    port.ask(&[0x20, 0x25], SHORT);
    let mut install = vec![0x20, 0x00];
    install.extend_from_slice(b"SICK_LMS");
    port.ask(&install, SHORT);
    let got = port.ask(&[0x74], SHORT);
    let mut write = vec![0x77];
    write.extend_from_slice(&got.telegrams[0][5..39]);
    write[1 + 4] |= 0x02;
    let got = port.ask(&write, SHORT);
    assert_eq!(got.telegrams[0][4..6], [0xF7, 0x01]);
    let got = port.ask(&[0x20, 0x24], Duration::from_millis(600));
    let indices: Vec<u8> = got.telegrams[1..]
        .iter()
        .map(|t| measured(t).real_time_index().expect("an index"))
        .collect();
    assert!(indices.len() >= 8, "{}", indices.len());
    assert!(indices.windows(2).all(|w| w[1] != w[0]), "{indices:?}");
    // Back as it was: no indices (the configuration is kept like EEPROM).
    port.ask(&[0x20, 0x25], SHORT);
    write[1 + 4] &= !0x02;
    port.ask(&install, SHORT);
    port.ask(&write, SHORT);
}

/// The co-processor's status line reports `what` (within 10 s).
fn status_says(dir: &Path, what: &str) {
    let log = dir.join("coprocessor.log");
    let until = Instant::now() + Duration::from_secs(10);
    loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        if text.lines().last().is_some_and(|l| l.contains(what)) {
            return;
        }
        assert!(
            Instant::now() < until,
            "status line without {what:?}: {}",
            text.lines().last().unwrap_or("")
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The co-processor's counters (`55` → `D5`).
fn counters(port: &mut Port, wait: Duration) -> Counters {
    let got = port.ask_until(&[0x55], 0xD5, 5, wait);
    let t = got.telegrams.iter().find(|t| t[4] == 0xD5).unwrap();
    let t = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
    Counters::decode(t.data()).expect("80 bytes of counters")
}

/// A burst of eight `31` and a `36` in one write, 100 bad telegrams in
/// one write, then: the relay works, and every drop is counted (`D5`; and
/// on the status line of a native co-processor, `status`).
fn burst_then_relay(port: &mut Port, dir: &Path, wait: Duration, status: bool) {
    // The sensor streams once a relayed 36 is the sensor's 92 (with its
    // status byte) rather than the face's: wait for a relayed 3A (BA).
    port.ask_until(&[0x3A], 0xBA, 100, wait);
    let before = counters(port, wait);
    let mut burst = Vec::new();
    for _ in 0..8 {
        burst.extend(telegram(&[0x31]));
    }
    burst.extend(telegram(&[0x36]));
    port.send(&burst);
    let got = port.collect(wait * 3);
    let c = counters(port, wait);
    let dropped = c.host_requests_dropped - before.host_requests_dropped;
    // What the client saw agrees with the count: eight B1 and the 36
    // dropped (a pty hands the burst over at once: the queue is full), or
    // the sensor's 92 for it too (the firmware's UART takes it a byte at a
    // time and the face keeps up).
    let mut want = vec![0xB1; 8];
    if dropped == 0 {
        want.push(0x92);
    }
    assert_eq!(got.codes(), want, "{dropped} dropped");
    assert_eq!(got.acks, want.len());
    if status {
        assert_eq!(dropped, 1, "a pty hands the burst over whole");
        status_says(dir, " host_requests_dropped=1 ");
    }
    // 100 bad telegrams in one write: 100 NAKs.
    let mut bad = Vec::new();
    for _ in 0..100 {
        let mut t = telegram(&[0x31]);
        let last = t.len() - 1;
        t[last] ^= 0x55;
        bad.extend(t);
    }
    port.send(&bad);
    let got = port.collect(wait * 2);
    assert_eq!((got.naks, got.telegrams.len()), (100, 0));
    let c = counters(port, wait);
    assert_eq!(c.host_crc_errors, before.host_crc_errors + 100);
    if status {
        status_says(dir, " host_crc_errors=100 ");
    }
    // The relay is not wedged: a value mode is the sensor's (A0 00), 3A too.
    let got = port.ask(&[0x20, 0x26, 0x05], wait);
    assert_eq!(got.telegrams[0][4..6], [0xA0, 0x00], "{:02X?}", got.codes());
    let got = port.ask(&[0x20, 0x25], wait);
    assert!(got.codes().contains(&0xA0));
    port.collect(wait);
    let got = port.ask(&[0x36], wait);
    assert_eq!((got.codes(), got.acks), (vec![0x92], 1));
}

#[test]
fn a_burst_of_requests_leaves_the_coprocessor_relaying() {
    let dir = common::scratch("lms-modes", "burst");
    let (_sim, _cop, link) = chain(&dir, &[]);
    let mut port = Port::open(&link);
    to_500k(&mut port);
    burst_then_relay(&mut port, &dir, SHORT, true);
}

/// The opted-in client, then an unmodified one on the same line.
fn opted_in_then_plain(link: &Path, wait: Duration, scans: Duration) {
    let mut first = Port::open(link);
    to_500k(&mut first);
    let got = first.ask(&[0x56, 0x01], wait);
    assert_eq!(got.codes(), vec![0xD6]);
    let got = first.ask(&[0x20, 0x24], scans);
    assert!(got.codes().contains(&0xD0), "features after the B0s");
    // It leaves without a word; the next client starts as a driver does.
    drop(first);
    let mut next = Port::open(link);
    next.set_speed(BaudRate::B500000);
    let got = next.ask_until(&[0x20, 0x48], 0xA0, 20, wait);
    // Feature telegrams already on the wire when the request came may
    // still arrive before its answer; none follow the answer.
    let answered: Vec<u8> = got.codes().into_iter().skip_while(|&c| c != 0xA0).collect();
    assert!(
        answered.iter().all(|&c| c == 0xA0 || c == 0xB0),
        "{:02X?}",
        got.codes()
    );
    for payload in [&[0x20, 0x25][..], &[0x3A], &[0x31], &[0x74]] {
        let got = next.ask(payload, wait);
        assert!(!got.codes().iter().any(|c| (0xD0..=0xD6).contains(c)));
    }
    let got = next.ask(&[0x20, 0x24], scans);
    let n = got.codes().iter().filter(|&&c| c == 0xB0).count();
    assert!(n >= 10, "{n} scans");
    assert!(
        got.codes().iter().all(|&c| c == 0xA0 || c == 0xB0),
        "{:02X?}",
        got.codes()
    );
    next.ask(&[0x20, 0x25], wait);
}

#[test]
fn an_unmodified_client_after_an_opted_in_one_reads_plain_scans() {
    let dir = common::scratch("lms-modes", "session");
    let (_sim, _cop, link) = chain(&dir, &[]);
    opted_in_then_plain(&link, SHORT, Duration::from_secs(2));
}

#[test]
fn partial_scans_through_the_coprocessor_are_passed_on_and_joined() {
    let dir = common::scratch("lms-modes", "partial");
    let (_sim, _cop, link) = chain(&dir, &[]);
    let mut port = Port::open(&link);
    to_500k(&mut port);
    port.ask_until(&[0x3A], 0xBA, 100, SHORT);
    let got = port.ask(&[0x3B, 0x64, 0x00, 0x19, 0x00], SHORT);
    assert_eq!(got.telegrams[0][4..6], [0xBB, 0x01]);
    // The sensor is brought up again at 100°/0.25°.
    std::thread::sleep(Duration::from_secs(3));
    port.ask(&[0x56, 0x01], SHORT);
    let got = port.ask(&[0x20, 0x2A], Duration::from_secs(2));
    assert_eq!(got.telegrams[0][4..6], [0xA0, 0x00], "{:02X?}", got.codes());
    let partials: Vec<_> = got.telegrams.iter().filter(|t| t[4] == 0xB0).collect();
    assert!(partials.len() >= 16, "{}", partials.len());
    assert!(partials
        .iter()
        .all(|t| measured(t).partial_offset().is_some()));
    // Features follow the scans joined from four partial scans, bit for bit
    // the std build's features of those scans.
    let got = Got {
        telegrams: got.telegrams[1..].to_vec(),
        ..Got::default()
    };
    let groups = joined_features_match(&got, lms_core::Variant::Fov100Res25);
    assert!(groups >= 2, "{groups} feature groups");
    port.ask(&[0x20, 0x25], SHORT);
}

/// The same through the firmware under QEMU (`coprocessor --qemu`).
#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn a_burst_and_the_next_client_through_the_firmware_under_qemu() {
    let elf = common::qemu_firmware();
    let dir = common::scratch("lms-modes", "qemu");
    let (_sim, _cop, link) = chain(&dir, &["--qemu", elf.to_str().unwrap()]);
    let mut port = Port::open(&link);
    // QEMU's serial lines are slower than a pty: longer waits.
    let wait = Duration::from_secs(2);
    port.ask_until(&[0x20, 0x25], 0xA0, 60, wait);
    to_500k(&mut port);
    burst_then_relay(&mut port, &dir, wait, false);
    // It leaves as the common drivers do, the line back at 9600 Bd, where
    // the next client starts.
    let got = port.ask_until(&[0x20, 0x42], 0xA0, 5, wait);
    assert!(got.telegrams.iter().any(|t| t[4..6] == [0xA0, 0x00]));
    drop(port);
    opted_in_then_plain(&link, wait, Duration::from_secs(6));
}

/// The features of every whole scan joined from the partial scans in
/// `got` (in order from partial 0 at `variant`), recomputed by the std
/// build, equal the feature groups that follow them; returns the groups
/// checked.
fn joined_features_match(got: &Got, variant: lms_core::Variant) -> usize {
    use lms_core::device::emulator::{partial_values, turns_per_scan};
    let turns = turns_per_scan(variant) as usize;
    let step = (variant.resolution_centideg() / 25) as u8;
    let (mut words, mut next) = (vec![0u16; variant.beams()], 0);
    features_follow_their_scans(&got.telegrams, |t| {
        let m = measured(t);
        let part = usize::from(m.partial_offset().expect("a partial scan") / step.max(1));
        next = if part == next { next + 1 } else { 0 };
        let (first, stride, _) = partial_values(variant, part as u8);
        for (k, w) in m.words().enumerate() {
            words[first + k * stride] = w;
        }
        if next < turns {
            return None;
        }
        next = 0;
        let v = lms_core::telegram::MeasuredValues::from_raw(&words, m.units(), 0x10);
        Some(
            v.unwrap()
                .to_frame(lms_core::telegram::RangeBits::Bits13)
                .unwrap(),
        )
    })
}

/// A chain through the firmware under QEMU (`coprocessor --qemu`) with a
/// client at 500 kBd once the sensor streams (a relayed `3A` answered),
/// and the wait for a reply on QEMU's slower lines.
fn qemu_streaming(name: &str) -> ((Proc, Proc), Port, Duration) {
    let elf = common::qemu_firmware();
    let dir = common::scratch("lms-modes", name);
    let (sim, cop, link) = chain(&dir, &["--qemu", elf.to_str().unwrap()]);
    let mut port = Port::open(&link);
    let wait = Duration::from_secs(2);
    port.ask_until(&[0x20, 0x25], 0xA0, 60, wait);
    to_500k(&mut port);
    port.ask_until(&[0x3A], 0xBA, 60, wait);
    ((sim, cop), port, wait)
}

/// Partial scans through the firmware under QEMU: passed on, joined, and
/// the features of the joined scans bit-identical to the std build's.
/// 180°/1° (each partial scan is a whole one) and 100°/0.5° (two partial
/// scans a scan; QEMU's slower sensor line drops some, counted).
#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn partial_scans_through_the_firmware_under_qemu() {
    let (_chain, mut port, wait) = qemu_streaming("qemu-partial");
    port.ask(&[0x56, 0x01], wait);
    let mut checked = 0;
    for (request, variant) in [
        (
            [0x3B, 0xB4, 0x00, 0x64, 0x00],
            lms_core::Variant::Fov180Res100,
        ),
        (
            [0x3B, 0x64, 0x00, 0x32, 0x00],
            lms_core::Variant::Fov100Res50,
        ),
    ] {
        let got = port.ask(&request, wait);
        assert!(got.codes().contains(&0xBB));
        // The sensor is brought up again with the variant.
        std::thread::sleep(Duration::from_secs(4));
        port.ask_until(&[0x3A], 0xBA, 30, wait);
        let got = port.ask(&[0x20, 0x2A], Duration::from_secs(8));
        let partials = got.codes().iter().filter(|&&c| c == 0xB0).count();
        assert!(partials >= 4, "{partials} partial scans at {variant:?}");
        let from = got.codes().iter().position(|&c| c == 0xB0).unwrap();
        let got = Got {
            telegrams: got.telegrams[from..].to_vec(),
            ..Got::default()
        };
        checked += joined_features_match(&got, variant);
        port.ask(&[0x20, 0x25], wait);
        port.collect(wait);
    }
    assert!(checked >= 2, "{checked} feature groups checked");
}

/// Real-time indices on (installation mode, `74`, then `77` with byte
/// `[4]` bit 1), features on, streaming: every `B0` reaches the client
/// whole with its index, and the features after it are bit for bit the std
/// build's features of that `B0`'s values; the configuration is put back
/// as it was. Returns the feature groups checked.
fn indexed_scans_and_their_features(port: &mut Port, wait: Duration, stream: Duration) -> usize {
    port.ask(&[0x56, 0x01], wait);
    port.ask(&[0x20, 0x25], wait);
    let mut install = vec![0x20, 0x00];
    install.extend_from_slice(b"SICK_LMS");
    let got = port.ask_until(&install, 0xA0, 5, wait);
    assert!(got.telegrams.iter().any(|t| t[4..6] == [0xA0, 0x00]));
    let got = port.ask_until(&[0x74], 0xF4, 5, wait);
    let f4 = got.telegrams.iter().find(|t| t[4] == 0xF4).unwrap();
    let mut write = vec![0x77];
    write.extend_from_slice(&f4[5..39]);
    write[1 + 4] |= 0x02;
    let got = port.ask_until(&write, 0xF7, 5, wait);
    assert!(got.telegrams.iter().any(|t| t[4..6] == [0xF7, 0x01]));
    // The co-processor brings the sensor up again with the written bytes.
    std::thread::sleep(Duration::from_secs(3));
    let got = port.ask(&[0x20, 0x24], stream);
    let from = got
        .telegrams
        .iter()
        .position(|t| t[4] == 0xB0 && measured(t).real_time_index().is_some())
        .expect("a scan with its real-time index");
    let telegrams = &got.telegrams[from..];
    let indices: Vec<u8> = telegrams
        .iter()
        .filter(|t| t[4] == 0xB0)
        .map(|t| measured(t).real_time_index().expect("every scan indexed"))
        .collect();
    assert!(indices.len() >= 8, "{} indexed scans", indices.len());
    assert!(indices.windows(2).all(|w| w[1] != w[0]), "{indices:?}");
    let checked = features_follow_their_scans(telegrams, |t| {
        Some(
            measured(t)
                .to_frame(lms_core::telegram::RangeBits::Bits13)
                .unwrap(),
        )
    });
    // Back as it was (the configuration is kept like EEPROM).
    port.ask(&[0x20, 0x25], wait);
    port.collect(wait);
    write[1 + 4] &= !0x02;
    port.ask_until(&install, 0xA0, 5, wait);
    port.ask_until(&write, 0xF7, 5, wait);
    checked
}

/// The features of every whole scan in `telegrams` (`whole_scan` makes
/// it from a `B0`, or `None` while it is not whole yet), recomputed by the
/// std build, equal the feature group that follows it; returns the groups
/// checked.
fn features_follow_their_scans(
    telegrams: &[Vec<u8>],
    mut whole_scan: impl FnMut(&[u8]) -> Option<lms_core::Frame>,
) -> usize {
    use lms_core::telegram::features::{Assembled, FeatureAssembler};
    let mut asm = FeatureAssembler::new();
    let mut extractor = lms_core::Extractor::new();
    let (mut want, mut checked) = (None, 0);
    for t in telegrams {
        let tel = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
        if t[4] == 0xB0 {
            if let Some(frame) = whole_scan(t) {
                let features = extractor.run(&frame, &lms_core::ValidParams::DEFAULT);
                want = Some(features.clone());
            }
        } else if let Ok(Assembled::Complete(_, features)) = asm.push(&tel) {
            let want = want.take().expect("features after a whole scan");
            let diffs = host_bridge::verify::differences(features, &want);
            assert!(diffs.is_empty(), "{diffs:?}");
            checked += 1;
        }
    }
    checked
}

#[test]
fn real_time_indices_through_the_coprocessor_with_bit_identical_features() {
    let dir = common::scratch("lms-modes", "indices");
    let (_sim, _cop, link) = chain(&dir, &[]);
    let mut port = Port::open(&link);
    to_500k(&mut port);
    port.ask_until(&[0x3A], 0xBA, 100, SHORT);
    let checked = indexed_scans_and_their_features(&mut port, SHORT, Duration::from_secs(2));
    assert!(checked >= 8, "{checked} feature groups checked");
}

/// The same through the firmware under QEMU.
#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn real_time_indices_through_the_firmware_under_qemu() {
    let (_chain, mut port, wait) = qemu_streaming("qemu-indices");
    let checked = indexed_scans_and_their_features(&mut port, wait, Duration::from_secs(8));
    assert!(checked >= 4, "{checked} feature groups checked");
}
