//! Unmodified LMS 2xx clients through `host-bridge coprocessor` against
//! `host-bridge simulate`, over real pseudo-terminals.
//!
//! Each modelled client follows one behaviour of common LMS 2xx drivers,
//! with its own framing written from the public protocol (CRC, `02 80`
//! sync), and fails the way such a driver fails:
//!
//! | client | behaviour | trips on |
//! |---|---|---|
//! | `any-reply` | after `ACK`, the first telegram addressed `0x80` is the reply; while streaming, the next telegram must be `B0` | any telegram it did not ask for |
//! | `sync-crc` | syncs on `02 80`, checks `LEN ≤ 812` and the CRC, resyncs a byte on; skips codes it does not wait for | any resync or CRC error |
//! | `stream-b0` | tolerant replies; while streaming, every telegram must be `B0` | a non-`B0` in the stream |
//! | `ack-60ms` | waits 60 ms for the `ACK`, then sends the request again (≤ 10 times) | no `ACK` after 10 tries |
//! | `features` | opts in (`56 01` → `D6 01`); after every `B0`, its `D4 D3 D1… D2… D0` group | a group missing, cut, or not bit-identical to the std build's features of that `B0` |
//! | `driver` | the habits of a widely used LMS 2xx driver: a power-on baud search from 9600 Bd, lock-step requests, 1 s for every message (3 s for a mode switch `20 xx`, 15 s for `3B`/`77`), a reply it does not wait for (`92` too) skipped until the time-out, each request tried 3 times, then an error; telegrams it does not wait for in the stream skipped | a message later than its time-out; a request not answered in 3 tries |
//!
//! Every client, at 9600, 38400 and 500000 Bd on its own chain (a
//! `simulate` and a `coprocessor` process each, all chains at once, so that
//! the slow 9600 Bd runs overlap): initialises (`20 4x`, `3A`, `31`), then
//! for each of the five variants in both units sets them (`3B`, `20 00`,
//! `74`, `77`), checks `31` and `74` tell them, streams (`20 24`) and reads
//! [`scans_per_setting`] scans — 100 in all — whose value count, unit bits
//! and values must equal one of the scans `simulate` sends for that variant
//! and unit ([`SceneSource::scans_for`], the same seeded scene), then stops
//! the stream (`20 25`). At the last setting, the value modes (mean
//! values `20 26`, subrange `20 27`, mean subrange `20 28`, and a bad
//! subrange refused `A0 02`), applied on the sensor through the
//! co-processor: [`VALUE_TELEGRAMS`] `B6`/`B7`/`BF` each, their values
//! checked against `simulate`'s scans; then `B0`s (and features) again.

