//! `host-bridge simulate`: a simulated LMS 2xx on a real pseudo-terminal.
//!
//! ```text
//! host-bridge simulate [--link PATH] [--verbose]
//!                      [--scene room|corridor|random] [--seed N] [--count N]
//!                      [--noise-sigma S] [--dropout P]
//!                      [--replay LOG]
//!                      [--scans N] [--quit-after SECONDS] [--restart-delay SECONDS]
//!                      [--bit-error-rate P] [--drop-rate P] [--fault-seed N]
//!                      [--variant FOV/RES] [--units cm|mm] [--range-mode 8|16|32]
//!                      [--foxglove [ADDR]]
//! ```
//!
//! `--variant`, `--units` and `--range-mode` are the sensor's stored
//! (power-on) configuration, as a real LMS keeps them in EEPROM: a client
//! that sets nothing gets scans of that variant in those units, with 13
//! (8 m), 14 (16 m) or 15 (32 m) range bits (default 180°/1°, cm, 8 m, the
//! LMS's factory setting); `10` (reset) returns to them. The range mode is
//! the configuration's measuring-mode byte (`00`, `04`, `06`); the scene's
//! values are encoded with its range bits (a replayed log keeps 13).
//!
//! It opens a pseudo-terminal ([`crate::pty`]), prints the slave device
//! (e.g. `/dev/pts/7`) as one line on stdout, optionally links `--link` to
//! it, and runs [`lms_core::device::emulator::Emulator`] behind it: the client's
//! bytes are fed in with the monotonic clock, the sensor's bytes are written
//! paced at the sensor's current line rate (10 bits per byte). An unmodified
//! LMS 2xx client opens the device like a serial port.
//!
//! # Line speed
//!
//! A pty carries bytes whatever speed is set, but a real serial line does
//! not: when the client's termios speed (read on the master, see
//! [`crate::pty`]) differs from the sensor's current rate, both directions
//! are noise.
//!
//! * Client → sensor: the bytes are dropped (the sensor's UART discards
//!   bytes with framing errors), so a request sent at the wrong speed gets
//!   no answer at all.
//! * Sensor → client: every byte is replaced by a pseudo-random one, never
//!   `STX` (0x02), `ACK` (0x06) or `NAK` (0x15), so the client sees traffic
//!   but nothing it could take for a telegram or a handshake (a real line
//!   could produce those by chance; excluding them keeps the simulation
//!   deterministic for tests).
//!
//! So a client that probes the rates with `20 4x` finds the sensor only at
//! its actual rate, and a client that forgets to follow a baud change reads
//! garbage, as on a real line.
//!
//! # Connections
//!
//! The sensor runs from start to exit, whether or not a client has the
//! device open (the stream goes on at its rate; a new client may have to
//! find the rate again). Bytes sent with no client are lost; a new client
//! starts with empty queues (both are flushed when a client goes away). Without a client the loop sleeps 20 ms at a
//! time (no busy polling on `POLLHUP`).
//!
//! # Scan sources
//!
//! * Default: the built-in synthetic scene ([`SceneSource`]) cast at the
//!   bearings of the current variant (all five) and drawn in the current
//!   units (mm or cm) with the `--noise-sigma`/`--dropout` noise; `--count`
//!   noisy draws are made per variant and units and sent in turn. At
//!   180°/0.5° in mm, scan `k` has the same values as frame `k mod count` of
//!   `host-bridge extract` with the same scene options.
//! * `--replay LOG`: the `FLASER` scans of a CARMEN log ([`ReplaySource`]),
//!   in order, looping. Scans are resampled to the variant the client asks
//!   for (stated on stderr): a coarser variant takes every 2nd/4th beam, a
//!   finer one repeats the nearest beam, a 100° variant takes 40°…140° of a
//!   180° log; a 180° variant from a 100° log is refused (`BB 00`).
//! * `--replay CAPTURE`: a capture recorded by `host-bridge scan`
//!   (recognised by its magic), its `B0` scans in order, looping, resampled
//!   and converted to the units asked for like a log's.
//!
//! # A faulty line
//!
//! `--bit-error-rate P` flips each bit on the line with probability `P`,
//! `--drop-rate P` loses each byte with probability `P`, in both directions
//! (seeded by `--fault-seed`, one generator per direction, so what reaches
//! the client depends only on what was sent), to try a client against a noisy RS-232/422
//! link: the sensor NAKs damaged requests, the client has to skip damaged
//! telegrams. The summary counts the bits flipped and bytes dropped.
//!
//! # Live view
//!
//! `--foxglove [ADDR]` serves the scans sent, with the features the std
//! pipeline computes for them (default parameters), to Foxglove
//! ([`crate::live_view`]): while a Foxglove client is subscribed, the bytes
//! sent are framed, and each `B0` goes to a thread that runs the pipeline
//! and publishes; the sensor's loop never waits for it.
//!
//! # Exit
//!
//! SIGINT, SIGTERM, `--quit-after SECONDS` or `--scans N` end the run
//! cleanly: the `--link` is removed and a summary goes to stderr. After the
//! N-th `B0` of `--scans N` nothing more is sent, and the device stays open
//! until the client closes it (at most 1 s), since closing the master would
//! drop the bytes the client has not read yet. `--verbose` logs requests, replies decided, baud
//! switches, stream start/stop, connections and speed mismatches.

