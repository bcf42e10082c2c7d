//! A second, independent LMS 2xx client against `host-bridge simulate`.
//!
//! Everything protocol-related here is written from PROTOCOL.md alone — its
//! own CRC (§1), its own telegram builder and stream parser — and uses
//! neither `lms_core::telegram` nor any `host_bridge` code: it checks the
//! simulator the way an unmodified client would. The pseudo-terminal is
//! opened like a serial port (raw termios, the client's own line speed).
//!
//! The main test runs the start-up sequence of PROTOCOL.md §5: baud probing
//! with `20 4x`, `20 25`, `3A`, `31`, `74`, installation mode and `77`,
//! 38400 and 500000 Bd, `3B` 180°/0.5°, `20 24` and the `B0` stream, a
//! wrong line speed in the middle of the stream, `20 25`, back to 9600 Bd.

use std::cell::RefCell;
use std::fs::File;
use std::io::Read;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use nix::fcntl::{open, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::stat::Mode;
use nix::sys::termios::{cfmakeraw, cfsetspeed, tcflush, tcgetattr, tcsetattr, BaudRate};
use nix::sys::termios::{FlushArg, SetArg};

const BIN: &str = env!("CARGO_BIN_EXE_host-bridge");

// ---------------------------------------------------------------------------
// The protocol, from PROTOCOL.md §1 only.

const STX: u8 = 0x02;
const ACK: u8 = 0x06;
const NAK: u8 = 0x15;

/// The LMS checksum of §1: shift left (feeding back 0x8005 on a carry),
/// then xor in the byte and the previous byte.
fn lms_crc(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    let mut prev: u8 = 0;
    for &b in bytes {
        crc = if crc & 0x8000 != 0 {
            ((crc & 0x7FFF) << 1) ^ 0x8005
        } else {
            crc << 1
        };
        crc ^= u16::from(b) | (u16::from(prev) << 8);
        prev = b;
    }
    crc
}

/// A host → sensor telegram to address 0: `02 00 LEN CMD DATA CRC`.
fn telegram(payload: &[u8]) -> Vec<u8> {
    let len = payload.len() as u16;
    let mut t = vec![STX, 0x00, len as u8, (len >> 8) as u8];
    t.extend_from_slice(payload);
    let crc = lms_crc(&t);
    t.push(crc as u8);
    t.push((crc >> 8) as u8);
    t
}

/// What a client finds in the sensor's byte stream.
#[derive(Clone, Debug, PartialEq)]
enum Item {
    Ack,
    Nak,
    /// A complete telegram from address 0x80 with a correct CRC: its
    /// payload, `CMD … STATUS`.
    Telegram(Vec<u8>),
}

/// Parse a sensor → host byte stream: handshake bytes between telegrams,
/// telegrams starting `02 80` with a correct CRC; everything else is
/// skipped and counted. A telegram cut off at the end is left out. Each
/// item comes with the offset just after it.
fn parse_with_ends(bytes: &[u8]) -> (Vec<(Item, usize)>, usize) {
    let mut items = Vec::new();
    let mut skipped = 0;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            ACK => {
                i += 1;
                items.push((Item::Ack, i));
                continue;
            }
            NAK => {
                i += 1;
                items.push((Item::Nak, i));
                continue;
            }
            STX if bytes.get(i + 1) == Some(&0x80) && i + 4 <= bytes.len() => {
                let len = usize::from(bytes[i + 2]) | usize::from(bytes[i + 3]) << 8;
                let total = 4 + len + 2;
                if (2..=812).contains(&len) {
                    if i + total > bytes.len() {
                        break; // still arriving
                    }
                    let t = &bytes[i..i + total];
                    let crc = u16::from(t[total - 2]) | u16::from(t[total - 1]) << 8;
                    if crc == lms_crc(&t[..total - 2]) {
                        i += total;
                        items.push((Item::Telegram(t[4..4 + len].to_vec()), i));
                        continue;
                    }
                }
            }
            _ => {}
        }
        skipped += 1;
        i += 1;
    }
    (items, skipped)
}

/// [`parse_with_ends`] without the offsets.
fn parse(bytes: &[u8]) -> (Vec<Item>, usize) {
    let (items, skipped) = parse_with_ends(bytes);
    (items.into_iter().map(|(it, _)| it).collect(), skipped)
}