use std::fs::File;
use std::io::Read as _;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use host_bridge::simulate::SceneSource;
use host_bridge::synthetic::SceneArgs;
use lms_core::device::coprocessor::sensor_link::{REPLY_TIMEOUT_US, STREAM_SILENCE_US};
use lms_core::device::emulator::scan_period_us;
use lms_core::telegram::features::{Assembled, FeatureAssembler};
use lms_core::telegram::{Direction, MeasuredView, RangeBits, Telegram, MAX_TELEGRAM_LEN};
use lms_core::{Extractor, Unit, ValidParams, Variant};
use nix::fcntl::{open, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::stat::Mode;
use nix::sys::termios::{cfmakeraw, cfsetspeed, tcflush, tcgetattr, tcsetattr, BaudRate};
use nix::sys::termios::{FlushArg, SetArg};

const BIN: &str = env!("CARGO_BIN_EXE_host-bridge");

/// Scans read per variant (in each unit): 100 per client in all, more of
/// the short scans, so that the 9600 Bd runs (a 401-value `B0` takes
/// 0.85 s there) stay short.
fn scans_per_setting(v: Variant) -> usize {
    match v {
        Variant::Fov100Res100 => 20,
        Variant::Fov180Res100 | Variant::Fov100Res50 => 10,
        _ => 5,
    }
}
/// The scene `simulate` plays (and the test recomputes).
const SCENE: &[&str] = &["--count", "4", "--seed", "5"];

const ACK: u8 = 0x06;

// ------------------------------------------------------------ the waits --
//
// Every wait is what the line and the co-processor need for it, at the
// client's rate (or the chain's, if slower), times [`SLACK`]: no fixed
// guess of how long a reply "should" take.

/// Bytes that may be on the client's line ahead of what it waits for: a
/// `B0` and its feature group, less than two of the longest telegrams
/// (docs/PROTOCOL.md §3); the host-line budget lets no more queue (§2c).
const AHEAD_BYTES: usize = 2 * MAX_TELEGRAM_LEN;
/// The margin on every wait: on the loaded 2-core CI machine the chain's
/// processes (and QEMU's clock) run slower than real time.
const SLACK: u32 = 4;
/// Time a wait always gets on top: the chain's processes stalled by the
/// scheduler (CI runs the tests in parallel on 2 cores; at a load of 20, a
/// 0.7 s wait for a 500 kBd reply timed out in 14 of 15 sessions).
const FLOOR: Duration = Duration::from_secs(5);
/// QEMU's USARTs carry about 10 KB/s whatever their rate (100 µs a byte):
/// at 500 kBd the firmware's lines are slower than the rate says.
const QEMU_BYTE_US: u64 = 100;
/// Under QEMU, what is queued ahead of every reply of the sensor: QEMU's
/// USART takes ≈ 10 KB/s of the sensor's 500 kBd stream (15–28 KB/s), so
/// up to a TCP window (64 KiB) of it waits in the bridge's socket: 6.5 s
/// (seen: the `20 25` of a bring-up answered 5.8 s after it was sent).
const QEMU_SENSOR_BACKLOG_US: u64 = 64 * 1024 * QEMU_BYTE_US;
/// The co-processor's work for a relayed request: the sensor link waits
/// behind the stream (≤ 2 s) and 300 ms more for the reply, and sends once
/// more (core `sensor_link`).
const RELAY_US: u64 = 2 * (STREAM_SILENCE_US + REPLY_TIMEOUT_US);
/// A bring-up of the sensor for a new variant or unit: seven requests of
/// up to 300 ms with one resend each, the `20 25` behind the stream (≤ 2 s),
/// the baud search's four rates.
const BRING_UP_US: u64 = 14 * REPLY_TIMEOUT_US + STREAM_SILENCE_US + 4 * PROBE_US;
/// The baud search's wait at 9600 Bd, its longest (core `probe_wait_us`).
const PROBE_US: u64 = lms_core::device::coprocessor::sensor_link::probe_wait_us(
    lms_core::telegram::Baud::B9600,
    lms_core::telegram::Baud::B500000,
);

/// The driver's time-out for a message: a reply, and every scan in the
/// stream.
const DRIVER_MESSAGE: Duration = Duration::from_secs(1);
/// The driver's tries of a request.
const DRIVER_TRIES: u32 = 3;
/// Under QEMU the firmware gets whole scans less often than the sensor
/// sends them: QEMU's USART takes about 10 KB/s (the bridge lets at most
/// 1000 bytes wait, modelled at 5 KB/s), so a 401-value `B0` (812 bytes)
/// reaches the firmware every 100–220 ms instead of every 53 ms, and after
/// its host line frees the next whole scan may be that much later (client
/// gaps of 0.80–1.02 s measured at 9600 Bd, 100°/0.25°). A board (500 kBd
/// sensor line, a scan every 53.3 ms) sends a 401-value scan at 9600 Bd
/// 0.853 s after the last
/// ([`the_board_streams_100_0_25_at_9600_bd_within_the_drivers_second`]):
/// the driver's second holds there.
const QEMU_STREAM_EXTRA: Duration = Duration::from_millis(400);

/// The driver's time-out for the reply to `payload`: 3 s for a mode
/// switch (`20 xx`), 15 s for a new variant or configuration (`3B`, `77`:
/// the co-processor answers at once, a real LMS takes seconds), else
/// [`DRIVER_MESSAGE`].
fn driver_timeout(payload: &[u8]) -> Duration {
    match payload[0] {
        0x20 => Duration::from_secs(3),
        0x3B | 0x77 => Duration::from_secs(15),
        _ => DRIVER_MESSAGE,
    }
}

/// `true` for the requests the co-processor relays to the sensor (`3A`,
/// the value modes).
fn relayed(payload: &[u8]) -> bool {
    payload[0] == 0x3A || (payload[0] == 0x20 && matches!(payload.get(1), Some(0x26..=0x28)))
}

// ------------------------------------------------------------ the wire --

/// The LMS checksum (public telegram listing): shift left, feeding back
/// 0x8005 on a carry, xor in the byte and the previous byte.
fn lms_crc(bytes: &[u8]) -> u16 {
    let (mut crc, mut prev) = (0u16, 0u8);
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

/// A request to address 0: `02 00 LEN CMD DATA CRC`.
fn telegram(payload: &[u8]) -> Vec<u8> {
    let len = payload.len() as u16;
    let mut t = vec![0x02, 0x00, len as u8, (len >> 8) as u8];
    t.extend_from_slice(payload);
    let crc = lms_crc(&t);
    t.extend_from_slice(&crc.to_le_bytes());
    t
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

/// The `20 4x` mode byte of a rate.
fn baud_code(bps: u32) -> u8 {
    match bps {
        38400 => 0x40,
        19200 => 0x41,
        9600 => 0x42,
        _ => 0x48,
    }
}

/// The client's serial port (the pty's slave), with a receive buffer.
struct Port {
    fd: OwnedFd,
    rx: Vec<u8>,
}

impl Port {
    fn open(path: &Path) -> Port {
        let fd = open(
            path,
            OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK,
            Mode::empty(),
        )
        .unwrap_or_else(|e| panic!("cannot open {}: {e}", path.display()));
        let port = Port { fd, rx: Vec::new() };
        port.set_speed(9600);
        port
    }

    fn set_speed(&self, bps: u32) {
        let mut t = tcgetattr(self.fd.as_fd()).unwrap();
        cfmakeraw(&mut t);
        cfsetspeed(&mut t, termios_rate(bps)).unwrap();
        tcsetattr(self.fd.as_fd(), SetArg::TCSANOW, &t).unwrap();
    }

    fn flush_input(&mut self) {
        tcflush(self.fd.as_fd(), FlushArg::TCIFLUSH).unwrap();
        self.rx.clear();
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

    /// Read what is there, waiting up to `wait` for something; `false` if
    /// nothing came.
    fn pull(&mut self, wait: Duration) -> bool {
        let ms = wait.as_millis().clamp(0, 50) as u16;
        let mut fds = [PollFd::new(self.fd.as_fd(), PollFlags::POLLIN)];
        let _ = poll(&mut fds, PollTimeout::from(ms));
        let mut buf = [0u8; 4096];
        let mut got = false;
        loop {
            match nix::unistd::read(&self.fd, &mut buf) {
                Ok(0) | Err(nix::errno::Errno::EAGAIN) | Err(nix::errno::Errno::EIO) => break,
                Ok(n) => {
                    self.rx.extend_from_slice(&buf[..n]);
                    got = true;
                }
                Err(e) => panic!("read: {e}"),
            }
        }
        got
    }

    /// The next byte within `deadline`.
    fn byte(&mut self, deadline: Instant) -> Result<u8, String> {
        while self.rx.is_empty() {
            if Instant::now() >= deadline {
                return Err("time-out waiting for a byte".into());
            }
            self.pull(deadline.saturating_duration_since(Instant::now()));
        }
        Ok(self.rx.remove(0))
    }

    /// `n` bytes within `deadline`.
    fn bytes(&mut self, n: usize, deadline: Instant) -> Result<Vec<u8>, String> {
        while self.rx.len() < n {
            if Instant::now() >= deadline {
                return Err(format!("time-out waiting for {n} bytes"));
            }
            self.pull(deadline.saturating_duration_since(Instant::now()));
        }
        Ok(self.rx.drain(..n).collect())
    }
}

/// Read one frame the way the drivers do: find `02 80`, `LEN` (≤ 812),
/// payload, CRC. `Ok(None)` is a frame that failed a check (the caller
/// decides whether that trips it); the bytes after its `02` stay.
fn read_frame(port: &mut Port, deadline: Instant) -> Result<Option<Vec<u8>>, String> {
    loop {
        if port.byte(deadline)? != 0x02 {
            continue;
        }
        let addr = port.bytes(1, deadline)?[0];
        if addr != 0x80 {
            port.rx.insert(0, addr);
            continue;
        }
        let len = port.bytes(2, deadline)?;
        let n = usize::from(u16::from_le_bytes([len[0], len[1]]));
        if !(2..=812).contains(&n) {
            port.rx.splice(0..0, len);
            return Ok(None);
        }
        let body = port.bytes(n + 2, deadline)?;
        let mut all = vec![0x02, 0x80, len[0], len[1]];
        all.extend_from_slice(&body[..n]);
        if lms_crc(&all) != u16::from_le_bytes([body[n], body[n + 1]]) {
            port.rx.splice(
                0..0,
                all[1..].iter().copied().chain(body[n..].iter().copied()),
            );
            return Ok(None);
        }
        return Ok(Some(body[..n].to_vec()));
    }
}

// --------------------------------------------------------- the clients --

/// The behaviours of the table in the module docs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Behaviour {
    AnyReply,
    SyncCrc,
    StreamB0,
    Ack60,
    Features,
    Driver,
}

impl Behaviour {
    const ALL: [Behaviour; 6] = [
        Behaviour::AnyReply,
        Behaviour::SyncCrc,
        Behaviour::StreamB0,
        Behaviour::Ack60,
        Behaviour::Features,
        Behaviour::Driver,
    ];

    fn name(self) -> &'static str {
        match self {
            Behaviour::AnyReply => "any-reply",
            Behaviour::SyncCrc => "sync-crc",
            Behaviour::StreamB0 => "stream-b0",
            Behaviour::Ack60 => "ack-60ms",
            Behaviour::Features => "features",
            Behaviour::Driver => "driver",
        }
    }
}

/// What a client run found.
#[derive(Debug, Default)]
struct Tally {
    scans: usize,
    feature_groups: usize,
    skipped_telegrams: usize,
    resends: usize,
    value_telegrams: usize,
}

struct Client {
    behaviour: Behaviour,
    port: Port,
    baud: u32,
    extractor: Extractor,
    assembler: FeatureAssembler,
    tally: Tally,
    /// The requests sent (seconds since the session began), for a report.
    trail: Vec<String>,
    began: Instant,
    /// Through the firmware under QEMU (its lines' rate, [`QEMU_BYTE_US`]).
    qemu: bool,
}

impl Client {
    /// A client of `behaviour` at `baud` on `link` (`qemu`: the firmware
    /// under QEMU is the co-processor).
    fn new(behaviour: Behaviour, baud: u32, link: &Path, qemu: bool) -> Client {
        Client {
            behaviour,
            port: Port::open(link),
            baud,
            extractor: Extractor::new(),
            assembler: FeatureAssembler::new(),
            tally: Tally::default(),
            trail: Vec::new(),
            began: Instant::now(),
            qemu,
        }
    }

    /// The line time of `bytes` at the client's rate, or the chain's.
    fn line(&self, bytes: usize) -> Duration {
        let mut byte_us = 10_000_000 / u64::from(self.baud);
        if self.qemu {
            byte_us = byte_us.max(QEMU_BYTE_US);
        }
        Duration::from_micros(bytes as u64 * byte_us)
    }

    /// The deadline of a wait that needs `need`: [`SLACK`] times it, plus
    /// [`FLOOR`].
    fn deadline(&self, need: Duration) -> Instant {
        Instant::now() + need * SLACK + FLOOR
    }

    /// The reply's deadline: what may be ahead of it, itself, and the
    /// sensor's work if the request is relayed.
    fn reply_deadline(&self, payload: &[u8]) -> Instant {
        let relay = match relayed(payload) {
            true => self.sensor_work(RELAY_US),
            false => Duration::ZERO,
        };
        self.deadline(self.line(AHEAD_BYTES + MAX_TELEGRAM_LEN) + relay)
    }

    /// `work_us` of the co-processor with the sensor, and under QEMU the
    /// sensor's stream queued ahead of its replies.
    fn sensor_work(&self, work_us: u64) -> Duration {
        let backlog = if self.qemu { QEMU_SENSOR_BACKLOG_US } else { 0 };
        Duration::from_micros(work_us + backlog)
    }

    /// Send `payload` and return the reply (`CMD … STATUS`) with code `want`,
    /// as this client's driver would.
    fn request(&mut self, payload: &[u8], want: u8) -> Result<Vec<u8>, String> {
        let at = self.began.elapsed().as_secs_f64();
        self.trail.push(format!(
            "{at:.2} s {:02X?}",
            &payload[..payload.len().min(3)]
        ));
        let deadline = self.reply_deadline(payload);
        match self.behaviour {
            Behaviour::AnyReply => {
                self.port.send(&telegram(payload));
                while self.port.byte(deadline)? != ACK {}
                let reply =
                    read_frame(&mut self.port, deadline)?.ok_or("bad frame as the reply")?;
                if reply[0] != want {
                    return Err(format!(
                        "unexpected message {:02X} (waiting for {want:02X})",
                        reply[0]
                    ));
                }
                Ok(reply)
            }
            Behaviour::Driver => self.driver_request(payload, want),
            Behaviour::Ack60 => {
                let mut tries = 0;
                loop {
                    self.port.send(&telegram(payload));
                    tries += 1;
                    let ack_by = Instant::now() + Duration::from_millis(60);
                    if matches!(self.port.byte(ack_by), Ok(ACK)) {
                        break;
                    }
                    if tries == 10 {
                        return Err(format!("no ACK to {:02X} in 10 tries", payload[0]));
                    }
                    // What came instead (e.g. a late reply to the last try)
                    // is dropped before the request goes again.
                    self.port.pull(Duration::ZERO);
                    self.port.flush_input();
                    self.tally.resends += 1;
                }
                self.tolerant_reply(want, deadline)
            }
            _ => {
                self.port.send(&telegram(payload));
                self.tolerant_reply(want, deadline)
            }
        }
    }

    /// Frames until the one with code `want`, skipping others (`sync-crc`
    /// trips on a bad frame).
    fn tolerant_reply(&mut self, want: u8, deadline: Instant) -> Result<Vec<u8>, String> {
        loop {
            match read_frame(&mut self.port, deadline)? {
                Some(f) if f[0] == want => return Ok(f),
                Some(_) => self.tally.skipped_telegrams += 1,
                None if self.behaviour == Behaviour::SyncCrc => {
                    return Err("resync: bad length or CRC".into())
                }
                None => {}
            }
        }
    }

    /// The next scan (`B0` payload) while streaming, due within `period`
    /// plus what may be ahead of it on the line.
    fn scan(&mut self, period: Duration) -> Result<Vec<u8>, String> {
        self.streamed(0xB0, period)
    }

    /// The next stream telegram with code `want` (`B0`, or a value mode's
    /// `B6`/`B7`/`BF`: then not even the features client takes another),
    /// due within `period` plus what may be ahead of it on the line.
    fn streamed(&mut self, want: u8, period: Duration) -> Result<Vec<u8>, String> {
        let deadline = match self.behaviour {
            // The driver's second per scan; the first after a new setting
            // waits for the sensor's bring-up. (The value modes' telegrams:
            // means of several scans, as the other clients.)
            Behaviour::Driver if want == 0xB0 && period < DRIVER_MESSAGE => {
                Instant::now() + DRIVER_MESSAGE + self.qemu_stream_extra()
            }
            _ => self.deadline(period + self.line(AHEAD_BYTES)),
        };
        let strict = match self.behaviour {
            Behaviour::AnyReply | Behaviour::StreamB0 => true,
            Behaviour::Features => want != 0xB0,
            Behaviour::SyncCrc | Behaviour::Ack60 | Behaviour::Driver => false,
        };
        loop {
            let frame = read_frame(&mut self.port, deadline)?;
            match (self.behaviour, frame) {
                (_, Some(f)) if f[0] == want => return Ok(f),
                (_, Some(f)) if strict => {
                    return Err(format!("unexpected message {:02X} in the stream", f[0]))
                }
                (Behaviour::SyncCrc, None) => return Err("resync in the stream".into()),
                (_, Some(_)) => self.tally.skipped_telegrams += 1,
                (_, None) => {}
            }
        }
    }

    /// The driver's request: sent, then every telegram but the one with
    /// code `want` skipped (a `92` too) until its time-out
    /// ([`driver_timeout`]); three tries, then an error.
    fn driver_request(&mut self, payload: &[u8], want: u8) -> Result<Vec<u8>, String> {
        let timeout = driver_timeout(payload) + self.qemu_reply_extra(payload);
        let mut seen = Vec::new();
        for attempt in 1..=DRIVER_TRIES {
            if attempt > 1 {
                self.tally.resends += 1;
            }
            self.port.send(&telegram(payload));
            let deadline = Instant::now() + timeout;
            loop {
                match read_frame(&mut self.port, deadline) {
                    Ok(Some(f)) if f[0] == want => return Ok(f),
                    Ok(Some(f)) => {
                        if !seen.contains(&f[0]) {
                            seen.push(f[0]);
                        }
                    }
                    Ok(None) => {}
                    Err(_) => break,
                }
            }
        }
        Err(format!(
            "no {want:02X} to {:02X?} in {DRIVER_TRIES} tries of {timeout:?} (got instead: {seen:02X?})",
            &payload[..payload.len().min(3)]
        ))
    }

    /// Under QEMU, what its slow USARTs add to a reply of the sensor's
    /// (relayed) or of a bring-up: the sensor's stream queued ahead of it.
    fn qemu_reply_extra(&self, payload: &[u8]) -> Duration {
        match self.qemu && (relayed(payload) || matches!(payload[0], 0x3B | 0x77)) {
            true => self.sensor_work(0),
            false => Duration::ZERO,
        }
    }

    /// Under QEMU, the most its sensor line adds between two scans:
    /// [`QEMU_STREAM_EXTRA`]. Nothing on a computer's or a board's lines.
    fn qemu_stream_extra(&self) -> Duration {
        match self.qemu {
            true => QEMU_STREAM_EXTRA,
            false => Duration::ZERO,
        }
    }

    /// The features client: the group after a `B0`, bit-identical to the
    /// std build's features of that scan.
    fn check_features(&mut self, b0: &Telegram<&[u8]>) -> Result<(), String> {
        let frame = MeasuredView::parse(b0)
            .and_then(|m| m.to_frame(RangeBits::Bits13))
            .map_err(|e| format!("B0: {e}"))?;
        let want = self.extractor.run(&frame, &ValidParams::DEFAULT).clone();
        let deadline = self.deadline(self.line(AHEAD_BYTES));
        loop {
            let f = read_frame(&mut self.port, deadline)?.ok_or("bad frame in a group")?;
            let wire = wire_bytes(&f);
            let t = Telegram::new_checked(&wire[..], Direction::SensorToHost)
                .map_err(|e| format!("{e:?}"))?;
            if f[0] == 0xB0 {
                return Err("a B0 before the previous scan's D0".into());
            }
            match self.assembler.push(&t) {
                Ok(Assembled::Complete(summary, got)) => {
                    let diffs = host_bridge::verify::differences(got, &want);
                    if !diffs.is_empty() || usize::from(summary.beams) != frame.len() {
                        return Err(format!("features differ: {diffs:?}"));
                    }
                    self.tally.feature_groups += 1;
                    return Ok(());
                }
                Ok(_) => {}
                Err(e) => return Err(format!("feature telegram: {e:?}")),
            }
        }
    }

    /// Stop the stream as a driver must with an LMS too: `20 25`, read on
    /// until its `A0` (it may come late behind queued scans, e.g. under a
    /// loaded QEMU), let the line go quiet for 300 ms, drop what came, ask
    /// again (now the next telegram is the reply).
    fn stop_stream(&mut self) -> Result<(), String> {
        self.port.send(&telegram(&[0x20, 0x25]));
        let deadline = self.reply_deadline(&[0x20, 0x25]);
        while read_frame(&mut self.port, deadline)?.is_none_or(|f| f[0] != 0xA0) {}
        let mut quiet_since = Instant::now();
        while quiet_since.elapsed() < Duration::from_millis(300) && Instant::now() < deadline {
            if self.port.pull(Duration::from_millis(20)) {
                quiet_since = Instant::now();
            }
        }
        self.port.flush_input();
        let a0 = self.request(&[0x20, 0x25], 0xA0)?;
        expect(a0[1] == 0, "20 25 answered A0 00", &a0)
    }
}

/// A frame's payload back to its bytes on the wire.
fn wire_bytes(payload: &[u8]) -> Vec<u8> {
    let len = payload.len() as u16;
    let mut t = vec![0x02, 0x80, len as u8, (len >> 8) as u8];
    t.extend_from_slice(payload);
    let crc = lms_crc(&t);
    t.extend_from_slice(&crc.to_le_bytes());
    t
}

fn expect(ok: bool, what: &str, got: &[u8]) -> Result<(), String> {
    if ok {
        Ok(())
    } else {
        Err(format!("{what}: got {:02X?}", &got[..got.len().min(16)]))
    }
}

// ------------------------------------------------------------ a session --

/// A variant and unit, and the scans (value words) `simulate` sends for it.
type Expected = ((Variant, Unit), Vec<Vec<u16>>);

/// The scans `simulate` sends for each variant and unit.
fn expected_scans() -> Vec<Expected> {
    let args = SceneArgs {
        count: 4,
        seed: 5,
        ..SceneArgs::default()
    };
    let mut source = SceneSource::new(&args).unwrap();
    let mut all = Vec::new();
    for v in VARIANTS {
        for u in [Unit::Millimetre, Unit::Centimetre] {
            all.push(((v, u), source.scans_for(v, u)));
        }
    }
    all
}

const VARIANTS: [Variant; 5] = [
    Variant::Fov180Res100,
    Variant::Fov180Res50,
    Variant::Fov100Res100,
    Variant::Fov100Res50,
    Variant::Fov100Res25,
];

/// Find the sensor as drivers do at start-up: `20 25` at 9600 Bd every
/// 500 ms until an `A0` comes (a co-processor, like an LMS, may still be
/// booting: the firmware under a loaded QEMU takes seconds), at most 60 s;
/// then let the line go quiet and drop what came.
fn connect(c: &mut Client) -> Result<(), String> {
    if c.behaviour == Behaviour::Driver {
        return driver_connect(c);
    }
    let until = Instant::now() + Duration::from_secs(60);
    loop {
        c.port.send(&telegram(&[0x20, 0x25]));
        let by = Instant::now() + Duration::from_millis(500);
        match read_frame(&mut c.port, by.min(until)) {
            Ok(Some(f)) if f[0] == 0xA0 => break,
            _ if Instant::now() >= until => return Err("no answer to 20 25 in 60 s".into()),
            _ => {}
        }
    }
    let mut quiet_since = Instant::now();
    while quiet_since.elapsed() < Duration::from_millis(300) {
        if c.port.pull(Duration::from_millis(20)) {
            quiet_since = Instant::now();
        }
    }
    c.port.flush_input();
    Ok(())
}

/// The driver's power-on baud search: `20 25` at 9600, 19200, 38400 and
/// 500000 Bd in turn, one second each, until an `A0` comes (from the top
/// again while a co-processor boots, at most 60 s); the line then at
/// 9600 Bd, where [`initialise`] starts.
fn driver_connect(c: &mut Client) -> Result<(), String> {
    let until = Instant::now() + Duration::from_secs(60);
    let found = 'search: loop {
        for bps in [9600u32, 19200, 38400, 500_000] {
            c.port.set_speed(bps);
            c.port.flush_input();
            c.port.send(&telegram(&[0x20, 0x25]));
            let by = Instant::now() + DRIVER_MESSAGE;
            while let Ok(f) = read_frame(&mut c.port, by) {
                if f.is_some_and(|f| f[0] == 0xA0) {
                    break 'search bps;
                }
            }
        }
        if Instant::now() >= until {
            return Err("baud search: no answer to 20 25 at any rate in 60 s".into());
        }
    };
    if found != 9600 {
        let a0 = c.request(&[0x20, 0x42], 0xA0)?;
        expect(a0[1] == 0, "20 42 answered A0 00", &a0)?;
        c.port.set_speed(9600);
    }
    c.port.flush_input();
    Ok(())
}

/// Initialise: the rate, the features (opted-in client), type and status.
fn initialise(c: &mut Client) -> Result<(), String> {
    if c.baud != 9600 {
        let a0 = c.request(&[0x20, baud_code(c.baud)], 0xA0)?;
        expect(a0[1] == 0, "20 4x answered A0 00", &a0)?;
        c.port.set_speed(c.baud);
    }
    if c.behaviour == Behaviour::Features {
        let d6 = c.request(&[0x56, 0x01], 0xD6)?;
        expect(d6[1] == 1, "56 01 answered D6 01", &d6)?;
    }
    let ba = c.request(&[0x3A], 0xBA)?;
    expect(ba[1..].starts_with(b"LMS"), "3A answered BA LMS…", &ba)?;
    let b1 = c.request(&[0x31], 0xB1)?;
    expect(b1.len() > 122, "31 answered B1", &b1)
}

/// Set a variant and unit and check that `31` and `74` tell them.
fn set_up(c: &mut Client, v: Variant, u: Unit) -> Result<(), String> {
    let (fov, res) = (v.fov_deg(), v.resolution_centideg());
    let mut req = vec![0x3B];
    req.extend_from_slice(&fov.to_le_bytes());
    req.extend_from_slice(&res.to_le_bytes());
    let bb = c.request(&req, 0xBB)?;
    expect(
        bb[1] == 1 && bb[2..6] == req[1..5],
        "3B answered BB 01 + variant",
        &bb,
    )?;
    let mut install = vec![0x20, 0x00];
    install.extend_from_slice(b"SICK_LMS");
    let a0 = c.request(&install, 0xA0)?;
    expect(a0[1] == 0, "installation mode", &a0)?;
    let f4 = c.request(&[0x74], 0xF4)?;
    let mut config = f4[1..35].to_vec();
    config[6] = u8::from(u == Unit::Millimetre);
    let mut write = vec![0x77];
    write.extend_from_slice(&config);
    let f7 = c.request(&write, 0xF7)?;
    expect(
        f7[1] == 1 && f7[2..36] == config[..],
        "77 answered F7 01",
        &f7,
    )?;
    let b1 = c.request(&[0x31], 0xB1)?;
    let angle = u16::from_le_bytes([b1[107], b1[108]]);
    let resolution = u16::from_le_bytes([b1[109], b1[110]]);
    let ok = (angle, resolution, b1[122]) == (fov, res, config[6]);
    expect(ok, "B1 tells the variant and units", &b1[105..123])?;
    let f4 = c.request(&[0x74], 0xF4)?;
    expect(f4[7] == config[6], "F4 tells the units", &f4)
}

/// Stream and read [`scans_per_setting`] scans of `v` in `u`, each one of
/// `expected`.
fn read_scans(c: &mut Client, v: Variant, u: Unit, expected: &[Vec<u16>]) -> Result<(), String> {
    let a0 = c.request(&[0x20, 0x24], 0xA0)?;
    expect(a0[1] == 0, "20 24 answered A0 00", &a0)?;
    let period = Duration::from_micros(scan_period_us(v));
    // The first after a new setting waits for the sensor's bring-up.
    let mut wait = period + c.sensor_work(BRING_UP_US);
    for _ in 0..scans_per_setting(v) {
        let b0 = c.scan(std::mem::replace(&mut wait, period))?;
        let count = u16::from_le_bytes([b0[1], b0[2]]);
        let unit_bits = count >> 14;
        let n = usize::from(count & 0x3FFF);
        let want_unit = u16::from(u == Unit::Millimetre);
        expect(
            n == v.beams() && unit_bits == want_unit,
            "B0 of the variant and units set",
            &b0[..3],
        )?;
        let words: Vec<u16> = (0..n)
            .map(|j| u16::from_le_bytes([b0[3 + 2 * j], b0[4 + 2 * j]]))
            .collect();
        expect(
            expected.contains(&words),
            "B0 values are one of simulate's scans",
            &b0[..8],
        )?;
        c.tally.scans += 1;
        if c.behaviour == Behaviour::Features {
            let wire = wire_bytes(&b0);
            let t = Telegram::new_checked(&wire[..], Direction::SensorToHost)
                .map_err(|e| format!("{e:?}"))?;
            c.check_features(&t)?;
        }
    }
    c.stop_stream()
}

/// Value telegrams read per value mode.
const VALUE_TELEGRAMS: usize = 3;

/// The value modes at the last setting (`v` in `u`), applied on the sensor
/// and its telegrams passed through: `20 26 4` (`B6`: every value within
/// the range of `simulate`'s scans at its beam), `20 27 10 60` (`B7`: one
/// of `simulate`'s scans, values 10…60), `20 28 2 10 60` (`BF`), a bad
/// subrange refused with the sensor's `A0 02`, each stopped with `20 25`.
fn value_modes(c: &mut Client, v: Variant, u: Unit, expected: &[Vec<u16>]) -> Result<(), String> {
    let (first, last) = (10usize, 60usize);
    let sub = |a: usize, b: usize| [a as u8, (a >> 8) as u8, b as u8, (b >> 8) as u8];
    let bad = c.request(&[[0x20, 0x27].as_slice(), &sub(60, 10)].concat(), 0xA0)?;
    expect(bad[1] == 2, "20 27 60 10 refused with A0 02", &bad)?;
    let modes: [(Vec<u8>, u8, usize, bool); 3] = [
        (vec![0x20, 0x26, 4], 0xB6, 2, true),
        (
            [[0x20, 0x27].as_slice(), &sub(first, last)].concat(),
            0xB7,
            5,
            false,
        ),
        (
            [[0x20, 0x28, 2].as_slice(), &sub(first, last)].concat(),
            0xBF,
            6,
            true,
        ),
    ];
    for (request, code, at, mean) in modes {
        let a0 = c.request(&request, 0xA0)?;
        expect(a0[1] == 0, "value mode answered A0 00", &a0)?;
        let (start, n) = if code == 0xB6 {
            (0, v.beams())
        } else {
            (first - 1, last - first + 1)
        };
        let samples = if mean { u64::from(request[2]) } else { 1 };
        // The first behind the sensor's stream (under QEMU).
        let period = Duration::from_micros(scan_period_us(v) * samples);
        let mut wait = period + c.sensor_work(0);
        for _ in 0..VALUE_TELEGRAMS {
            let f = c.streamed(code, std::mem::replace(&mut wait, period))?;
            let word = u16::from_le_bytes([f[at], f[at + 1]]);
            let want_unit = u16::from(u == Unit::Millimetre);
            let ok = usize::from(word & 0x3FF) == n && word >> 14 == want_unit;
            expect(ok, "value telegram's count and units", &f[..at + 2])?;
            let words: Vec<u16> = (0..n)
                .map(|j| u16::from_le_bytes([f[at + 2 + 2 * j], f[at + 3 + 2 * j]]))
                .collect();
            let ok = if mean {
                (0..n).all(|j| {
                    let at_beam = expected.iter().map(|s| s[start + j]);
                    let (lo, hi) = (at_beam.clone().min(), at_beam.max());
                    lo <= Some(words[j]) && Some(words[j]) <= hi
                })
            } else {
                expected.iter().any(|s| s[start..start + n] == words[..])
            };
            expect(ok, "values from simulate's scans", &f[..at + 8])?;
            c.tally.value_telegrams += 1;
        }
        c.stop_stream()?;
    }
    Ok(())
}

/// One client's whole run on `link` (`qemu`: the firmware under QEMU is
/// the co-processor).
fn session(behaviour: Behaviour, baud: u32, link: &Path, qemu: bool) -> Result<Tally, String> {
    let mut c = Client::new(behaviour, baud, link, qemu);
    // The line settles (a client opening the port sees nothing it did not ask for).
    c.port.pull(Duration::from_millis(50));
    c.port.flush_input();
    let r = run_session(&mut c);
    r.map_err(|e| format!("{e}\n  {}", diagnose(&mut c)))
}

/// After a failure: the requests last sent (seconds since the session
/// began) and the co-processor's counters (`55` → `D5`), for the report.
fn diagnose(c: &mut Client) -> String {
    let trail = c
        .trail
        .iter()
        .rev()
        .take(6)
        .rev()
        .cloned()
        .collect::<Vec<_>>();
    std::thread::sleep(Duration::from_millis(300));
    c.port.pull(Duration::ZERO);
    c.port.flush_input();
    c.port.send(&telegram(&[0x55]));
    let deadline = Instant::now() + Duration::from_secs(3);
    let counters = loop {
        match read_frame(&mut c.port, deadline) {
            Ok(Some(f)) if f[0] == 0xD5 => {
                break lms_core::telegram::features::Counters::decode(&f[1..f.len() - 1])
                    .map_or_else(|| format!("D5 {:02X?}", f), |k| format!("{k:?}"))
            }
            Ok(_) => {}
            Err(e) => break format!("no D5: {e}"),
        }
    };
    format!(
        "last requests: {}\n  counters: {counters}",
        trail.join(", ")
    )
}

/// [`session`]'s steps.
fn run_session(c: &mut Client) -> Result<Tally, String> {
    connect(c)?;
    initialise(c)?;
    let all = expected_scans();
    for ((v, u), expected) in &all {
        set_up(c, *v, *u).map_err(|e| format!("{v:?} {u}: {e}"))?;
        read_scans(c, *v, *u, expected).map_err(|e| format!("{v:?} {u}: {e}"))?;
    }
    if let Some(((v, u), expected)) = all.last() {
        value_modes(c, *v, *u, expected).map_err(|e| format!("value modes: {e}"))?;
        read_scans(c, *v, *u, expected).map_err(|e| format!("B0 after: {e}"))?;
    }
    finish(c)?;
    Ok(std::mem::take(&mut c.tally))
}

/// On exit, as drivers do: features off, back to 9600 Bd (the next client
/// finds the line as at power-on).
fn finish(c: &mut Client) -> Result<(), String> {
    if c.behaviour == Behaviour::Features {
        let d6 = c.request(&[0x56, 0x00], 0xD6)?;
        expect(d6[1] == 0, "56 00 answered D6 00", &d6)?;
    }
    if c.baud != 9600 {
        let a0 = c.request(&[0x20, 0x42], 0xA0)?;
        expect(a0[1] == 0, "20 42 answered A0 00", &a0)?;
        c.port.set_speed(9600);
    }
    Ok(())
}

// -------------------------------------------------------- the processes --

/// A child process, stopped when dropped: `SIGINT` first (a `coprocessor
/// --qemu` then ends its QEMU: killed outright it left QEMU running, under
/// `timeout`'s day-long bound), `SIGKILL` after 5 s.
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

/// Wait until `path` exists (a `--link`).
fn await_path(path: &Path, what: &str) {
    let until = Instant::now() + Duration::from_secs(20);
    while std::fs::symlink_metadata(path).is_err() {
        assert!(Instant::now() < until, "{what}: no {}", path.display());
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `simulate` and `coprocessor` for one client; the client's link.
fn chain(dir: &Path, name: &str) -> (Proc, Proc, PathBuf) {
    chain_with(dir, name, &[])
}

/// [`chain`] with more `coprocessor` options (e.g. `--qemu ELF`).
fn chain_with(dir: &Path, name: &str, cop_args: &[&str]) -> (Proc, Proc, PathBuf) {
    let sensor = dir.join(format!("{name}.sensor"));
    let client = dir.join(format!("{name}.client"));
    let log = |what: &str| File::create(dir.join(format!("{name}.{what}.log"))).unwrap();
    let sim = Command::new(BIN)
        .arg("simulate")
        .args(SCENE)
        .arg("--link")
        .arg(&sensor)
        .stdout(Stdio::null())
        .stderr(log("simulate"))
        .spawn()
        .expect("simulate");
    await_path(&sensor, "simulate");
    let cop = Command::new(BIN)
        .args(["coprocessor", "--status-every", "5"])
        .args(cop_args)
        .arg("--sensor")
        .arg(&sensor)
        .arg("--link")
        .arg(&client)
        .stdout(Stdio::null())
        .stderr(log("coprocessor"))
        .spawn()
        .expect("coprocessor");
    await_path(&client, "coprocessor");
    (Proc(sim), Proc(cop), client)
}

fn tail(path: &Path) -> String {
    let mut s = String::new();
    if let Ok(mut f) = File::open(path) {
        let _ = f.read_to_string(&mut s);
    }
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(3)..].join("\n")
}

#[test]
fn lms_clients_through_the_coprocessor_against_simulate() {
    let dir = std::env::temp_dir().join(format!("host-bridge-lms-clients-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let started = Instant::now();
    let mut runs = Vec::new();
    for baud in [9600u32, 38400, 500_000] {
        for behaviour in Behaviour::ALL {
            let name = format!("{}-{baud}", behaviour.name());
            let (sim, cop, link) = chain(&dir, &name);
            let handle = std::thread::spawn(move || {
                let t0 = Instant::now();
                let r = session(behaviour, baud, &link, false);
                (r, t0.elapsed())
            });
            runs.push((name, sim, cop, handle));
        }
    }
    let mut failures = Vec::new();
    for (name, sim, cop, handle) in runs {
        let (result, took) = handle.join().unwrap();
        drop((cop, sim));
        match result {
            Ok(t) => {
                println!(
                    "{name:18} {:3} scans, {:3} feature groups, {} value telegrams, {} telegrams skipped, {} resends, {:.1} s",
                    t.scans,
                    t.feature_groups,
                    t.value_telegrams,
                    t.skipped_telegrams,
                    t.resends,
                    took.as_secs_f64()
                );
                let features = name.starts_with("features");
                let values = t.value_telegrams == 3 * VALUE_TELEGRAMS;
                if t.scans < 100 || !values || (features && t.feature_groups != t.scans) {
                    failures.push(format!("{name}: {t:?}"));
                }
            }
            Err(e) => failures.push(format!(
                "{name}: {e}\n  coprocessor: {}\n  simulate: {}",
                tail(&dir.join(format!("{name}.coprocessor.log"))),
                tail(&dir.join(format!("{name}.simulate.log")))
            )),
        }
    }
    println!("all clients: {:.1} s", started.elapsed().as_secs_f64());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_powers_up_with_its_stored_settings() {
    let dir = std::env::temp_dir().join(format!("host-bridge-power-on-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("lms");
    let sim = Command::new(BIN)
        .args([
            "simulate",
            "--variant",
            "100/0.25",
            "--units",
            "mm",
            "--range-mode",
            "16",
        ])
        .arg("--link")
        .arg(&link)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("simulate");
    let _sim = Proc(sim);
    await_path(&link, "simulate");
    let mut c = Client::new(Behaviour::AnyReply, 9600, &link, false);
    c.port.pull(Duration::from_millis(100));
    c.port.flush_input();
    // A client that sets nothing: B1, F4 and the scans tell the stored
    // 100°/0.25°, mm, 16 m mode (measuring mode 04, 14 range bits).
    let b1 = c.request(&[0x31], 0xB1).unwrap();
    let angle = u16::from_le_bytes([b1[107], b1[108]]);
    let res = u16::from_le_bytes([b1[109], b1[110]]);
    assert_eq!((angle, res, b1[122]), (100, 25, 1));
    let f4 = c.request(&[0x74], 0xF4).unwrap();
    assert_eq!((f4[6], f4[7]), (0x04, 1), "measuring mode 04, mm");
    let b0 = c.request(&[0x30, 0x01], 0xB0).unwrap();
    let count = u16::from_le_bytes([b0[1], b0[2]]);
    assert_eq!((count & 0x3FF, count >> 14), (401, 1));
    // The room is within 8 m: every value a range or the 14-bit "not valid".
    let words = (0..401).map(|j| u16::from_le_bytes([b0[3 + 2 * j], b0[4 + 2 * j]]));
    assert!(
        words.clone().all(|w| w < 8000 || w == 0x3FFF),
        "14-bit codes"
    );
    assert!(
        words.clone().any(|w| w == 0x3FFF),
        "dropouts coded in 14 bits"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A request the co-processor's face does not interpret reaches the sensor
/// and its answer the client: `simulate --verbose` logs each request it
/// gets, so the test sees which reached it.
#[test]
fn requests_the_face_does_not_interpret_are_simulates_to_answer() {
    let dir = std::env::temp_dir().join(format!("host-bridge-relay-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (sensor, client) = (dir.join("sensor"), dir.join("client"));
    let sim_log = dir.join("simulate.log");
    let sim = Command::new(BIN)
        .args(["simulate", "--verbose", "--link"])
        .arg(&sensor)
        .stdout(Stdio::null())
        .stderr(File::create(&sim_log).unwrap())
        .spawn()
        .expect("simulate");
    let _sim = Proc(sim);
    await_path(&sensor, "simulate");
    let cop = Command::new(BIN)
        .args(["coprocessor", "--sensor"])
        .arg(&sensor)
        .arg("--link")
        .arg(&client)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("coprocessor");
    let _cop = Proc(cop);
    await_path(&client, "coprocessor");
    let mut c = Client::new(Behaviour::AnyReply, 9600, &client, false);
    connect(&mut c).unwrap();
    let reached = |what: &str| std::fs::read_to_string(&sim_log).unwrap().contains(what);
    // The face answers `92` itself until the sensor streams; then `36 01`
    // is the sensor's to answer.
    let until = Instant::now() + Duration::from_secs(30);
    let mut reply;
    loop {
        reply = c.request(&[0x36, 0x01], 0x92);
        let relayed = reached("36 with 1 data bytes: unknown, answered 92");
        if relayed || Instant::now() > until {
            assert!(relayed, "36 01 never reached simulate");
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    assert_eq!(reply.unwrap(), [0x92, 0x10], "the sensor's 92 and status");
    assert_eq!(c.request(&[0x63], 0x92).unwrap(), [0x92, 0x10]);
    assert!(reached("63 with 0 data bytes: unknown, answered 92"));
    // Too long for the relay: the face's 92; simulate never hears of it.
    assert_eq!(c.request(&[0x36; 10], 0x92).unwrap(), [0x92, 0x10]);
    // The face's own requests still work, and the stream.
    let b1 = c.request(&[0x31], 0xB1).unwrap();
    assert!(b1.len() > 122);
    let a0 = c.request(&[0x20, 0x24], 0xA0).unwrap();
    assert_eq!(a0[1], 0);
    c.scan(Duration::from_micros(BRING_UP_US)).unwrap();
    assert!(!reached("36 with 9 data bytes"), "9 data bytes not relayed");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The release firmware (`cd firmware && cargo build --release`) with
/// `qemu-system-arm` on PATH, or a failure that names what is missing.
fn firmware_elf() -> PathBuf {
    let elf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../firmware/target/thumbv7em-none-eabihf/release/lms-firmware");
    let qemu = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("qemu-system-arm").exists()));
    assert!(
        qemu,
        "qemu-system-arm is not on PATH (apt-get install qemu-system-arm)"
    );
    assert!(
        elf.is_file(),
        "no firmware ELF at {} (cd firmware && cargo build --release)",
        elf.display()
    );
    elf
}

/// The clients that run through the firmware under QEMU in CI: every
/// client and every rate at least once, on two chains at once (each
/// session leaves the line at 9600 Bd, features off, for the next): the
/// `features` client at 9600 Bd on one (the longest run, ~150 s of line
/// time), the others on the second, the `driver` at 9600 Bd last (58 s).
/// The whole matrix (18 sessions; without the `driver`'s three, 354 s on
/// two chains: 9600 Bd on one, 38400 and 500000 Bd on the other) runs with
/// `LMS_QEMU_RUNS=all`; any other list with
/// `LMS_QEMU_RUNS="features:9600;any-reply:38400,sync-crc:500000"`
/// (chains split by `;`).
fn qemu_chains() -> Vec<Vec<(Behaviour, u32)>> {
    let spec = std::env::var("LMS_QEMU_RUNS").unwrap_or_else(|_| {
        "features:9600;any-reply:38400,sync-crc:500000,stream-b0:500000,ack-60ms:500000,driver:9600"
            .into()
    });
    if spec == "all" {
        let all = |rates: &[u32]| {
            rates
                .iter()
                .flat_map(|&r| Behaviour::ALL.iter().map(move |&b| (b, r)))
                .collect::<Vec<_>>()
        };
        return vec![all(&[9600]), all(&[38400, 500_000])];
    }
    spec.split(';')
        .map(|chain| {
            chain
                .split(',')
                .map(|r| {
                    let (name, baud) = r.split_once(':').expect("LMS_QEMU_RUNS: client:baud,…");
                    let b = Behaviour::ALL.iter().find(|b| b.name() == name);
                    (*b.expect("a client name"), baud.parse().expect("a rate"))
                })
                .collect()
        })
        .collect()
}

/// The same clients through the real firmware under QEMU
/// (`host-bridge coprocessor --qemu`), [`qemu_chains`]. A chain starts once
/// the one before it has its QEMU up: `coprocessor --qemu` picks free TCP
/// ports for its QEMU's serial lines, and two started together may pick the
/// same ones (found so: the chains crossed). Needs the release firmware and
/// QEMU; CI runs it after the firmware build:
/// `cargo test -p host-bridge --test lms_clients -- --ignored --nocapture`.
#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn lms_clients_through_the_firmware_under_qemu() {
    let elf = firmware_elf();
    let dir = std::env::temp_dir().join(format!("host-bridge-lms-qemu-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let started = Instant::now();
    let mut chains = Vec::new();
    for (i, runs) in qemu_chains().into_iter().enumerate() {
        let name = format!("qemu{i}");
        let (sim, cop, link) = chain_with(&dir, &name, &["--qemu", elf.to_str().unwrap()]);
        let log = dir.join(format!("{name}.coprocessor.log"));
        await_text(&log, "firmware under QEMU between");
        let handle = std::thread::spawn(move || qemu_runs(&runs, &link, &log));
        chains.push((sim, cop, handle));
    }
    let mut failures = Vec::new();
    for (sim, cop, handle) in chains {
        failures.extend(handle.join().unwrap());
        drop((cop, sim));
    }
    println!(
        "all clients under QEMU: {:.1} s",
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Wait until the file at `path` holds `text` (a process's log line).
fn await_text(path: &Path, text: &str) {
    let until = Instant::now() + Duration::from_secs(60);
    while !std::fs::read_to_string(path).is_ok_and(|s| s.contains(text)) {
        assert!(Instant::now() < until, "no '{text}' in {}", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The clients of `runs` one after another on `link`; their failures.
fn qemu_runs(runs: &[(Behaviour, u32)], link: &Path, log: &Path) -> Vec<String> {
    let mut failures = Vec::new();
    for &(behaviour, baud) in runs {
        let t0 = Instant::now();
        match session(behaviour, baud, link, true) {
            Ok(t) => {
                println!(
                    "qemu {:10} {baud:6} Bd: {:3} scans, {:3} feature groups, {} value telegrams, {} resends, {:.1} s",
                    behaviour.name(),
                    t.scans,
                    t.feature_groups,
                    t.value_telegrams,
                    t.resends,
                    t0.elapsed().as_secs_f64()
                );
                let features = behaviour == Behaviour::Features;
                let values = t.value_telegrams == 3 * VALUE_TELEGRAMS;
                if t.scans < 100 || !values || (features && t.feature_groups != t.scans) {
                    failures.push(format!("{} {baud}: {t:?}", behaviour.name()));
                }
            }
            Err(e) => failures.push(format!(
                "{} {baud}: {e}\n  coprocessor: {}",
                behaviour.name(),
                tail(log)
            )),
        }
    }
    failures
}

// ------------------------------------------ the driver's findings, each --
//
// What the driver of the `driver` client met through the co-processor, one
// test each, so that a regression shows by name.

/// A `driver` client on a fresh chain (`simulate` and `coprocessor`) in
/// `dir`, connected at 9600 Bd and initialised at `baud`.
fn driver_on_chain(dir: &Path, name: &str, baud: u32) -> (Proc, Proc, Client) {
    let (sim, cop, link) = chain(dir, name);
    let mut c = Client::new(Behaviour::Driver, baud, &link, false);
    c.port.pull(Duration::from_millis(50));
    c.port.flush_input();
    connect(&mut c).unwrap();
    initialise(&mut c).unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    (sim, cop, c)
}

/// The driver asks for partial scans (`20 2A`) at 100°/0.25°: the
/// co-processor must relay it (an LMS answers `A0 00` and streams each
/// quarter of the scan as a `B0` of its own, count word bit 13, offsets
/// 0.25° apart); a `92` is not the driver's reply: it waits 3 s, three
/// times, and fails.
#[test]
fn driver_gets_partial_scans_through_the_coprocessor() {
    let dir =
        std::env::temp_dir().join(format!("host-bridge-driver-partial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (_sim, _cop, mut c) = driver_on_chain(&dir, "partial", 500_000);
    set_up(&mut c, Variant::Fov100Res25, Unit::Millimetre).unwrap();
    let a0 = c
        .request(&[0x20, 0x2A], 0xA0)
        .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    assert_eq!(a0[1], 0, "20 2A answered A0 00");
    let mut offsets = Vec::new();
    let mut wait = Duration::from_micros(BRING_UP_US);
    for _ in 0..8 {
        let b0 = c
            .scan(std::mem::replace(&mut wait, Duration::ZERO))
            .unwrap_or_else(|e| panic!("partial scan: {e}\n  {}", diagnose(&mut c)));
        let count = u16::from_le_bytes([b0[1], b0[2]]);
        assert!(
            count & 0x2000 != 0,
            "count word {count:04X}: not a partial scan"
        );
        offsets.push((count >> 11) & 3);
    }
    // Every offset of the four comes round.
    for k in 0..4 {
        assert!(offsets.contains(&k), "offsets {offsets:?}");
    }
    c.stop_stream().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A request the driver gave up on (`36 01`, relayed, answered `92` by
/// the sensor: not its reply) must not wedge the relay: the driver's next
/// relayed requests (`3A`) are each answered within its second.
#[test]
fn driver_relayed_requests_are_answered_after_one_given_up() {
    let dir = std::env::temp_dir().join(format!("host-bridge-driver-relay-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (_sim, _cop, mut c) = driver_on_chain(&dir, "relay", 38400);
    let given_up = c.request(&[0x36, 0x01], 0xB6);
    assert!(
        given_up.as_ref().is_err_and(|e| e.contains("92")),
        "{given_up:?}"
    );
    // Stream and stop in between, as a driver does.
    let a0 = c.request(&[0x20, 0x24], 0xA0).unwrap();
    assert_eq!(a0[1], 0);
    let mut wait = Duration::from_micros(BRING_UP_US);
    for _ in 0..3 {
        c.scan(std::mem::replace(&mut wait, Duration::ZERO))
            .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    }
    c.stop_stream().unwrap();
    for _ in 0..5 {
        let ba = c
            .request(&[0x3A], 0xBA)
            .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
        assert!(ba[1..].starts_with(b"LMS"), "{ba:02X?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A client that opted in to the features and went away without `56 00`
/// (a program killed) leaves them on for nobody: the next client, the
/// driver at 9600 Bd, must get only what an LMS sends, every scan within
/// its second (features behind each `B0` take more than that at 9600 Bd).
/// The driver's power-on search meets the line at the first client's
/// 500 kBd (noise at the other rates), so it sets 9600 Bd with `20 42`: a
/// new session (docs/PROTOCOL.md §2a).
fn opt_in_ends_with_its_client(name: &str, cop_args: &[&str]) {
    let dir = std::env::temp_dir().join(format!("host-bridge-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (_sim, _cop, link) = chain_with(&dir, name, cop_args);
    {
        let mut first = Client::new(Behaviour::Features, 500_000, &link, false);
        first.port.pull(Duration::from_millis(50));
        first.port.flush_input();
        connect(&mut first).unwrap();
        initialise(&mut first).unwrap();
        let a0 = first.request(&[0x20, 0x24], 0xA0).unwrap();
        assert_eq!(a0[1], 0);
        first.scan(Duration::from_micros(BRING_UP_US)).unwrap();
        // Gone: no `56 00`, no `20 25`, the line left at 500 kBd.
    }
    std::thread::sleep(Duration::from_millis(500));
    let mut c = Client::new(Behaviour::Driver, 9600, &link, false);
    c.port.pull(Duration::from_millis(50));
    c.port.flush_input();
    connect(&mut c).unwrap_or_else(|e| panic!("{e}"));
    initialise(&mut c).unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    let a0 = c.request(&[0x20, 0x24], 0xA0).unwrap();
    assert_eq!(a0[1], 0);
    let mut wait = Duration::from_micros(BRING_UP_US);
    for _ in 0..10 {
        c.scan(std::mem::replace(&mut wait, Duration::ZERO))
            .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    }
    assert_eq!(
        c.tally.skipped_telegrams, 0,
        "telegrams an LMS does not send reached the next client"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_opt_in_ends_with_its_client() {
    opt_in_ends_with_its_client("opt-in", &[]);
}

/// The same through the firmware under QEMU.
#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn an_opt_in_ends_with_its_client_through_the_firmware_under_qemu() {
    let elf = firmware_elf();
    opt_in_ends_with_its_client("opt-in-qemu", &["--qemu", elf.to_str().unwrap()]);
}

// ------------------------------------------------ the board's timing --

/// The board's two UARTs, in memory, on a virtual clock: the sensor line
/// carries bytes as they come (the LMS's own pacing is the emulator's);
/// the host line is the firmware's: a transmit queue of
/// `HOST_TX_SLOTS - 1` = 831 bytes (firmware/src/board.rs) sending one
/// byte per 10 bit times at the face's rate.
mod board {
    use std::collections::VecDeque;
    use std::convert::Infallible;

    use embedded_io::{ErrorType, Read, ReadReady, Write};
    use lms_core::device::coprocessor::WriteRoom;
    use lms_core::telegram::Baud;

    /// The firmware's host transmit queue (bytes).
    pub const HOST_TX_QUEUE: usize = 831;

    #[derive(Default)]
    pub struct SensorUart {
        pub rx: VecDeque<u8>,
        pub tx: Vec<u8>,
    }

    impl ErrorType for SensorUart {
        type Error = Infallible;
    }

    impl ReadReady for SensorUart {
        fn read_ready(&mut self) -> Result<bool, Infallible> {
            Ok(!self.rx.is_empty())
        }
    }

    impl Read for SensorUart {
        fn read(&mut self, out: &mut [u8]) -> Result<usize, Infallible> {
            let n = out.len().min(self.rx.len());
            for (slot, b) in out.iter_mut().zip(self.rx.drain(..n)) {
                *slot = b;
            }
            Ok(n)
        }
    }

    impl Write for SensorUart {
        fn write(&mut self, bytes: &[u8]) -> Result<usize, Infallible> {
            self.tx.extend_from_slice(bytes);
            Ok(bytes.len())
        }

        fn flush(&mut self) -> Result<(), Infallible> {
            Ok(())
        }
    }

    pub struct HostUart {
        pub rx: VecDeque<u8>,
        queue: VecDeque<u8>,
        /// Bytes the queue holds: [`HOST_TX_QUEUE`], or no limit (a
        /// pseudo-terminal, `host-bridge coprocessor`).
        pub capacity: usize,
        pub baud: Baud,
        /// When the byte on the line now has gone (µs).
        busy_until: u64,
        /// Bytes that reached the client, with the time each arrived.
        pub out: Vec<(u8, u64)>,
    }

    impl HostUart {
        pub fn new() -> Self {
            HostUart {
                rx: VecDeque::new(),
                queue: VecDeque::new(),
                capacity: HOST_TX_QUEUE,
                baud: Baud::B9600,
                busy_until: 0,
                out: Vec::new(),
            }
        }

        /// Send what the line carries by `now_us` (called every step of
        /// the clock: an idle line starts the next byte at the step).
        pub fn drain(&mut self, now_us: u64) {
            let bits: u64 = 10 * 1_000_000;
            let rate = u64::from(self.baud.bits_per_second());
            while let Some(&b) = self.queue.front() {
                // The end of the next byte, to the µs.
                let end = self.busy_until + u64::div_ceil(bits, rate);
                if end > now_us {
                    return;
                }
                self.busy_until = end;
                self.queue.pop_front();
                self.out.push((b, end));
            }
            self.busy_until = self.busy_until.max(now_us);
        }
    }

    impl ErrorType for HostUart {
        type Error = Infallible;
    }

    impl ReadReady for HostUart {
        fn read_ready(&mut self) -> Result<bool, Infallible> {
            Ok(!self.rx.is_empty())
        }
    }

    impl Read for HostUart {
        fn read(&mut self, out: &mut [u8]) -> Result<usize, Infallible> {
            let n = out.len().min(self.rx.len());
            for (slot, b) in out.iter_mut().zip(self.rx.drain(..n)) {
                *slot = b;
            }
            Ok(n)
        }
    }

    impl Write for HostUart {
        fn write(&mut self, bytes: &[u8]) -> Result<usize, Infallible> {
            assert!(
                self.queue.len() + bytes.len() <= self.capacity,
                "over the queue"
            );
            self.queue.extend(bytes);
            Ok(bytes.len())
        }

        fn flush(&mut self) -> Result<(), Infallible> {
            Ok(())
        }
    }

    impl WriteRoom for HostUart {
        fn write_room(&mut self) -> Result<usize, Infallible> {
            Ok(self.capacity.saturating_sub(self.queue.len()))
        }
    }
}

/// On the board (the co-processor's code on the firmware's UARTs, on a
/// virtual clock), a client streaming 100°/0.25° at 9600 Bd gets a scan
/// every 0.853 s, inside the driver's second: a 401-value `B0` (812 bytes,
/// 10 bits each) takes 846 ms at 9600 Bd, the next fits the 831-byte
/// transmit queue 19.8 ms before the line frees, and the LMS delivers a
/// whole scan every 53.3 ms at 500 kBd (16.2 ms on its line). Under QEMU
/// the sensor line carries ≈ 10 KB/s, whole scans reach the firmware every
/// 100–220 ms, and the gaps grow to 0.95–1.02 s ([`QEMU_STREAM_EXTRA`]):
/// QEMU's sensor line alone.
#[test]
fn the_board_streams_100_0_25_at_9600_bd_within_the_drivers_second() {
    use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
    use lms_core::device::emulator::{Emulator, Settings};
    use lms_core::telegram::{Baud, Event, Framer, Handshake};

    let setup = SensorSetup {
        variant: Variant::Fov100Res25,
        units: Unit::Millimetre,
        baud: Baud::B500000,
    };
    let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, setup));
    let source = host_bridge::emulated_link::PatternSource::default();
    let mut lms = Emulator::new(source, Settings::DEFAULT, 0);
    let (mut sensor, mut host) = (board::SensorUart::default(), board::HostUart::new());
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    cop.start(0);
    let (mut asked, mut seen, mut b0_at) = (false, 0, Vec::new());
    let mut buf = [0u8; 4096];
    let mut t = 0u64;
    while t < 30_000_000 && b0_at.len() < 16 {
        t += 200;
        loop {
            let n = lms.transmit(t, &mut buf);
            sensor.rx.extend(&buf[..n]);
            if n == 0 {
                break;
            }
        }
        while lms.next_event().is_some() {}
        let outcome = cop.poll(&mut sensor, &mut host, t).unwrap();
        if let Some(b) = outcome.host_baud {
            host.baud = b;
        }
        lms.receive(t, &std::mem::take(&mut sensor.tx));
        host.drain(t);
        // The client: continuous output once the sensor streams.
        if !asked && cop.link().step() == lms_core::device::coprocessor::Step::Streaming {
            host.rx.extend(telegram(&[0x20, 0x24]));
            asked = true;
        }
        for &(b, at) in &host.out[seen..] {
            let mut input = &[b][..];
            while !input.is_empty() {
                let fed = framer.feed(input);
                input = fed.remaining;
                if let Some(Event::Telegram(tg)) = fed.event {
                    if tg.command() == 0xB0 {
                        b0_at.push(at);
                    }
                }
            }
        }
        seen = host.out.len();
    }
    assert!(b0_at.len() >= 16, "{} scans in 30 s", b0_at.len());
    let gaps: Vec<u64> = b0_at.windows(2).map(|w| w[1] - w[0]).collect();
    let (min, max) = (*gaps.iter().min().unwrap(), *gaps.iter().max().unwrap());
    println!("B0 gaps at 9600 Bd: {min}..{max} µs ({gaps:?})");
    assert!(min >= 845_000, "{gaps:?}");
    assert!(max <= 900_000, "{gaps:?}");
    assert!(max < DRIVER_MESSAGE.as_micros() as u64);
}

/// The driver with real-time indices on (configuration byte `[4]` bit 1,
/// written with `77`) sees every scan of the sensor's stream at 500 kBd:
/// the index after the values steps by the same count from each scan to
/// the next (a step twice as long is a scan lost on the way: the
/// co-processor on a loaded computer lost 1–3 of 200).
#[test]
fn driver_sees_every_scan_by_its_real_time_index() {
    let dir = std::env::temp_dir().join(format!("host-bridge-driver-index-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (_sim, _cop, mut c) = driver_on_chain(&dir, "index", 500_000);
    let mut install = vec![0x20, 0x00];
    install.extend_from_slice(b"SICK_LMS");
    assert_eq!(c.request(&install, 0xA0).unwrap()[1], 0);
    let f4 = c.request(&[0x74], 0xF4).unwrap();
    let mut write = vec![0x77];
    write.extend_from_slice(&f4[1..35]);
    write[1 + 4] |= 0x02;
    let f7 = c
        .request(&write, 0xF7)
        .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
    assert_eq!(f7[1], 1, "77 accepted");
    assert_eq!(c.request(&[0x20, 0x24], 0xA0).unwrap()[1], 0);
    let mut indices = Vec::new();
    let mut wait = Duration::from_micros(BRING_UP_US);
    while indices.len() < 60 {
        let b0 = c
            .scan(std::mem::replace(&mut wait, Duration::ZERO))
            .unwrap_or_else(|e| panic!("{e}\n  {}", diagnose(&mut c)));
        let n = usize::from(u16::from_le_bytes([b0[1], b0[2]]) & 0x3FF);
        // The first scans may come before the sensor has the new setting.
        if b0.len() == 3 + 2 * n + 2 {
            indices.push(b0[3 + 2 * n]);
        }
    }
    let steps: Vec<u8> = indices
        .windows(2)
        .map(|w| w[1].wrapping_sub(w[0]))
        .collect();
    assert!(
        steps.iter().all(|&s| s == steps[0] && s > 0),
        "real-time indices {indices:?}"
    );
    c.stop_stream().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// The co-processor on a computer whose loop is held off the CPU for a
/// third of a second (seen under load): the scans the LMS sent meanwhile
/// (500 kBd, 180°/0.5°, one per 26.7 ms) wait at the sensor port. Handed
/// over at once, at the time the loop found them, they look back to back
/// and the host-line budget drops all but two; handed over with their
/// arrival times ([`host_bridge::serial::Arrivals`]) none is dropped.
#[test]
fn scans_queued_while_the_loop_was_away_keep_their_arrival_times() {
    use host_bridge::serial::Arrivals;
    use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
    use lms_core::device::emulator::{Emulator, Settings};
    use lms_core::telegram::Baud;

    /// Host-line drops after a 330 ms stall, with or without `Arrivals`.
    fn drops_after_a_stall(arrivals: bool) -> u32 {
        let setup = SensorSetup {
            variant: Variant::Fov180Res50,
            units: Unit::Millimetre,
            baud: Baud::B500000,
        };
        let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, setup));
        let source = host_bridge::emulated_link::PatternSource::default();
        let mut lms = Emulator::new(source, Settings::DEFAULT, 0);
        let mut sensor = Arrivals::new(board::SensorUart::default());
        let mut host = board::HostUart::new();
        host.capacity = usize::MAX;
        cop.start(0);
        let mut buf = [0u8; 4096];
        let (mut t, mut asked, mut stall) = (0u64, false, None);
        let mut streaming_since = None;
        while t < 20_000_000 {
            t += 200;
            loop {
                let n = lms.transmit(t, &mut buf);
                sensor.port_mut().rx.extend(&buf[..n]);
                if n == 0 {
                    break;
                }
            }
            while lms.next_event().is_some() {}
            // The loop away for 330 ms, 2 s into the stream.
            let away = stall.is_some_and(|(from, to)| t >= from && t < to);
            if !away {
                let outcome = if arrivals {
                    sensor.poll(&mut cop, &mut host, || t).unwrap()
                } else {
                    cop.poll(sensor.port_mut(), &mut host, t).unwrap()
                };
                if let Some(b) = outcome.host_baud {
                    host.baud = b;
                }
            }
            lms.receive(t, &std::mem::take(&mut sensor.port_mut().tx));
            host.drain(t);
            if !asked && cop.link().step() == lms_core::device::coprocessor::Step::Streaming {
                // The client at 500 kBd, streaming.
                host.rx.extend(telegram(&[0x20, 0x48]));
                asked = true;
            }
            if asked && streaming_since.is_none() && host.baud == Baud::B500000 {
                host.rx.extend(telegram(&[0x20, 0x24]));
                streaming_since = Some(t);
                stall = Some((t + 2_000_000, t + 2_330_000));
            }
            if stall.is_some_and(|(_, to)| t > to + 1_000_000) {
                break;
            }
        }
        let c = cop.counters();
        assert!(c.scans_out > 80, "{c:?}");
        c.host_scans_dropped
    }
    assert!(
        drops_after_a_stall(false) >= 5,
        "the stall must bunch the scans"
    );
    assert_eq!(drops_after_a_stall(true), 0);
}
