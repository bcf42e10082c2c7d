//! `host-bridge coprocessor`: the core's [`CoProcessor`] natively, between a
//! sensor on a serial port and a pseudo-terminal for the client.
//!
//! ```text
//! host-bridge coprocessor --sensor PORT --link PATH [--variant FOV/RES] [--units mm|cm]
//!                         [--status-every SECONDS] [--quit-after SECONDS] [--foxglove [ADDR]]
//!                         [pipeline options]
//! ```
//!
//! The same code as the firmware: it brings the LMS on `PORT` up (9600 Bd
//! at first, then 500 kBd), and offers the client a pseudo-terminal,
//! symlinked at `PATH`, that behaves like an LMS 2xx (see
//! `lms_core::device::coprocessor` and docs/PROTOCOL.md: by default only
//! what an LMS sends; the features after `56 01`). The client picks its own
//! speed on the pseudo-terminal with `20 4x`, as with a real LMS; the
//! co-processor's host-line budget follows that speed (a pty itself carries
//! bytes at memory speed). The budget judges each scan by when it reached
//! the sensor port, not by when the loop got to it: on a loaded computer
//! the loop may be held off for a third of a second, and the scans that
//! queued meanwhile reach the co-processor with their arrival times
//! ([`crate::serial::Arrivals`]).
//!
//! A status line goes to stderr every `--status-every` seconds (scans in
//! and out, host-line drops, sensor CRC errors, the sensor's bring-up state,
//! the client's rate, mode and feature output). SIGINT/SIGTERM (Ctrl-C)
//! stops the sensor's stream (`20 25`), removes the link and exits with 0.
//!
//! `-o FILE.mcap` records the sensor's scans with those features into an
//! MCAP file of ROS 2 messages (as `extract -o x.mcap` writes them,
//! stamped with the computer's clock; a chunk closed every second; the
//! file finished on Ctrl-C or SIGTERM, see
//! [`crate::ros2::mcap_out::Recording`]).
//!
//! `--foxglove [ADDR]` shows the sensor's scans live in Foxglove with their
//! features, computed off the co-processor's loop by the std pipeline with
//! the same parameters, which gives the co-processor's features bit for bit
//! ([`crate::live_view::StreamView`]; not with `--qemu`).

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{ensure, Context, Result};
use clap::Args;
use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
use lms_core::telegram::features::CounterKind;
use lms_core::telegram::{Baud, RangeBits, Request};
use lms_core::{Unit, ValidParams};

use crate::live_view::{ScanTap, StreamView};
use crate::options::{ParamArgs, UnitArg};
use crate::pty::Pty;
use crate::ros2::mcap_out::Recording;
use crate::scan::{variant_name, VariantChoice};
use crate::serial::{Link, PtyPort, SerialLink, TICK};
use crate::simulate::symlink::Symlink;

mod pc;
mod qemu_bridge;

pub use pc::PcCoProcessor;

/// Options of `host-bridge coprocessor`.
#[derive(Args, Debug, Clone)]
pub struct CoprocessorArgs {
    /// Serial port of the sensor, e.g. /dev/ttyUSB0 (or the pty of `host-bridge simulate`)
    #[arg(long, value_name = "PORT")]
    pub sensor: PathBuf,
    /// Make a pseudo-terminal for the client and a symbolic link to it here
    /// (an existing symlink is replaced; removed on exit)
    #[arg(long, value_name = "PATH")]
    pub link: PathBuf,
    /// Variant the sensor is brought up with until the client sets one (FOV/RES)
    #[arg(long, default_value = "180/0.5", value_name = "FOV/RES")]
    pub variant: VariantChoice,
    /// Units the sensor is brought up with until the client sets them
    #[arg(long, default_value = "mm", value_parser = UnitArg::sensor_parser())]
    pub units: UnitArg,
    /// Seconds between status lines on stderr (0: none)
    #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
    pub status_every: f64,
    /// Exit after this many seconds
    #[arg(long, value_name = "SECONDS")]
    pub quit_after: Option<f64>,
    /// Run the real firmware under QEMU (default ELF: the release build in
    /// firmware/target) instead of the core's CoProcessor natively; the bytes
    /// are passed between its UARTs, the sensor port and the client's pty
    #[arg(long, value_name = "ELF", num_args = 0..=1)]
    pub qemu: Option<Option<PathBuf>>,
    /// Pipeline parameters (the ALGORITHM.md defaults unless set).
    #[command(flatten)]
    pub params: ParamArgs,
    /// `--foxglove`: the sensor's scans, with their features, live in Foxglove.
    #[command(flatten)]
    pub live: crate::live_view::FoxgloveArgs,
    /// Record the sensor's scans with their features into this MCAP file
    /// (ROS 2 messages, as `extract -o x.mcap` writes them; finished on
    /// Ctrl-C or SIGTERM)
    #[arg(long, short, value_name = "FILE.mcap")]
    pub output: Option<PathBuf>,
}

