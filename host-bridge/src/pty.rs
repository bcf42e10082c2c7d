//! A pseudo-terminal standing in for a serial port (Linux).
//!
//! The simulator holds the master side; a client opens the slave device
//! (`/dev/pts/N`) exactly as it would open `/dev/ttyUSB0`. What this module
//! relies on, checked by its tests:
//!
//! * **Line settings are shared.** The termios of the pair belong to the
//!   slave; `tcgetattr` on the master reads what the client set, so the
//!   master sees the client's line speed ([`Pty::client_speed`]). A pty
//!   carries bytes at memory speed whatever the speed says; pacing and the
//!   consequences of a speed mismatch are the simulator's business.
//! * **Connection state.** With no slave open, `poll` on the master reports
//!   `POLLHUP` and `read` fails with `EIO` — but only once a slave has been
//!   opened and closed: before that the master looks like a quiet line, and
//!   bytes written to it wait for the first client. [`Pty::open`] therefore
//!   opens and closes the slave once, so that from then on
//!   [`Pty::client_connected`] is exact. Bytes written with no client open
//!   still wait in the kernel for the next client, so the caller must not
//!   write then (a real serial line would lose them).
//! * **Raw mode.** The pair starts in raw mode (no echo, no line editing, no
//!   CR/LF translation) at 9600 Bd, the LMS 2xx's power-on rate; a client
//!   sets its own mode anyway.
//!
//! Everything is non-blocking; [`Pty::wait_readable`] is the one place that
//! sleeps.

use std::fs::OpenOptions;
use std::io;
use std::os::fd::AsFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result};
use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::pty::{grantpt, posix_openpt, ptsname_r, unlockpt, PtyMaster};
use nix::sys::termios::{
    cfmakeraw, cfsetspeed, tcflush, tcgetattr, tcsetattr, BaudRate, ControlFlags, FlushArg, SetArg,
};

/// What a non-blocking read found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadOutcome {
    /// This many bytes.
    Data(usize),
    /// Nothing waiting.
    Empty,
    /// No client has the slave open (`EIO`).
    Closed,
}

/// What a non-blocking write did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteOutcome {
    /// This many bytes were taken (possibly fewer than offered).
    Written(usize),
    /// The client's input queue is full; nothing was taken.
    Full,
    /// No client has the slave open (`EIO`).
    Closed,
}

/// The master side of a pseudo-terminal pair.
#[derive(Debug)]
pub struct Pty {
    master: PtyMaster,
    slave: PathBuf,
}