fn telegrams(items: &[Item]) -> Vec<&Vec<u8>> {
    items
        .iter()
        .filter_map(|it| match it {
            Item::Telegram(p) => Some(p),
            _ => None,
        })
        .collect()
}

fn u16_at(p: &[u8], at: usize) -> u16 {
    u16::from(p[at]) | u16::from(p[at + 1]) << 8
}

// ---------------------------------------------------------------------------
// The serial port (the pty's slave side), with nix termios.

/// The client's end of the line, with its receive buffer: bytes read but
/// not yet consumed stay for the next read, as in a real client.
struct Port {
    fd: OwnedFd,
    rx: RefCell<Vec<u8>>,
}

fn termios_rate(bps: u32) -> BaudRate {
    match bps {
        9600 => BaudRate::B9600,
        19200 => BaudRate::B19200,
        38400 => BaudRate::B38400,
        500_000 => BaudRate::B500000,
        other => panic!("no rate {other}"),
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
            rx: RefCell::new(Vec::new()),
        };
        let mut t = tcgetattr(port.fd.as_fd()).unwrap();
        cfmakeraw(&mut t);
        cfsetspeed(&mut t, BaudRate::B9600).unwrap();
        tcsetattr(port.fd.as_fd(), SetArg::TCSANOW, &t).unwrap();
        port
    }

    /// Open and wait until the line is quiet: a client that connects while
    /// the power-on telegram (30 ms at 9600 Bd) is on the line sees its
    /// tail.
    fn open_quiet(path: &Path) -> Port {
        let port = Port::open(path);
        port.read_for(Duration::from_millis(100));
        port
    }

    fn set_speed(&self, bps: u32) {
        let mut t = tcgetattr(self.fd.as_fd()).unwrap();
        cfsetspeed(&mut t, termios_rate(bps)).unwrap();
        tcsetattr(self.fd.as_fd(), SetArg::TCSANOW, &t).unwrap();
    }

    /// Drop everything received so far.
    fn discard_input(&self) {
        tcflush(self.fd.as_fd(), FlushArg::TCIFLUSH).unwrap();
        self.rx.borrow_mut().clear();
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

    /// Receive into the buffer until `done(buffer)` or `timeout`.
    fn fill(&self, timeout: Duration, mut done: impl FnMut(&[u8]) -> bool) {
        let end = Instant::now() + timeout;
        let mut buf = [0u8; 4096];
        while !done(&self.rx.borrow()) {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            let ms = left.as_millis().clamp(1, 50) as u16;
            let mut fds = [PollFd::new(self.fd.as_fd(), PollFlags::POLLIN)];
            let _ = poll(&mut fds, PollTimeout::from(ms));
            loop {
                match nix::unistd::read(&self.fd, &mut buf) {
                    Ok(0) => break,
                    Ok(n) => self.rx.borrow_mut().extend_from_slice(&buf[..n]),
                    Err(nix::errno::Errno::EAGAIN) => break,
                    // The simulator has gone.
                    Err(nix::errno::Errno::EIO) => return,
                    Err(e) => panic!("read: {e}"),
                }
            }
        }
    }

    /// Everything received until `done(bytes)` or `timeout`.
    fn read_until(&self, timeout: Duration, done: impl FnMut(&[u8]) -> bool) -> Vec<u8> {
        self.fill(timeout, done);
        std::mem::take(&mut *self.rx.borrow_mut())
    }

    /// Everything that arrives within `d` (and was waiting before).
    fn read_for(&self, d: Duration) -> Vec<u8> {
        self.read_until(d, |_| false)
    }

    /// Send a request and read until its reply telegram (`cmd | 0x80`) or
    /// a `92` has arrived; returns the items up to and including it (the
    /// bytes after it stay in the buffer).
    fn transact(&self, payload: &[u8]) -> Vec<Item> {
        self.transact_for(payload, payload[0] | 0x80)
    }

    /// [`transact`](Port::transact) for a reply code other than
    /// `cmd | 0x80` (`10` → `91`).
    fn transact_for(&self, payload: &[u8], want: u8) -> Vec<Item> {
        self.send(&telegram(payload));
        let reply_end = |b: &[u8]| {
            parse_with_ends(b)
                .0
                .into_iter()
                .find_map(|(it, end)| match it {
                    Item::Telegram(p) if p[0] == want || p[0] == 0x92 => Some(end),
                    _ => None,
                })
        };
        self.fill(Duration::from_secs(3), |b| reply_end(b).is_some());
        let mut rx = self.rx.borrow_mut();
        let end = reply_end(&rx).unwrap_or(rx.len());
        let head: Vec<u8> = rx.drain(..end).collect();
        parse(&head).0
    }

    /// [`transact`](Port::transact), expecting `ACK` and then the reply
    /// (possibly after telegrams the client did not ask for); returns the
    /// reply's payload.
    fn ask(&self, payload: &[u8]) -> Vec<u8> {
        self.ask_for(payload, payload[0] | 0x80)
    }

    /// [`ask`](Port::ask) for a reply code other than `cmd | 0x80`.
    fn ask_for(&self, payload: &[u8], want: u8) -> Vec<u8> {
        let items = self.transact_for(payload, want);
        let at = items
            .iter()
            .position(|it| matches!(it, Item::Telegram(p) if p[0] == want))
            .unwrap_or_else(|| panic!("no {want:02X} reply to {payload:02X?}: {items:02X?}"));
        assert!(
            at > 0 && items[at - 1] == Item::Ack,
            "no ACK before {want:02X}"
        );
        match &items[at] {
            Item::Telegram(p) => p.clone(),
            _ => unreachable!(),
        }
    }
}