//!
//! # Layout
//!
//! * Scan sources: [`SceneSource`] (`scene_source`), [`ReplaySource`]
//!   (`replay`), [`Source`] (`source`, the choice between them).
//! * `line` — the pty side between the client and the emulator (speed
//!   mismatch, line faults, counters); `symlink` — `--link`.
//! * `events` — the emulator's events, counted and logged.
//! * This module — the options and the main loop ([`run`]).

mod events;
mod line;
mod replay;
mod scene_source;
mod source;
pub(crate) mod symlink;

use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{ensure, Result};
use clap::builder::TypedValueParser as _;
use clap::Args;
use lms_core::device::emulator::{Emulator, Settings};
use lms_core::telegram::{Baud, RangeBits};
use lms_core::ValidParams;

use crate::live_view::StreamView;
use crate::pty::Pty;
use line::PtyLine;
pub use replay::ReplaySource;
pub use scene_source::SceneSource;
pub use source::Source;
use symlink::Symlink;

/// Longest sleep of the main loop while a client is connected.
const MAX_WAIT: Duration = Duration::from_millis(50);
/// Sleep of the main loop while no client has the device open.
const IDLE_WAIT: Duration = Duration::from_millis(20);
/// After `--scans N`: how long the device stays open for the client to read
/// the last scan.
const LINGER: Duration = Duration::from_secs(1);

/// Options of `host-bridge simulate`.
#[derive(Args, Debug, Clone)]
pub struct SimulateArgs {
    /// Also make a symbolic link to the pty's slave device here (an
    /// existing symlink is replaced; it is removed on exit)
    #[arg(long, value_name = "PATH")]
    pub link: Option<PathBuf>,
    /// The synthetic scene, or a log replayed (looping, resampled to the
    /// variant the client asks for).
    #[command(flatten)]
    pub play: crate::synthetic::PlayArgs,
    /// Exit after this many scans (B0 telegrams) have been sent
    #[arg(long, value_name = "N")]
    pub scans: Option<u64>,
    /// Exit after this many seconds
    #[arg(long, value_name = "SECONDS", value_parser = crate::options::seconds)]
    pub quit_after: Option<f64>,
    /// Time from the 91 reply to a reset until the 90 power-on telegram (s)
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = crate::options::seconds)]
    pub restart_delay: f64,
    /// Log requests, baud switches, connections and speed mismatches on
    /// stderr
    #[arg(long, short)]
    pub verbose: bool,
    /// A faulty line: flip each bit, in both directions, with this
    /// probability (e.g. 1e-5)
    #[arg(long, value_name = "P", default_value_t = 0.0)]
    pub bit_error_rate: f64,
    /// A faulty line: lose each byte, in both directions, with this
    /// probability
    #[arg(long, value_name = "P", default_value_t = 0.0)]
    pub drop_rate: f64,
    /// Seed of the line faults
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub fault_seed: u64,
    /// Stored (power-on) variant, FOV/RES: a real LMS keeps it in EEPROM
    #[arg(long, default_value = "180/1", value_name = "FOV/RES")]
    pub variant: crate::scan::VariantChoice,
    /// Stored (power-on) units of the range values
    #[arg(long, default_value = "cm", value_parser = crate::options::UnitArg::sensor_parser())]
    pub units: crate::options::UnitArg,
    /// Stored (power-on) range mode in metres (with mm: 8 → measuring mode 00,
    /// 13 range bits; 16 → 04, 14 bits; 32 → 06, 15 bits)
    #[arg(long, default_value_t = 8, value_name = "8|16|32",
          value_parser = clap::builder::PossibleValuesParser::new(["8", "16", "32"])
              .map(|s: String| s.parse::<u8>().unwrap_or(8)))]
    pub range_mode: u8,
    /// `--foxglove`: the scans sent, with their features, live in Foxglove.
    #[command(flatten)]
    pub live: crate::live_view::FoxgloveArgs,
}

