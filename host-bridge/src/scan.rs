//! `host-bridge scan`: record scans from an LMS 2xx (or `host-bridge
//! simulate`) into a [capture file](crate::capture).
//!
//! The session ([`run_session`]), on any [`Link`]:
//!
//! 1. find the sensor's rate ([`Client::find_baud`]: 9600 first, where a
//!    sensor powers up, then 19200, 38400, 500000);
//! 2. set the variant (`3B`) and the units (`74`, and if they differ
//!    `20 00 SICK_LMS`, `77`, `20 25`);
//! 3. switch to the target rate (`20 4x`, reply at the old rate);
//! 4. stream (`20 24`) and read N scans, or request each with `30 01`
//!    (`--single`);
//! 5. stop the stream (`20 25`) and, unless told otherwise, put the sensor
//!    back at 9600 Bd as the usual driver does on exit.
//!
//! [`run`] wraps it for the command line: a real serial port, a progress
//! bar on a terminal, the capture written to `NAME.partial` and renamed when
//! all scans are in, and a summary on stderr. Every record is flushed to
//! the file as it comes, so a kill or a power loss costs at most the
//! record being written, and every reader keeps the complete records of a
//! cut file. `-o` is checked before the sensor is touched (not a
//! directory, in an existing directory); without `-o` the run is refused
//! unless `--no-save` says so; a run that fails before the first scan
//! leaves no file. Ctrl-C (SIGINT), SIGTERM or SIGHUP (a closed terminal)
//! at any stage — the search for the sensor included — ends the run: the
//! stream is stopped, the sensor put back at 9600 Bd (unless
//! `--keep-baud`), the scans so far are left in `NAME.partial`, and the
//! exit status is non-zero; a second signal exits at once.
//!
//! `-o NAME.mcap` records an MCAP file instead of a capture
//! ([`crate::ros2::mcap_out::Recording`]): each scan as it is complete,
//! with the features the std pipeline computes for it (default
//! parameters), as `sensor_msgs/msg/LaserScan`, markers and
//! `lms_features_msgs/msg/Features`, stamped with the computer's clock.
//! A chunk is closed every second, so a killed recorder leaves every
//! chunk but the last readable; a signal or an error ends the session
//! with the file finished (summary and indexes).
//!
//! `--foxglove [ADDR]` shows the scans received live in Foxglove, with the
//! features the std pipeline computes for them on this computer (default
//! parameters, as `extract` uses for the capture), off the reading thread
//! ([`crate::live_view::LiveFeed`]).

use std::fmt;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::str::FromStr;
use std::sync::atomic::Ordering;
use std::time::Duration;

use anyhow::{bail, ensure, Context, Result};
use clap::Args;
use lms_core::telegram::{Baud, FramerStats};
use lms_core::Unit;
use lms_core::Variant;

use crate::capture::CaptureFile;
use crate::client::{Client, ClientStats, Scan, Timeouts};
use crate::options::UnitArg;
use crate::ros2::mcap_out::Recording;
use crate::ros2::rosbag2_out::Format;
use crate::serial::{Link, SerialLink};

/// `--baud`: the rate to stream at, or `auto` to keep the one found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaudChoice {
    /// Keep the rate the sensor was found at.
    Auto,
    /// Switch to this rate.
    Rate(Baud),
}

impl FromStr for BaudChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(BaudChoice::Auto);
        }
        s.parse::<u32>()
            .ok()
            .and_then(Baud::from_bits_per_second)
            .map(BaudChoice::Rate)
            .ok_or_else(|| {
                format!(
                    "`{s}` is not a rate of the LMS 2xx: use auto, 9600, 19200, 38400 or 500000"
                )
            })
    }
}

impl fmt::Display for BaudChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BaudChoice::Auto => f.write_str("auto"),
            BaudChoice::Rate(b) => write!(f, "{}", b.bits_per_second()),
        }
    }
}

/// `--variant`: field of view / resolution in degrees, e.g. `180/0.5`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VariantChoice(pub Variant);