// ---------------------------------------------------------------------------
// The simulator process.

struct Sim {
    child: Child,
    path: PathBuf,
    log: PathBuf,
}

impl Sim {
    fn start(name: &str, args: &[&str]) -> Sim {
        let log =
            std::env::temp_dir().join(format!("host-bridge-sim-{}-{name}.log", std::process::id()));
        let mut child = Command::new(BIN)
            .arg("simulate")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(File::create(&log).unwrap())
            .spawn()
            .expect("cannot start host-bridge simulate");
        // The first line on stdout is the device.
        let mut stdout = child.stdout.take().unwrap();
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        while stdout.read(&mut byte).unwrap() == 1 && byte[0] != b'\n' {
            line.push(byte[0]);
        }
        let path = PathBuf::from(String::from_utf8(line).unwrap());
        assert!(
            path.starts_with("/dev/pts/"),
            "first stdout line: {}",
            path.display()
        );
        Sim { child, path, log }
    }

    fn stderr(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// SIGINT, and the exit status.
    fn interrupt(&mut self) -> ExitStatus {
        Command::new("kill")
            .args(["-s", "INT", &self.child.id().to_string()])
            .status()
            .unwrap();
        self.wait(Duration::from_secs(5))
    }

    fn wait(&mut self, limit: Duration) -> ExitStatus {
        let end = Instant::now() + limit;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(Instant::now() < end, "simulator did not exit");
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

// ---------------------------------------------------------------------------

const SICK_LMS: &[u8; 8] = b"SICK_LMS";

#[test]
fn independent_client_start_up_sequence() {
    let link = std::env::temp_dir().join(format!("host-bridge-lms-{}", std::process::id()));
    let link_arg = link.to_str().unwrap().to_string();
    let mut sim = Sim::start(
        "startup",
        &["--verbose", "--quit-after", "120", "--link", &link_arg],
    );
    assert_eq!(std::fs::read_link(&link).unwrap(), sim.path);
    let port = Port::open(&link);

    // 1. Probe the rates with `20 4x` at each speed: only the sensor's own
    //    rate (9600 after power-on) answers; the others get nothing
    //    intelligible.
    let mut found = None;
    for (bps, code) in [(500_000, 0x48), (38400, 0x40), (19200, 0x41), (9600, 0x42)] {
        port.set_speed(bps);
        port.discard_input();
        port.send(&telegram(&[0x20, code]));
        let got = port.read_for(Duration::from_millis(300));
        let (items, _) = parse(&got);
        if bps == 9600 {
            assert_eq!(
                got,
                [ACK, 0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A],
                "at 9600"
            );
            found = Some(bps);
        } else {
            assert!(items.is_empty(), "{bps} Bd: {items:02X?}");
        }
    }
    assert_eq!(found, Some(9600));

    // 2. Values on request.
    assert_eq!(port.ask(&[0x20, 0x25]), [0xA0, 0x00, 0x10]);

    // 3. Type.
    let ba = port.ask(&[0x3A]);
    let text = String::from_utf8_lossy(&ba[1..ba.len() - 1]).into_owned();
    assert!(text.contains("LMS200;30106"), "{text}");

    // 4. Status: B1 + 152 bytes + status; fields by payload index.
    let b1 = port.ask(&[0x31]);
    assert_eq!(b1.len(), 154);
    assert_eq!(b1[8], 0x25, "operating mode");
    assert_eq!(u16_at(&b1, 107), 180, "scan angle");
    assert_eq!(u16_at(&b1, 109), 100, "resolution");
    assert_eq!(u16_at(&b1, 116), 103, "baud word at 9600");
    assert_eq!(b1[120], 0, "address");
    assert_eq!(b1[122], 0, "units: cm");

    // 5. Configuration; then installation mode and mm units.
    let f4 = port.ask(&[0x74]);
    assert_eq!(f4.len(), 36);
    let mut config = f4[1..35].to_vec();
    assert_eq!(config[6], 0);
    config[6] = 1;
    let mut write = vec![0x77];
    write.extend_from_slice(&config);
    let refused = port.ask(&write);
    assert_eq!(&refused[..2], &[0xF7, 0x00], "77 outside installation mode");
    let mut install = vec![0x20, 0x00];
    install.extend_from_slice(SICK_LMS);
    assert_eq!(port.ask(&install), [0xA0, 0x00, 0x10]);
    let f7 = port.ask(&write);
    assert_eq!(f7.len(), 37);
    assert_eq!(&f7[..2], &[0xF7, 0x01]);
    assert_eq!(&f7[2..36], &config[..]);

    // 6. 38400 Bd: the reply comes at the old rate, then both switch.
    assert_eq!(port.ask(&[0x20, 0x40]), [0xA0, 0x00, 0x10]);
    port.set_speed(38400);
    let b1 = port.ask(&[0x31]);
    assert_eq!(u16_at(&b1, 116), 25, "baud word at 38400");
    assert_eq!(b1[8], 0x00, "installation mode");
    assert_eq!(b1[122], 1, "units: mm");

    // 7. 500000 Bd.
    assert_eq!(port.ask(&[0x20, 0x48]), [0xA0, 0x00, 0x10]);
    port.set_speed(500_000);
    let b1 = port.ask(&[0x31]);
    assert_eq!(u16_at(&b1, 116), 1, "baud word at 500000");

    // 8. Variant 180°/0.5°: the BB reply of PROTOCOL.md §4, byte for byte.
    port.send(&telegram(&[0x3B, 0xB4, 0x00, 0x32, 0x00]));
    let got = port.read_until(Duration::from_secs(2), |b| b.len() >= 14);
    assert_eq!(
        got,
        [ACK, 0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D]
    );

    // 9. The stream: 361 values in mm (count word 0x4169) per B0, one per
    //    26.7 ms (the mirror, not the line, limits at 500 kBd).
    assert_eq!(port.ask(&[0x20, 0x24]), [0xA0, 0x00, 0x10]);
    let t0 = Instant::now();
    let bytes = port.read_until(Duration::from_secs(5), |b| {
        telegrams(&parse(b).0).len() >= 21
    });
    let elapsed = t0.elapsed();
    let (items, skipped) = parse(&bytes);
    assert_eq!(skipped, 0);
    assert!(
        !items.contains(&Item::Ack),
        "streamed telegrams carry no ACK"
    );
    let scans = telegrams(&items);
    assert!(scans.len() >= 21, "{} scans", scans.len());
    for p in &scans {
        assert_eq!(p[0], 0xB0);
        assert_eq!(p.len(), 726, "LEN of a 361-value B0");
        assert_eq!(u16_at(p, 1), 0x4169, "count word: 361 values, mm");
        assert_eq!(p[725], 0x10, "status");
        let values: Vec<u16> = (0..361).map(|j| u16_at(p, 3 + 2 * j)).collect();
        let valid: Vec<u16> = values.iter().copied().filter(|&v| v < 8183).collect();
        assert!(valid.len() > 330, "{} valid", valid.len());
        // The built-in room: everything within 8 m.
        assert!(valid.iter().all(|&v| v > 100 && v < 8000));
        assert!(values.iter().all(|&v| v < 8183 || v == 8191));
    }
    // 20 intervals of 26.7 ms = 533 ms; not faster than the mirror.
    assert!(
        elapsed >= Duration::from_millis(420),
        "21 scans in {elapsed:?}"
    );

    // 10. A client at the wrong speed reads only noise: bytes, but no
    //     telegram and no handshake byte. Back at the right speed it
    //     resynchronises.
    port.set_speed(38400);
    port.discard_input();
    let noise = port.read_for(Duration::from_millis(300));
    assert!(noise.len() > 1000, "{} bytes", noise.len());
    let (items, _) = parse(&noise);
    assert!(items.is_empty(), "{items:02X?}");
    port.set_speed(500_000);
    port.discard_input();
    let again = port.read_until(Duration::from_secs(2), |b| {
        telegrams(&parse(b).0).len() >= 2
    });
    assert!(telegrams(&parse(&again).0).iter().all(|p| p[0] == 0xB0));

    // 11. Stop: the stream ends first, then ACK and A0; nothing after it.
    let items = port.transact(&[0x20, 0x25]);
    let n = items.len();
    assert_eq!(items[n - 1], Item::Telegram(vec![0xA0, 0x00, 0x10]));
    assert_eq!(items[n - 2], Item::Ack);
    // Before: only (the rest of) the stream; handshake-looking bytes in a
    // B0 cut by the start of this read are not telegrams.
    assert!(telegrams(&items[..n - 2]).iter().all(|p| p[0] == 0xB0));
    assert!(port.read_for(Duration::from_millis(300)).is_empty());

    // 12. Back to 9600 Bd, as a client does on exit.
    assert_eq!(port.ask(&[0x20, 0x42]), [0xA0, 0x00, 0x10]);
    port.set_speed(9600);
    let b1 = port.ask(&[0x31]);
    assert_eq!(u16_at(&b1, 116), 103);
    assert_eq!(b1[8], 0x25, "values on request");
    assert_eq!(b1[122], 1, "units still mm");

    drop(port);
    let status = sim.interrupt();
    let log = sim.stderr();
    assert!(status.success(), "{status}: {log}");
    assert!(!link.exists(), "link left behind");
    for expected in [
        "request 20 24: continuous output",
        "line switched 9600 -> 38400 Bd",
        "line switched 38400 -> 500000 Bd",
        "client at 38400 Bd, sensor at 500000 Bd",
        "stopped (signal)",
    ] {
        assert!(log.contains(expected), "no {expected:?} in:\n{log}");
    }
}

#[test]
fn independent_client_nak_and_92() {
    let sim = Sim::start("nak", &["--quit-after", "60"]);
    let port = Port::open_quiet(&sim.path);
    // A corrupted checksum: NAK, nothing else.
    let mut bad = telegram(&[0x31]);
    assert_eq!(bad, [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12]);
    *bad.last_mut().unwrap() ^= 0x40;
    port.discard_input();
    port.send(&bad);
    assert_eq!(port.read_for(Duration::from_millis(300)), [NAK]);
    // The client resends: ACK and the status.
    assert_eq!(port.ask(&[0x31]).len(), 154);

    // An unknown command, and a known one with the wrong data: the 92 reply
    // of PROTOCOL.md §4.
    let reply_92 = [ACK, 0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33];
    for payload in [&[0x55][..], &[0x20, 0x99], &[0x3A, 0x00]] {
        port.send(&telegram(payload));
        let got = port.read_until(Duration::from_secs(2), |b| b.len() >= 9);
        assert_eq!(got, reply_92, "{payload:02X?}");
    }
    // 0.25° is refused with 180° (BB 00, variant kept); 100°/0.25° is taken.
    let bb = port.ask(&[0x3B, 180, 0, 25, 0]);
    assert_eq!(bb, [0xBB, 0x00, 180, 0, 100, 0, 0x10]);
    port.send(&telegram(&[0x3B, 0x64, 0x00, 0x19, 0x00]));
    assert_eq!(
        telegram(&[0x3B, 0x64, 0x00, 0x19, 0x00]),
        [0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72]
    );
    let got = port.read_until(Duration::from_secs(2), |b| b.len() >= 14);
    let (items, _) = parse(&got);
    assert_eq!(
        items,
        [
            Item::Ack,
            Item::Telegram(vec![0xBB, 0x01, 0x64, 0x00, 0x19, 0x00, 0x10])
        ]
    );
    // One scan: 401 values in cm.
    let b0 = port.ask(&[0x30, 0x01]);
    assert_eq!(u16_at(&b0, 1), 401);
}

#[test]
fn independent_client_reset_reconnect_and_scans_limit() {
    let mut sim = Sim::start(
        "reset",
        &["--scans", "5", "--restart-delay", "0.2", "--verbose"],
    );
    let port = Port::open_quiet(&sim.path);
    assert_eq!(port.ask(&[0x20, 0x41]), [0xA0, 0x00, 0x10]);
    port.set_speed(19200);
    // Reset: ACK, 91; then the power-on 90 at 9600 Bd.
    assert_eq!(port.ask_for(&[0x10], 0x91), [0x91, 0x10]);
    port.set_speed(9600);
    let got = port.read_until(Duration::from_secs(3), |b| {
        telegrams(&parse(b).0).iter().any(|p| p[0] == 0x90)
    });
    let (items, _) = parse(&got);
    let p90 = match telegrams(&items).first() {
        Some(p) => (*p).clone(),
        None => panic!("no 90 in {got:02X?}; simulator:\n{}", sim.stderr()),
    };
    assert_eq!(p90.len(), 23);
    assert!(String::from_utf8_lossy(&p90).contains("LMS200"));
    let b1 = port.ask(&[0x31]);
    assert_eq!(u16_at(&b1, 116), 103);
    assert_eq!(b1[8], 0x25);

    // A client closes the port and another opens it: the sensor is still
    // there, at the rate it had.
    drop(port);
    std::thread::sleep(Duration::from_millis(100));
    let port = Port::open_quiet(&sim.path);
    assert_eq!(port.ask(&[0x31]).len(), 154);

    // `--scans 5`: the simulator exits after the fifth B0.
    assert_eq!(port.ask(&[0x20, 0x48]), [0xA0, 0x00, 0x10]);
    port.set_speed(500_000);
    port.send(&telegram(&[0x20, 0x24]));
    let got = port.read_until(Duration::from_secs(3), |b| {
        telegrams(&parse(b).0).len() >= 6
    });
    let got = [got, port.read_for(Duration::from_millis(100))].concat();
    drop(port);
    let status = sim.wait(Duration::from_secs(5));
    let n_b0 = telegrams(&parse(&got).0)
        .iter()
        .filter(|p| p[0] == 0xB0)
        .count();
    // It stops once the fifth B0 is out (a loop turn late under load, the
    // sixth may have gone too) and lets the client read them.
    assert!(
        (5..=6).contains(&n_b0),
        "{n_b0} scans; simulator:\n{}",
        sim.stderr()
    );
    assert!(status.success());
    assert!(
        sim.stderr().contains("stopped (--scans)"),
        "{}",
        sim.stderr()
    );
}

/// The first `FLASER` line of a CARMEN log, read here on its own (gzip).
fn first_flaser(path: &Path) -> Vec<f64> {
    let mut text = String::new();
    flate2::read::MultiGzDecoder::new(File::open(path).unwrap())
        .read_to_string(&mut text)
        .unwrap();
    let line = text.lines().find(|l| l.starts_with("FLASER ")).unwrap();
    let mut tokens = line.split_whitespace().skip(1);
    let n: usize = tokens.next().unwrap().parse().unwrap();
    tokens.take(n).map(|t| t.parse().unwrap()).collect()
}

#[test]
fn independent_client_replays_a_carmen_log() {
    let log = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/carmen/csail-corrected.log.gz");
    let sim = Sim::start(
        "replay",
        &["--replay", log.to_str().unwrap(), "--quit-after", "60"],
    );
    let port = Port::open_quiet(&sim.path);
    let bb = port.ask(&[0x3B, 0xB4, 0x00, 0x32, 0x00]);
    assert_eq!(bb[1], 0x01);
    let b0 = port.ask(&[0x30, 0x01]);
    assert_eq!(u16_at(&b0, 1), 361, "361 values in cm");
    let ranges = first_flaser(&log);
    assert_eq!(ranges.len(), 361);
    for (j, r) in ranges.iter().enumerate() {
        // cm: the log's metres × 100; 81.91 m is the no-echo code 8191.
        let expected = (r * 100.0).round() as u16;
        assert_eq!(u16_at(&b0, 3 + 2 * j), expected, "beam {j}");
    }
    drop(sim);
}
