//! [`SerialLink`]: a real serial port (or a pseudo-terminal's slave) as a
//! [`Link`].

use std::fmt;
use std::io::{self, Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use lms_core::telegram::Baud;

use super::{is_quiet, Link, WRITE_TIMEOUT};

/// A serial port that cannot be opened (or set up), with the reason.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OpenError {
    /// The device path.
    pub port: String,
    /// What went wrong, with a hint where one helps.
    pub detail: String,
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot open serial port {}: {}", self.port, self.detail)
    }
}

impl std::error::Error for OpenError {}

/// A real serial port (8N1, no flow control) through the `serialport`
/// crate, opened in exclusive mode.
///
/// Line speed: on Linux `serialport` sets every rate as an arbitrary
/// `termios2` speed (`BOTHER`). The four LMS 2xx rates are standard termios
/// speeds, so the link sets them by their standard codes (`B9600` …
/// `B500000`) instead, through a second descriptor on the device opened
/// before the port is made exclusive: right after opening, and for every
/// change. The line runs at the same rate either way; but the other end of
/// a pseudo-terminal (`host-bridge simulate`) and tools reading the speed
/// with `cfgetospeed` see the rate instead of `BOTHER`.
///
/// Writes block at most [`WRITE_TIMEOUT`] (2 s); a rate change first waits
/// until what was written has gone out.
pub struct SerialLink {
    port: Box<dyn serialport::SerialPort>,
    /// The second descriptor, for the standard speed code.
    control: std::fs::File,
    name: String,
    origin: Instant,
}

/// The termios speed code of an LMS 2xx rate.
fn termios_rate(baud: Baud) -> nix::sys::termios::BaudRate {
    use nix::sys::termios::BaudRate;
    match baud {
        Baud::B9600 => BaudRate::B9600,
        Baud::B19200 => BaudRate::B19200,
        Baud::B38400 => BaudRate::B38400,
        Baud::B500000 => BaudRate::B500000,
    }
}

/// Set the standard termios speed code for `baud` on `file` (a terminal).
fn set_standard_speed(file: &std::fs::File, baud: Baud) -> io::Result<()> {
    use nix::sys::termios::{cfsetspeed, tcgetattr, tcsetattr, SetArg};
    let mut t = tcgetattr(file)?;
    cfsetspeed(&mut t, termios_rate(baud))?;
    tcsetattr(file, SetArg::TCSANOW, &t)?;
    Ok(())
}

impl fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SerialLink")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// The control descriptor: the device opened without becoming its
/// controlling terminal, non-blocking (a port with no carrier opens too).
fn open_control(path: &Path) -> Result<std::fs::File, String> {
    use std::os::unix::fs::OpenOptionsExt;
    let flags = nix::fcntl::OFlag::O_NOCTTY | nix::fcntl::OFlag::O_NONBLOCK;
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(flags.bits())
        .open(path)
        .map_err(|e| match e.kind() {
            io::ErrorKind::PermissionDenied => {
                format!("{e} (is the user allowed to use serial ports, e.g. in group dialout?)")
            }
            _ if e.raw_os_error() == Some(nix::libc::EBUSY) => {
                format!("{e} (is another program using it?)")
            }
            _ => e.to_string(),
        })
}

/// The port itself through `serialport`: 8N1, no flow control, exclusive.
fn open_port(path: &str, baud: Baud) -> Result<Box<dyn serialport::SerialPort>, String> {
    serialport::new(path, baud.bits_per_second())
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| match e.kind {
            serialport::ErrorKind::NoDevice => {
                format!("{} (is another program using it?)", e.description)
            }
            // ENOTTY
            _ if e.description == "Not a typewriter" => {
                "not a serial port (not a terminal device)".into()
            }
            _ => e.description,
        })
}

impl SerialLink {
    /// Open the port at `path` at `baud`. A path that does not exist, a port
    /// in use or one that refuses the settings gives an error naming the path.
    pub fn open(path: &Path, baud: Baud) -> Result<Self, OpenError> {
        let name = path.display().to_string();
        let open_error = |detail: String| OpenError {
            port: name.clone(),
            detail,
        };
        if !path.exists() {
            return Err(open_error("no such file or device".into()));
        }
        let path_str = path
            .to_str()
            .ok_or_else(|| open_error("the path is not valid UTF-8".into()))?;
        let control = open_control(path).map_err(open_error)?;
        let port = open_port(path_str, baud).map_err(open_error)?;
        set_standard_speed(&control, baud)
            .map_err(|e| open_error(format!("cannot set {} Bd: {e}", baud.bits_per_second())))?;
        Ok(SerialLink {
            port,
            control,
            name,
            origin: Instant::now(),
        })
    }
}

fn to_io(e: serialport::Error) -> io::Error {
    match e.kind {
        serialport::ErrorKind::Io(kind) => io::Error::new(kind, e.description),
        _ => io::Error::other(e.description),
    }
}

impl Link for SerialLink {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.set_timeout(WRITE_TIMEOUT).map_err(to_io)?;
        self.port.write_all(bytes)
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.port.set_timeout(timeout).map_err(to_io)?;
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e) if is_quiet(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }

    fn set_baud(&mut self, baud: Baud) -> io::Result<()> {
        // What was sent goes out at the old rate (`tcdrain`).
        self.port.set_timeout(WRITE_TIMEOUT).map_err(to_io)?;
        self.port.flush()?;
        // The standard code only (see the type's docs): the same line rate
        // as `serialport`'s `set_baud_rate`, without a moment at `BOTHER`.
        set_standard_speed(&self.control, baud)
    }

    fn discard_input(&mut self) -> io::Result<()> {
        self.port
            .clear(serialport::ClearBuffer::Input)
            .map_err(to_io)
    }

    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn name(&self) -> String {
        self.name.clone()
    }
}