impl FromStr for VariantChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let v = match s.trim_end_matches('°') {
            "180/1" => Variant::Fov180Res100,
            "180/0.5" => Variant::Fov180Res50,
            "100/1" => Variant::Fov100Res100,
            "100/0.5" => Variant::Fov100Res50,
            "100/0.25" => Variant::Fov100Res25,
            _ => {
                return Err(format!(
                    "`{s}` is not a variant of the LMS 2xx: use 180/1, 180/0.5, 100/1, 100/0.5 or 100/0.25 \
                     (field of view / resolution, degrees)"
                ))
            }
        };
        Ok(VariantChoice(v))
    }
}

/// A variant as `180°/0.5°`.
pub fn variant_name(v: Variant) -> String {
    format!(
        "{}°/{}°",
        v.fov_deg(),
        f64::from(v.resolution_centideg()) / 100.0
    )
}

impl fmt::Display for VariantChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        write!(
            f,
            "{}/{}",
            v.fov_deg(),
            f64::from(v.resolution_centideg()) / 100.0
        )
    }
}

/// Options of `host-bridge scan`.
#[derive(Args, Clone, Debug)]
pub struct ScanArgs {
    /// Serial port of the sensor, e.g. /dev/ttyUSB0 (or the pty printed by `host-bridge simulate`)
    #[arg(long, value_name = "PATH")]
    pub port: PathBuf,
    /// Rate to stream at (auto: stay at the rate the sensor is found at)
    #[arg(
        long,
        default_value = "500000",
        value_name = "auto|9600|19200|38400|500000"
    )]
    pub baud: BaudChoice,
    /// Scan variant, field of view / resolution in degrees: 180/1, 180/0.5, 100/1, 100/0.5, 100/0.25
    #[arg(long, default_value = "180/0.5", value_name = "FOV/RES")]
    pub variant: VariantChoice,
    /// Range units of the scans
    #[arg(long, default_value = "mm", value_parser = UnitArg::sensor_parser())]
    pub units: UnitArg,
    /// Number of scans to record
    #[arg(long, default_value_t = 100, value_name = "N")]
    pub scans: usize,
    /// Capture file to record the scans into (see the README's capture section);
    /// a name ending in .mcap records an MCAP file of ROS 2 messages instead
    /// (the scans with their features, as `extract -o x.mcap` writes them);
    /// required unless --no-save
    #[arg(
        long,
        short,
        value_name = "CAPTURE",
        required_unless_present = "no_save"
    )]
    pub output: Option<PathBuf>,
    /// Read the scans without saving them (a link test; without -o)
    #[arg(long, conflicts_with = "output")]
    pub no_save: bool,
    /// Request each scan with `30 01` instead of streaming (`20 24`)
    #[arg(long)]
    pub single: bool,
    /// Resends of a request the sensor answers with NAK
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub retries: u32,
    /// Leave the sensor at the streaming rate (default: back to 9600 Bd, its power-on rate)
    #[arg(long)]
    pub keep_baud: bool,
    /// `--foxglove`: the scans received, with their features, live in Foxglove.
    #[command(flatten)]
    pub live: crate::live_view::FoxgloveArgs,
}

/// What a session does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Plan {
    /// Rates to probe, in order.
    pub probe: Vec<Baud>,
    /// Rate to stream at; `None` keeps the rate found.
    pub target: Option<Baud>,
    /// Scan variant.
    pub variant: Variant,
    /// Range units.
    pub units: Unit,
    /// Scans to read (at least 1).
    pub scans: usize,
    /// `30 01` per scan instead of streaming.
    pub single: bool,
    /// Put the sensor back at 9600 Bd at the end.
    pub restore_9600: bool,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            probe: Baud::ALL.to_vec(),
            target: Some(Baud::B500000),
            variant: Variant::Fov180Res50,
            units: Unit::Millimetre,
            scans: 10,
            single: false,
            restore_9600: true,
        }
    }
}