impl Pty {
    /// A new pair in raw mode at `initial_bps` (a standard termios rate);
    /// see the [module docs](self).
    pub fn open(initial_bps: u32) -> Result<Pty> {
        let master = posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY)
            .context("cannot open a pseudo-terminal (posix_openpt)")?;
        grantpt(&master).context("grantpt")?;
        unlockpt(&master).context("unlockpt")?;
        let slave = PathBuf::from(ptsname_r(&master).context("ptsname_r")?);
        fcntl(master.as_fd(), FcntlArg::F_SETFL(OFlag::O_NONBLOCK))
            .context("cannot make the pty non-blocking")?;
        let pty = Pty { master, slave };
        let mut t = tcgetattr(pty.master.as_fd()).context("tcgetattr on the pty")?;
        cfmakeraw(&mut t);
        let rate = baud_rate(initial_bps)
            .with_context(|| format!("{initial_bps} Bd is not a termios speed"))?;
        cfsetspeed(&mut t, rate).context("cfsetspeed")?;
        tcsetattr(pty.master.as_fd(), SetArg::TCSANOW, &t).context("tcsetattr on the pty")?;
        // Open and close the slave once, so that "no client" reads as HUP.
        drop(
            OpenOptions::new()
                .read(true)
                .write(true)
                .custom_flags(OFlag::O_NOCTTY.bits())
                .open(&pty.slave)
                .with_context(|| format!("cannot open {}", pty.slave.display()))?,
        );
        Ok(pty)
    }

    /// The slave device a client opens, e.g. `/dev/pts/7`.
    pub fn slave_path(&self) -> &Path {
        &self.slave
    }

    /// `true` while some process has the slave open.
    pub fn client_connected(&self) -> Result<bool> {
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::empty())];
        match poll(&mut fds, PollTimeout::ZERO) {
            Ok(_) | Err(Errno::EINTR) => {}
            Err(e) => return Err(e).context("poll on the pty"),
        }
        let hup = fds[0]
            .revents()
            .is_some_and(|r| r.contains(PollFlags::POLLHUP));
        Ok(!hup)
    }

    /// Wait until the client has sent something, hung up, or `timeout`
    /// passed (a signal also ends the wait). Returns `true` if the master is
    /// readable or hung up.
    pub fn wait_readable(&self, timeout: Duration) -> Result<bool> {
        let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(n) => Ok(n > 0),
            Err(Errno::EINTR) => Ok(false),
            Err(e) => Err(e).context("poll on the pty"),
        }
    }

    /// Read what the client sent, without blocking.
    pub fn read(&self, buf: &mut [u8]) -> Result<ReadOutcome> {
        match nix::unistd::read(&self.master, buf) {
            Ok(0) => Ok(ReadOutcome::Closed),
            Ok(n) => Ok(ReadOutcome::Data(n)),
            Err(Errno::EAGAIN | Errno::EINTR) => Ok(ReadOutcome::Empty),
            Err(Errno::EIO) => Ok(ReadOutcome::Closed),
            Err(e) => Err(io::Error::from(e)).context("read from the pty"),
        }
    }

    /// Write towards the client, without blocking.
    pub fn write(&self, bytes: &[u8]) -> Result<WriteOutcome> {
        match nix::unistd::write(&self.master, bytes) {
            Ok(n) => Ok(WriteOutcome::Written(n)),
            Err(Errno::EAGAIN | Errno::EINTR) => Ok(WriteOutcome::Full),
            Err(Errno::EIO) => Ok(WriteOutcome::Closed),
            Err(e) => Err(io::Error::from(e)).context("write to the pty"),
        }
    }

    /// The line speed the client set (its output speed), in bits per
    /// second; `None` for `B0` (hang up), a rate not listed in
    /// [`baud_rate`], or an arbitrary speed set through the `termios2`
    /// `BOTHER` ioctl (which a pty's master cannot read, PROTOCOL.md §5).
    pub fn client_speed(&self) -> Result<Option<u32>> {
        let t = tcgetattr(self.master.as_fd()).context("tcgetattr on the pty")?;
        // The speed code in the CBAUD bits of c_cflag (what cfgetospeed
        // returns; nix's cfgetospeed panics on BOTHER, so not through it).
        let code = (t.control_flags & ControlFlags::CBAUD).bits();
        Ok(RATES
            .iter()
            .find(|(_, r)| *r as nix::libc::tcflag_t == code)
            .map(|(b, _)| *b))
    }

    /// Drop whatever waits in either direction (e.g. left over from a client
    /// that went away).
    pub fn flush(&self) -> Result<()> {
        tcflush(self.master.as_fd(), FlushArg::TCIOFLUSH).context("tcflush on the pty")
    }
}

/// Noise for bytes sent at the wrong speed: what a UART at one rate makes
/// of bytes sent at another (xorshift32 over the bytes; never `STX`, `ACK`
/// or `NAK`, so that noise frames nothing).
#[derive(Debug)]
pub struct Scrambler(u32);

impl Default for Scrambler {
    fn default() -> Self {
        Scrambler(0x2545_F491)
    }
}

impl Scrambler {
    /// What `b` looks like at the other end.
    pub fn byte(&mut self, b: u8) -> u8 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        let g = b ^ (x >> 24) as u8;
        if matches!(g, 0x02 | 0x06 | 0x15) {
            g ^ 0x80
        } else {
            g
        }
    }
}