/// A [`Link`] as an `embedded-io` port: `read_ready` takes what has
/// arrived into a buffer.
struct LinkPort {
    link: SerialLink,
    buf: Vec<u8>,
    /// `--foxglove`: the bytes read go to it too, framed with `bits`; it
    /// shows the scans with the features of the co-processor's parameters
    /// (the std pipeline computes them bit for bit as the co-processor).
    live: Option<StreamView>,
    bits: RangeBits,
    /// `-o FILE.mcap`: the bytes read go to it too, framed with `bits`.
    record: Option<Recorder>,
}

/// `-o FILE.mcap`: the sensor's scans, picked out of its byte stream
/// ([`ScanTap`]), recorded with the features the std pipeline computes
/// with the co-processor's parameters (its features, bit for bit).
struct Recorder {
    tap: ScanTap,
    recording: Recording,
}

impl Recorder {
    /// The recorder of `-o`, if given.
    fn from_args(args: &CoprocessorArgs, params: lms_core::ValidParams) -> Result<Option<Self>> {
        let Some(path) = &args.output else {
            return Ok(None);
        };
        Ok(Some(Recorder {
            tap: ScanTap::default(),
            recording: Recording::create(path, params)?,
        }))
    }

    /// Record the complete scans in `bytes`.
    fn bytes(&mut self, bytes: &[u8], bits: RangeBits) -> Result<()> {
        let mut result = Ok(());
        let recording = &mut self.recording;
        self.tap.feed(bytes, bits, |frame| {
            if result.is_ok() {
                result = recording.record(&frame);
            }
        });
        result
    }

    /// Finish the file; the line that says what it holds.
    fn finish(mut self) -> Result<String> {
        self.recording.skipped += self.tap.skipped;
        self.recording.finish()
    }
}

/// After the loop: the live view's summary, the recording finished.
fn close_outputs(sensor: &mut LinkPort) -> Result<()> {
    if let Some(live) = sensor.live.take() {
        eprintln!("host-bridge coprocessor: {}", live.summary());
    }
    if let Some(record) = sensor.record.take() {
        eprintln!("host-bridge coprocessor: {}", record.finish()?);
    }
    Ok(())
}

impl LinkPort {
    /// Take the range bits of the sensor's measuring mode, as the
    /// co-processor knows it, for the scans the outputs frame.
    fn follow(&mut self, cop: &CoProcessor) {
        if self.live.is_some() || self.record.is_some() {
            self.bits = cop.link().config().map_or(RangeBits::Bits13, |c| {
                RangeBits::from_measuring_mode(c.measuring_mode())
            });
        }
    }