/// What a session did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Summary {
    /// Scans read.
    pub scans: usize,
    /// The rate the sensor was found at.
    pub found_baud: Baud,
    /// The rate the scans came at.
    pub baud: Baud,
    /// From the start of the stream (or the first `30 01`) to the first scan.
    pub first: Duration,
    /// From the start of the stream (or the first `30 01`) to the last scan.
    pub elapsed: Duration,
    /// Line counters while the scans came (CRC errors, resyncs, bytes skipped).
    pub line: FramerStats,
    /// Handshake counters of the whole session.
    pub handshake: ClientStats,
    /// Why putting the sensor back at 9600 Bd failed, if it did (the scans
    /// are complete all the same).
    pub restore_error: Option<String>,
}

impl Summary {
    /// Scans per second: between the first and the last scan when there
    /// are two or more, else over [`elapsed`](Self::elapsed).
    pub fn rate(&self) -> f64 {
        let (n, s) = if self.scans >= 2 {
            (
                self.scans - 1,
                (self.elapsed - self.first.min(self.elapsed)).as_secs_f64(),
            )
        } else {
            (self.scans, self.elapsed.as_secs_f64())
        };
        if s > 0.0 {
            n as f64 / s
        } else {
            0.0
        }
    }
}

/// `after − before`, field by field (the counters wrap).
pub fn framer_delta(after: &FramerStats, before: &FramerStats) -> FramerStats {
    FramerStats {
        telegrams: after.telegrams.wrapping_sub(before.telegrams),
        acks: after.acks.wrapping_sub(before.acks),
        naks: after.naks.wrapping_sub(before.naks),
        crc_errors: after.crc_errors.wrapping_sub(before.crc_errors),
        oversize: after.oversize.wrapping_sub(before.oversize),
        bad_headers: after.bad_headers.wrapping_sub(before.bad_headers),
        abandoned: after.abandoned.wrapping_sub(before.abandoned),
        resyncs: after.resyncs.wrapping_sub(before.resyncs),
        bytes_skipped: after.bytes_skipped.wrapping_sub(before.bytes_skipped),
    }
}

/// Run a session (see the [module docs](self)). `on_scan` gets each scan
/// with its index and its time since the stream started; an error from it
/// ends the session (after stopping the stream).
pub fn run_session<L: Link>(
    client: &mut Client<L>,
    plan: &Plan,
    mut on_scan: impl FnMut(usize, Duration, &Scan) -> Result<()>,
) -> Result<Summary> {
    ensure!(plan.scans > 0, "the number of scans must be at least 1");
    let found_baud = client
        .find_baud(&plan.probe)
        .context("looking for the sensor")?;
    client
        .set_variant(plan.variant)
        .with_context(|| format!("setting the variant {}", variant_name(plan.variant)))?;
    client
        .set_units(plan.units)
        .with_context(|| format!("setting the units to {:?}", plan.units))?;
    if let Some(target) = plan.target {
        client
            .set_baud(target)
            .with_context(|| format!("switching to {} Bd", target.bits_per_second()))?;
    }
    let baud = client.baud();

    let line_before = client.framer_stats();
    let result = read_scans(client, plan, &mut on_scan);
    let line = framer_delta(&client.framer_stats(), &line_before);
    let (first, elapsed) = match result {
        Ok(times) => times,
        Err(e) => {
            // Best effort: leave the sensor quiet and, if it still answers,
            // at 9600 Bd as asked.
            let quiet = !client.is_streaming() || client.stop_stream().is_ok();
            if quiet && plan.restore_9600 && client.baud() != Baud::B9600 {
                let _ = client.set_baud(Baud::B9600);
            }
            return Err(e);
        }
    };

    let mut restore_error = None;
    if plan.restore_9600 && client.baud() != Baud::B9600 {
        if let Err(e) = client.set_baud(Baud::B9600) {
            restore_error = Some(e.to_string());
        }
    }
    Ok(Summary {
        scans: plan.scans,
        found_baud,
        baud,
        first,
        elapsed,
        line,
        handshake: client.stats(),
        restore_error,
    })
}