impl SimulateArgs {
    /// The measuring-mode byte (`F4` `[5]`) of `--range-mode`.
    pub fn measuring_mode(&self) -> u8 {
        match self.range_mode {
            16 => 0x04,
            32 => 0x06,
            _ => 0x00,
        }
    }

    /// The power-on settings: variant, units and measuring mode in the
    /// configuration.
    fn settings(&self) -> Settings {
        let mut config = lms_core::telegram::Config::ZERO;
        config.set_units_code(u8::from(
            self.units.unit() == Some(lms_core::Unit::Millimetre),
        ));
        config.set_measuring_mode(self.measuring_mode());
        Settings {
            restart_us: (self.restart_delay * 1e6) as u64,
            variant: self.variant.0,
            config,
            ..Settings::default()
        }
    }
}

/// An error naming the first option out of range.
fn check_args(args: &SimulateArgs) -> Result<()> {
    if let Some(q) = args.quit_after {
        ensure!(
            q.is_finite() && q >= 0.0,
            "--quit-after must be >= 0 (seconds)"
        );
    }
    ensure!(
        args.restart_delay.is_finite() && args.restart_delay >= 0.0,
        "--restart-delay must be >= 0 (seconds)"
    );
    for (name, p) in [
        ("--bit-error-rate", args.bit_error_rate),
        ("--drop-rate", args.drop_rate),
    ] {
        ensure!(
            (0.0..=1.0).contains(&p),
            "{name} must be a probability in 0..=1, not {p}"
        );
    }
    Ok(())
}

/// Microseconds since `clock` (the emulator's time).
fn micros_since(clock: Instant) -> u64 {
    u64::try_from(clock.elapsed().as_micros()).unwrap_or(u64::MAX)
}

/// The device path as one line on stdout, then the banner on stderr.
fn announce(args: &SimulateArgs, pty: &Pty, link: Option<&Symlink>, about: &str) -> Result<()> {
    {
        let mut out = io::stdout().lock();
        writeln!(out, "{}", pty.slave_path().display())?;
        out.flush()?;
    }
    let mut banner = format!(
        "host-bridge simulate: LMS 2xx on {}",
        pty.slave_path().display()
    );
    if let Some(l) = link {
        let _ = write!(banner, " (link {})", l.path.display());
    }
    if args.bit_error_rate > 0.0 || args.drop_rate > 0.0 {
        let _ = write!(
            banner,
            " with line faults (bit error rate {:e}, drop rate {:e}, seed {})",
            args.bit_error_rate, args.drop_rate, args.fault_seed
        );
    }
    eprintln!(
        "{banner}; 9600 Bd, values on request, {} in {} ({} m range mode); scans from {about}",
        crate::scan::variant_name(args.variant.0),
        args.units.unit().unwrap_or(lms_core::Unit::Centimetre),
        args.range_mode
    );
    Ok(())
}

/// Run `host-bridge simulate`.
pub fn run(args: &SimulateArgs) -> Result<()> {
    check_args(args)?;
    let source = Source::open(args)?;
    let about = source.describe();
    let stop = crate::stop::stop_flag()?;

    let pty = Pty::open(Baud::B9600.bits_per_second())?;
    let link = match &args.link {
        Some(path) => Some(Symlink::create(path, pty.slave_path())?),
        None => None,
    };
    announce(args, &pty, link.as_ref(), &about)?;

    let clock = Instant::now();
    let settings = args.settings();
    let mut lms = Emulator::new(source, settings, micros_since(clock));
    let mut line = PtyLine::new(pty, args, clock);
    // The features of the scans sent, as `extract` computes them by default.
    let mut live = StreamView::from_args(&args.live, "host-bridge simulate", ValidParams::DEFAULT)?;
    let reason = serve(args, &mut lms, &mut line, &stop, clock, &mut live)?;
    if reason == "--scans" {
        linger(&mut line, &stop)?;
    }
    eprintln!("{}", summary(reason, clock, &lms, &line));
    if let Some(live) = live {
        eprintln!("host-bridge simulate: {}", live.summary());
    }
    drop(link);
    Ok(())
}