    /// Wait up to `timeout` for bytes (into the buffer).
    fn fill(&mut self, timeout: Duration) -> io::Result<()> {
        if !self.buf.is_empty() {
            return Ok(());
        }
        let mut chunk = [0u8; 4096];
        let n = self.link.receive(&mut chunk, timeout)?;
        self.buf.extend_from_slice(&chunk[..n]);
        if let Some(live) = self.live.as_mut() {
            live.sensor_bytes(&chunk[..n], self.bits);
        }
        if let Some(record) = self.record.as_mut() {
            record
                .bytes(&chunk[..n], self.bits)
                .map_err(io::Error::other)?;
        }
        Ok(())
    }
}

impl embedded_io::ErrorType for LinkPort {
    type Error = io::Error;
}

impl embedded_io::ReadReady for LinkPort {
    fn read_ready(&mut self) -> io::Result<bool> {
        self.fill(Duration::ZERO)?;
        Ok(!self.buf.is_empty())
    }
}

impl embedded_io::Read for LinkPort {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        let n = out.len().min(self.buf.len());
        out[..n].copy_from_slice(&self.buf[..n]);
        self.buf.drain(..n);
        Ok(n)
    }
}

impl embedded_io::Write for LinkPort {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.link.send(bytes)?;
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

fn check_args(args: &CoprocessorArgs) -> Result<()> {
    ensure!(
        args.status_every.is_finite() && args.status_every >= 0.0,
        "--status-every must be >= 0 (seconds)"
    );
    if let Some(q) = args.quit_after {
        ensure!(
            q.is_finite() && q >= 0.0,
            "--quit-after must be >= 0 (seconds)"
        );
    }
    ensure!(
        args.qemu.is_none() || args.live.foxglove.is_none(),
        "--foxglove is not available with --qemu (the firmware's lines are bridged as bytes)"
    );
    ensure!(
        args.qemu.is_none() || args.output.is_none(),
        "-o is not available with --qemu (the firmware's lines are bridged as bytes)"
    );
    if let Some(path) = &args.output {
        crate::scan::check_output(path)?;
    }
    Ok(())
}

/// The parameters the co-processor runs, validated, and the sensor set-up
/// it brings the LMS up with (500 kBd).
fn params_and_setup(args: &CoprocessorArgs) -> Result<(ValidParams, SensorSetup)> {
    check_args(args)?;
    args.params.ensure_coprocessor_runs_them()?;
    let params = args
        .params
        .to_params()?
        .validate()
        .map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
    let setup = SensorSetup {
        variant: args.variant.0,
        units: args.units.unit().unwrap_or(Unit::Millimetre),
        baud: Baud::B500000,
    };
    Ok((params, setup))
}

/// Run `host-bridge coprocessor`.
pub fn run(args: &CoprocessorArgs) -> Result<()> {
    let (params, setup) = params_and_setup(args)?;
    let link = SerialLink::open(&args.sensor, Baud::B9600)
        .with_context(|| "--sensor: cannot open the sensor's port".to_string())?;
    if let Some(elf) = &args.qemu {
        return run_qemu(args, link, elf.as_deref());
    }
    let sensor = LinkPort {
        link,
        buf: Vec::new(),
        live: StreamView::from_args(&args.live, "host-bridge coprocessor", params)?,
        bits: RangeBits::Bits13,
        record: Recorder::from_args(args, params)?,
    };
    let pty = Pty::open(Baud::B9600.bits_per_second())?;
    let symlink = Symlink::create(&args.link, pty.slave_path())?;
    let mut host = PtyPort::new(pty);
    let stop = crate::stop::stop_flag()?;
    eprintln!(
        "host-bridge coprocessor: sensor {} (brought up at {} in {}), client line {} -> {}",
        args.sensor.display(),
        variant_name(setup.variant),
        setup.units,
        symlink.path.display(),
        host.slave_path().display()
    );
    let mut pc = PcCoProcessor::start(params, setup, sensor);
    let status_every = Duration::from_secs_f64(args.status_every);
    let quit_after = args.quit_after.map(Duration::from_secs_f64);
    let mut next_status = Instant::now() + status_every;
    let reason = loop {
        if stop.load(Ordering::Relaxed) {
            break "signal";
        }
        if quit_after.is_some_and(|q| pc.elapsed() >= q) {
            break "--quit-after";
        }
        // The client line is the face's UART: a client at another rate
        // (a driver's power-on search) is noise to it, as on a real line.
        host.set_line_rate(pc.cop().host_face().baud().bits_per_second());
        let outcome = pc.poll(&mut host)?;
        if let Some(b) = outcome.sensor_baud {
            pc.sensor_mut()
                .link
                .set_baud(b)
                .context("sensor port: cannot switch the rate")?;
        }
        let (cop, sensor) = pc.parts();
        sensor.follow(cop);
        if args.status_every > 0.0 && Instant::now() >= next_status {
            eprintln!("{}", status(pc.cop(), &host, pc.elapsed()));
            next_status += status_every;
        }
        pc.sensor_mut().fill(TICK)?;
    };
    stop_sensor(pc.sensor_mut());
    eprintln!(
        "host-bridge coprocessor: stopped ({reason}); {}",
        status(pc.cop(), &host, pc.elapsed())
    );
    close_outputs(pc.sensor_mut())?;
    drop(symlink);
    Ok(())
}

/// `--qemu`: the firmware between the sensor and the client.
fn run_qemu(args: &CoprocessorArgs, mut sensor: SerialLink, elf: Option<&Path>) -> Result<()> {
    let pty = Pty::open(Baud::B9600.bits_per_second())?;
    let symlink = Symlink::create(&args.link, pty.slave_path())?;
    let mut client = PtyPort::new(pty);
    let stop = crate::stop::stop_flag()?;
    let quit_after = args.quit_after.map(Duration::from_secs_f64);
    let bound = quit_after.unwrap_or(Duration::from_secs(24 * 3600)) + Duration::from_secs(10);
    let mut qemu = crate::qemu::connect(elf, bound, &stop)?;
    eprintln!(
        "host-bridge coprocessor: the firmware under QEMU between sensor {} and client line {} -> {}",
        args.sensor.display(),
        symlink.path.display(),
        client.slave_path().display()
    );
    let reason = qemu_bridge::bridge(&mut sensor, &mut client, &mut qemu, &stop, quit_after)?;
    let mut buf = [0u8; 16];
    if let Ok(n) = Request::OnRequest.emit(0, &mut buf) {
        let _ = sensor.send(&buf[..n]);
    }
    eprintln!("host-bridge coprocessor: stopped ({reason})");
    drop(symlink);
    Ok(())
}

/// Stop the sensor's stream (`20 25`), so that it does not stream on with
/// nobody listening; wait briefly for the bytes to go out.
fn stop_sensor(sensor: &mut LinkPort) {
    let mut buf = [0u8; 16];
    if let Ok(n) = Request::OnRequest.emit(0, &mut buf) {
        let _ = sensor.link.send(&buf[..n]);
        let _ = sensor.fill(Duration::from_millis(50));
    }
}

/// The status line: every counter but the boot's (`name=value`, as `D5`
/// and the firmware's console name them), the sensor link, the client's
/// face; `host` is the client line (its bytes at another rate).
fn status(cop: &CoProcessor, host: &PtyPort, elapsed: Duration) -> String {
    let mut line = format!("[{:8.1} s]", elapsed.as_secs_f64());
    let counters = cop.counters();
    for (name, _, value) in counters.entries().filter(|e| e.1 != CounterKind::Boot) {
        let _ = write!(line, " {name}={value}");
    }
    let face = cop.host_face();
    let setup = cop.link().setup();
    let _ = write!(
        line,
        "; sensor {:?} ({} {}); client {} Bd, mode {:02X}, {} {}, features {}, \
         bytes at another rate {}",
        cop.link().step(),
        variant_name(setup.variant),
        setup.units,
        face.baud().bits_per_second(),
        face.operating_mode().code(),
        variant_name(face.variant()),
        face.units(),
        if cop.features_on() { "on" } else { "off" },
        host.bytes_at_another_rate(),
    );
    line
}