/// Read the scans of a plan; returns the times from the start to the first
/// and to the last scan.
fn read_scans<L: Link>(
    client: &mut Client<L>,
    plan: &Plan,
    on_scan: &mut impl FnMut(usize, Duration, &Scan) -> Result<()>,
) -> Result<(Duration, Duration)> {
    let mut first = Duration::ZERO;
    let mut last = Duration::ZERO;
    if plan.single {
        let start = client.now();
        for i in 0..plan.scans {
            let scan = client
                .single_scan()
                .with_context(|| format!("requesting scan {} of {}", i + 1, plan.scans))?;
            last = scan.time.saturating_sub(start);
            if i == 0 {
                first = last;
            }
            on_scan(i, last, &scan)?;
        }
        return Ok((first, last));
    }
    client.start_stream().context("starting the stream")?;
    let start = client.now();
    for i in 0..plan.scans {
        let scan = client
            .next_scan()
            .with_context(|| format!("reading scan {} of {}", i + 1, plan.scans))?;
        last = scan.time.saturating_sub(start);
        if i == 0 {
            first = last;
        }
        on_scan(i, last, &scan)?;
    }
    client.stop_stream().context("stopping the stream")?;
    Ok((first, last))
}

impl ScanArgs {
    /// The session these options ask for.
    pub fn plan(&self) -> Result<Plan> {
        ensure!(self.scans > 0, "--scans must be at least 1");
        Ok(Plan {
            probe: Baud::ALL.to_vec(),
            target: match self.baud {
                BaudChoice::Auto => None,
                BaudChoice::Rate(b) => Some(b),
            },
            variant: self.variant.0,
            units: self.units.unit().context("--units: mm or cm")?,
            scans: self.scans,
            single: self.single,
            restore_9600: !self.keep_baud,
        })
    }
}

/// Check `-o` before anything is sent: not a directory, in a directory
/// that exists; the `.partial` file is created (so that it can be
/// written) by [`CaptureFile::create`] right after.
pub fn check_output(path: &std::path::Path) -> Result<()> {
    ensure!(
        !path.is_dir(),
        "-o {}: that is a directory; give a capture file name, e.g. {}",
        path.display(),
        path.join("scans.lmscap").display()
    );
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    ensure!(
        parent.is_dir(),
        "-o {}: the directory {} does not exist",
        path.display(),
        parent.display()
    );
    Ok(())
}

/// `host-bridge scan`.
pub fn run(args: &ScanArgs) -> Result<()> {
    let plan = args.plan()?;
    if let Some(path) = &args.output {
        check_output(path)?;
    }
    // SIGINT / SIGTERM / SIGHUP at any stage (the search included): the
    // link reports the signal at its next read, the session stops the
    // stream and restores 9600 Bd, the scans so far stay in `.partial`;
    // a second signal exits at once with status 130.
    let interrupted = crate::stop::interrupt_flag()?;
    let link = SerialLink::open(&args.port, Baud::B9600)?;
    let link = Interruptible::new(link, interrupted.clone());
    let handled = link.handled();
    let mut client = Client::new(link, Baud::B9600, Timeouts::default());
    client.retries = args.retries;
    let (mut capture, mut recording) = open_output(args)?;
    // The features computed here, as `extract` does for the capture.
    let mut live = crate::live_view::LiveFeed::from_args(
        &args.live,
        "host-bridge scan",
        lms_core::ValidParams::DEFAULT,
    )?;
    let progress = progress_bar(plan.scans);
    let result = run_session(&mut client, &plan, |i, since_start, scan| {
        if let Some(c) = capture.as_mut() {
            let us = u64::try_from(since_start.as_micros()).unwrap_or(u64::MAX);
            c.write(us, &scan.telegram)?;
        }
        if let Some(r) = recording.as_mut() {
            record_scan(r, scan)?;
        }
        if let Some(live) = live.as_mut().filter(|l| l.watched()) {
            if let Ok(frame) = scan.values.to_frame(lms_core::telegram::RangeBits::Bits13) {
                live.send(crate::live_view::stamp_now(None), frame);
            }
        }
        progress.inc(1);
        if interrupted.load(Ordering::Relaxed) {
            // Reported here: the link lets the clean-up through.
            handled.store(true, Ordering::Relaxed);
            bail!(
                "interrupted by a signal after {} of {} scans",
                i + 1,
                plan.scans
            );
        }
        Ok(())
    });
    progress.finish_and_clear();
    if let Some(live) = live.take() {
        eprintln!("host-bridge scan: {}", live.summary());
    }
    let recorded = recording.map(Recording::finish);
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            return Err(with_recording(
                incomplete_capture(e, capture, args),
                recorded,
            ))
        }
    };
    let capture_line = saved_line(capture, recorded)?;
    print_summary(args, &plan, &summary, &capture_line);
    if let Some(e) = &summary.restore_error {
        crate::warning::warn(&format!(
            "scan: could not put the sensor back at 9600 Bd: {e}"
        ));
    }
    Ok(())
}