/// The main loop, until a stop condition; returns which one.
fn serve(
    args: &SimulateArgs,
    lms: &mut Emulator<Source>,
    line: &mut PtyLine,
    stop: &AtomicBool,
    clock: Instant,
    live: &mut Option<StreamView>,
) -> Result<&'static str> {
    let quit_after = args.quit_after.map(Duration::from_secs_f64);
    let mut out = [0u8; 4096];
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok("signal");
        }
        if quit_after.is_some_and(|q| clock.elapsed() >= q) {
            return Ok("--quit-after");
        }
        if args.scans.is_some_and(|n| line.counters.scans >= n) {
            return Ok("--scans");
        }
        line.check_connection()?;
        wait_for_work(lms, line, quit_after, clock)?;
        let now = micros_since(clock);
        line.receive_from_client(lms, now)?;
        loop {
            // `transmit` stops right after a baud switch: every byte of a
            // batch went at the rate before the call.
            let rate = lms.baud();
            let n = lms.transmit(now, &mut out);
            if n == 0 && lms.baud() == rate {
                break;
            }
            line.send_to_client(&out[..n], rate)?;
            if let Some(live) = live.as_mut() {
                let bits = RangeBits::from_measuring_mode(lms.config().measuring_mode());
                live.sensor_bytes(&out[..n], bits);
            }
        }
        events::handle_events(lms, line, args.restart_delay);
    }
}

/// Sleep until the sensor has something to do or the client writes.
fn wait_for_work(
    lms: &Emulator<Source>,
    line: &PtyLine,
    quit_after: Option<Duration>,
    clock: Instant,
) -> Result<()> {
    let now = micros_since(clock);
    let mut wait = lms
        .next_wakeup_us()
        .map_or(MAX_WAIT, |t| Duration::from_micros(t.saturating_sub(now)));
    if let Some(q) = quit_after {
        wait = wait.min(q.saturating_sub(clock.elapsed()));
    }
    if line.connected {
        // Whole milliseconds, at least one unless due now: bytes go out
        // in batches of ≤ 1 ms of line time.
        let ms = wait.min(MAX_WAIT).as_micros().div_ceil(1000) as u64;
        line.pty.wait_readable(Duration::from_millis(ms))?;
    } else {
        std::thread::sleep(IDLE_WAIT.min(wait.max(Duration::from_millis(1))));
    }
    Ok(())
}

/// After `--scans`: the master's close would drop what the client has not
/// read yet, so keep the device open (sending nothing more) until the
/// client closes it, at most [`LINGER`].
fn linger(line: &mut PtyLine, stop: &AtomicBool) -> Result<()> {
    let until = Instant::now() + LINGER;
    while Instant::now() < until && !stop.load(Ordering::Relaxed) && line.connected {
        std::thread::sleep(IDLE_WAIT);
        line.check_connection()?;
    }
    Ok(())
}

/// The summary line for stderr.
fn summary(reason: &str, clock: Instant, lms: &Emulator<Source>, line: &PtyLine) -> String {
    let s = lms.stats();
    let c = &line.counters;
    let mut summary = format!(
        "host-bridge simulate: stopped ({reason}) after {:.1} s: {} scans, {} requests, {} NAKs, \
         {} bytes to the client",
        clock.elapsed().as_secs_f64(),
        c.scans,
        s.requests,
        s.naks,
        c.written
    );
    if let Source::Replay(r) = lms.source() {
        let _ = write!(summary, ", log replayed {} times over", r.loops);
    }
    let _ = write!(
        summary,
        "; lost: {} bytes with no client, {} garbled and {} not understood (speed mismatch), \
         {} overrun; {} connections",
        c.no_client, c.garbled_out, c.dropped_in, c.overrun, c.connections
    );
    if line.faults[0].active() {
        let _ = write!(
            summary,
            "; line faults: {} bits flipped, {} bytes dropped",
            line.faults[0].bits_flipped + line.faults[1].bits_flipped,
            line.faults[0].bytes_dropped + line.faults[1].bytes_dropped
        );
    }
    summary
}