/// The standard termios rates this tool knows, as (bits per second, rate).
const RATES: [(u32, BaudRate); 14] = [
    (1200, BaudRate::B1200),
    (2400, BaudRate::B2400),
    (4800, BaudRate::B4800),
    (9600, BaudRate::B9600),
    (19200, BaudRate::B19200),
    (38400, BaudRate::B38400),
    (57600, BaudRate::B57600),
    (115_200, BaudRate::B115200),
    (230_400, BaudRate::B230400),
    (460_800, BaudRate::B460800),
    (500_000, BaudRate::B500000),
    (576_000, BaudRate::B576000),
    (921_600, BaudRate::B921600),
    (1_000_000, BaudRate::B1000000),
];

/// The termios rate for `bps`, if it is one of the standard ones above.
pub fn baud_rate(bps: u32) -> Option<BaudRate> {
    RATES.iter().find(|(b, _)| *b == bps).map(|(_, r)| *r)
}

/// Bits per second of a termios rate, if it is one of the standard ones.
pub fn bits_per_second(rate: BaudRate) -> Option<u32> {
    RATES.iter().find(|(_, r)| *r == rate).map(|(b, _)| *b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scrambled_bytes_never_look_like_framing() {
        let mut s = Scrambler::default();
        for _ in 0..10 {
            for b in 0..=255u8 {
                assert!(!matches!(s.byte(b), 0x02 | 0x06 | 0x15));
            }
        }
    }
    use std::fs::File;
    use std::io::{Read, Write};
    use std::os::fd::AsFd;

    fn open_client(path: &Path) -> File {
        OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(OFlag::O_NOCTTY.bits() | OFlag::O_NONBLOCK.bits())
            .open(path)
            .unwrap()
    }

    #[test]
    fn pty_sees_client_speed_and_connection() {
        let pty = Pty::open(9600).unwrap();
        assert!(pty.slave_path().starts_with("/dev/pts"));
        // Armed: no client reads as hung up, reads as closed.
        assert!(!pty.client_connected().unwrap());
        assert_eq!(pty.read(&mut [0; 8]).unwrap(), ReadOutcome::Closed);
        assert_eq!(pty.client_speed().unwrap(), Some(9600));

        let mut client = open_client(pty.slave_path());
        assert!(pty.client_connected().unwrap());
        assert_eq!(pty.read(&mut [0; 8]).unwrap(), ReadOutcome::Empty);
        // The client's speed, 500 kBd included, is visible on the master.
        let mut t = tcgetattr(client.as_fd()).unwrap();
        cfsetspeed(&mut t, BaudRate::B500000).unwrap();
        tcsetattr(client.as_fd(), SetArg::TCSANOW, &t).unwrap();
        assert_eq!(pty.client_speed().unwrap(), Some(500_000));

        // Raw both ways: 0x03 (^C), CR and LF pass unchanged.
        let bytes = [0x02, 0x03, 0x0D, 0x0A, 0x7F, 0xFF];
        client.write_all(&bytes).unwrap();
        assert!(pty.wait_readable(Duration::from_secs(1)).unwrap());
        let mut buf = [0u8; 16];
        assert_eq!(pty.read(&mut buf).unwrap(), ReadOutcome::Data(6));
        assert_eq!(&buf[..6], &bytes);
        assert_eq!(pty.write(&bytes).unwrap(), WriteOutcome::Written(6));
        let mut got = [0u8; 16];
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(client.read(&mut got).unwrap(), 6);
        assert_eq!(&got[..6], &bytes);

        drop(client);
        assert!(!pty.client_connected().unwrap());
        assert_eq!(pty.read(&mut buf).unwrap(), ReadOutcome::Closed);
        // A second client can connect.
        let _again = open_client(pty.slave_path());
        assert!(pty.client_connected().unwrap());
    }

    #[test]
    fn pty_rates() {
        assert_eq!(bits_per_second(BaudRate::B38400), Some(38400));
        assert_eq!(baud_rate(500_000), Some(BaudRate::B500000));
        assert_eq!(baud_rate(12345), None);
        assert_eq!(bits_per_second(BaudRate::B0), None);
    }
}