/// `-o`: a capture file, or with a name ending in `.mcap` an MCAP recording
/// of ROS 2 messages (the scans with the features the std pipeline
/// computes for them with the default parameters, as `extract` does for a
/// capture; see [`Recording`]).
fn open_output(args: &ScanArgs) -> Result<(Option<CaptureFile>, Option<Recording>)> {
    match &args.output {
        Some(path) if Format::choose(None, Some(path)) == Format::Mcap => Ok((
            None,
            Some(Recording::create(path, lms_core::ValidParams::DEFAULT)?),
        )),
        Some(path) => Ok((Some(CaptureFile::create(path)?), None)),
        None => Ok((None, None)),
    }
}

/// Record one scan received; a scan that makes no frame is counted.
fn record_scan(r: &mut Recording, scan: &Scan) -> Result<()> {
    match scan.values.to_frame(lms_core::telegram::RangeBits::Bits13) {
        Ok(frame) => r.record(&frame),
        Err(_) => {
            r.skipped += 1;
            Ok(())
        }
    }
}

/// The session's error, saying what the MCAP recording holds (it is
/// finished, summary and indexes written, whatever ended the session).
fn with_recording(e: anyhow::Error, recorded: Option<Result<String>>) -> anyhow::Error {
    match recorded {
        Some(Ok(line)) => e.context(format!("the scans so far are kept: {line}")),
        Some(Err(f)) => e.context(format!("the MCAP recording could not be finished: {f:#}")),
        None => e,
    }
}

/// The summary's line on what was saved: the capture (renamed from its
/// `.partial`), the MCAP recording, or nothing.
fn saved_line(capture: Option<CaptureFile>, recorded: Option<Result<String>>) -> Result<String> {
    if let Some(c) = capture {
        let (records, bytes) = (c.records(), c.bytes());
        let path = c.commit()?;
        return Ok(format!(
            "\n  capture: {} ({records} scans, {bytes} bytes)",
            path.display()
        ));
    }
    match recorded {
        Some(line) => Ok(format!("\n  {}", line?)),
        None => Ok("\n  not saved (--no-save)".to_string()),
    }
}

/// A [`Link`] that reports a signal: once `flag` is set, its next
/// `receive` fails (once) with "interrupted by a signal", which ends
/// whatever the client is doing — the search for the sensor included;
/// after that it works again, so that the session can stop the stream and
/// restore the rate. Waits are cut into slices of [`Interruptible::SLICE`].
#[derive(Debug)]
pub struct Interruptible<L> {
    inner: L,
    flag: std::sync::Arc<std::sync::atomic::AtomicBool>,
    fired: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl<L: Link> Interruptible<L> {
    /// Longest wait between two looks at the flag.
    pub const SLICE: Duration = Duration::from_millis(50);

    /// Wrap `inner`; `flag` is set by the signal handler.
    pub fn new(inner: L, flag: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Self {
        Interruptible {
            inner,
            flag,
            fired: Default::default(),
        }
    }

    /// Set once the signal has been reported (by the link, or by the
    /// caller storing `true`): from then on the link works normally.
    pub fn handled(&self) -> std::sync::Arc<std::sync::atomic::AtomicBool> {
        self.fired.clone()
    }

    fn check(&mut self) -> std::io::Result<()> {
        if self.flag.load(Ordering::Relaxed) && !self.fired.swap(true, Ordering::Relaxed) {
            return Err(std::io::Error::other("interrupted by a signal"));
        }
        Ok(())
    }
}

impl<L: Link> Link for Interruptible<L> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.inner.send(bytes)
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        let end = self.inner.now() + timeout;
        loop {
            self.check()?;
            let left = end.saturating_sub(self.inner.now());
            let n = self.inner.receive(buf, left.min(Self::SLICE))?;
            if n > 0 || left <= Self::SLICE {
                return Ok(n);
            }
        }
    }

    fn set_baud(&mut self, baud: Baud) -> std::io::Result<()> {
        self.inner.set_baud(baud)
    }

    fn discard_input(&mut self) -> std::io::Result<()> {
        self.inner.discard_input()
    }

    fn now(&self) -> Duration {
        self.inner.now()
    }

    fn name(&self) -> String {
        self.inner.name()
    }
}

/// A progress bar of `scans` on a terminal, hidden otherwise.
fn progress_bar(scans: usize) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(scans as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} scanning {bar:30} {pos}/{len} scans, {per_sec}, {eta} left",
    ) {
        bar.set_style(style);
    }
    bar
}

/// The session's error, saying where the scans recorded so far are (the
/// `.partial` file is kept, not renamed); a `.partial` without a single
/// scan is removed.
fn incomplete_capture(
    e: anyhow::Error,
    capture: Option<CaptureFile>,
    args: &ScanArgs,
) -> anyhow::Error {
    let Some(c) = capture else {
        return e;
    };
    let (records, partial) = (c.records(), c.partial().to_owned());
    drop(c);
    if records == 0 {
        return match std::fs::remove_file(&partial) {
            Ok(()) => e.context("no scan was recorded (nothing saved)"),
            Err(r) => e.context(format!(
                "no scan was recorded; the empty {} could not be removed: {r}",
                partial.display()
            )),
        };
    }
    e.context(format!(
        "the capture is incomplete: {records} scans recorded so far are in {} \
         (not renamed to {}; every reader takes it as it is)",
        partial.display(),
        args.output
            .as_deref()
            .unwrap_or(partial.as_path())
            .display()
    ))
}

/// The closing summary on stderr: scans, rate, line and handshake counters.
fn print_summary(args: &ScanArgs, plan: &Plan, summary: &Summary, capture_line: &str) {
    use std::io::Write as _;
    let h = &summary.handshake;
    // A closed stderr (a hung-up terminal) is not an error of the scan.
    let _ = writeln!(
        std::io::stderr(),
        "host-bridge scan: {} scans from {} ({}, {} values, {}) at {} Bd (sensor found at {} Bd) in {:.2} s: {:.1} scans/s\n  \
         line: {} CRC errors, {} resyncs, {} bytes skipped; handshake: {} NAK resends, {} wrong-address telegrams ignored{}",
        summary.scans,
        args.port.display(),
        variant_name(plan.variant),
        plan.variant.beams(),
        plan.units,
        summary.baud.bits_per_second(),
        summary.found_baud.bits_per_second(),
        summary.elapsed.as_secs_f64(),
        summary.rate(),
        summary.line.crc_errors,
        summary.line.resyncs,
        summary.line.bytes_skipped,
        h.resends,
        h.wrong_address,
        capture_line,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_parse() {
        assert_eq!("auto".parse::<BaudChoice>(), Ok(BaudChoice::Auto));
        assert_eq!(
            "38400".parse::<BaudChoice>(),
            Ok(BaudChoice::Rate(Baud::B38400))
        );
        assert!("115200"
            .parse::<BaudChoice>()
            .unwrap_err()
            .contains("115200"));
        assert_eq!(
            "100/0.25".parse::<VariantChoice>(),
            Ok(VariantChoice(Variant::Fov100Res25))
        );
        assert!("180/0.25".parse::<VariantChoice>().is_err());
        assert_eq!(VariantChoice(Variant::Fov180Res50).to_string(), "180/0.5");
        assert_eq!(variant_name(Variant::Fov100Res25), "100°/0.25°");
    }
}
