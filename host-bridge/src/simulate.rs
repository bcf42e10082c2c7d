//! `host-bridge simulate`: a simulated LMS 2xx on a real pseudo-terminal.
//!
//! ```text
//! host-bridge simulate [--link PATH] [--verbose]
//!                      [--scene room|corridor|random] [--seed N] [--count N]
//!                      [--noise-sigma S] [--dropout P]
//!                      [--replay LOG]
//!                      [--scans N] [--quit-after SECONDS] [--restart-delay SECONDS]
//!                      [--bit-error-rate P] [--drop-rate P] [--fault-seed N]
//! ```
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
//! # Exit
//!
//! SIGINT, SIGTERM, `--quit-after SECONDS` or `--scans N` end the run
//! cleanly: the `--link` is removed and a summary goes to stderr. After the
//! N-th `B0` of `--scans N` nothing more is sent, and the device stays open
//! until the client closes it (at most 1 s), since closing the master would
//! drop the bytes the client has not read yet. `--verbose` logs requests, replies decided, baud
//! switches, stream start/stop, connections and speed mismatches.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use clap::{Args, ValueEnum};
use lms_core::device::emulator::{Emulator, Event, Handled, ScanSource, Settings};
use lms_core::telegram::{Baud, MeasuredValues, RangeBits};
use lms_core::Unit;
use lms_core::{Invalid, Variant};
use lms_scene::{seeded_rng, Bearings, NoiseModel, Pose, RangeUnit, Scene};

use crate::carmen::{self, UnitMode};
use crate::pty::{Pty, ReadOutcome, WriteOutcome};
use crate::synthetic::{SceneArgs, SceneKind};

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
    /// The synthetic scene (when no `--replay` log is given).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Replay the scans of a CARMEN log (gzip or plain) instead of the
    /// synthetic scene, looping; resampled to the variant asked for
    #[arg(long = "replay", value_name = "LOG")]
    pub log: Option<PathBuf>,
    /// Exit after this many scans (B0 telegrams) have been sent
    #[arg(long, value_name = "N")]
    pub scans: Option<u64>,
    /// Exit after this many seconds
    #[arg(long, value_name = "SECONDS")]
    pub quit_after: Option<f64>,
    /// Time from the 91 reply to a reset until the 90 power-on telegram (s)
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0)]
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
}

// ---------------------------------------------------------------------------
// Scan sources

/// The lms-scene unit for a sensor unit (10 cm is drawn in cm, then scaled).
fn range_unit(units: Unit) -> RangeUnit {
    match units {
        Unit::Millimetre => RangeUnit::Millimetre,
        Unit::Centimetre | Unit::Decimetre => RangeUnit::Centimetre,
    }
}

/// The lms-scene bearings of a variant (ALGORITHM.md §1).
fn bearings(variant: Variant) -> Bearings {
    match variant {
        Variant::Fov180Res100 => Bearings::lms_180_1deg(),
        Variant::Fov180Res50 => Bearings::lms_180_half_deg(),
        Variant::Fov100Res100 => Bearings::lms_100_1deg(),
        Variant::Fov100Res50 => Bearings::lms_100_half_deg(),
        Variant::Fov100Res25 => Bearings::lms_100_quarter_deg(),
    }
}

/// `fov°/res°` for messages.
fn variant_name(v: Variant) -> String {
    format!(
        "{}°/{}°",
        v.fov_deg(),
        f64::from(v.resolution_centideg()) / 100.0
    )
}

/// The built-in synthetic scene as a scan source (see the module docs).
#[derive(Debug)]
pub struct SceneSource {
    args: SceneArgs,
    scene: Scene,
    /// Per variant and units: `count` scans of raw values.
    draws: HashMap<(Variant, Unit), Vec<Vec<u16>>>,
    /// Scans handed out so far.
    sent: usize,
}

impl SceneSource {
    /// The scene of `args` (checked like `host-bridge extract` checks them).
    pub fn new(args: &SceneArgs) -> Result<Self> {
        ensure!(args.count > 0, "--count must be at least 1");
        ensure!(
            args.noise_sigma.is_finite() && args.noise_sigma >= 0.0,
            "--noise-sigma must be finite and >= 0 (metres)"
        );
        ensure!(
            (0.0..=1.0).contains(&args.dropout),
            "--dropout must be a probability in 0..=1"
        );
        let (scene, _) = Self::scene_and_rng(args);
        Ok(SceneSource {
            args: args.clone(),
            scene,
            draws: HashMap::new(),
            sent: 0,
        })
    }

    /// The scene and the generator positioned after drawing it, as
    /// `synthetic::frames` does (so the draws match `extract`).
    fn scene_and_rng(args: &SceneArgs) -> (Scene, lms_scene::ChaCha8Rng) {
        let mut rng = seeded_rng(args.seed);
        let scene = match args.scene {
            SceneKind::Room => Scene::room_with_box(),
            SceneKind::Corridor => Scene::corridor(),
            SceneKind::Random => Scene::random_room(&mut rng),
        };
        (scene, rng)
    }

    /// The `count` noisy scans of a variant in these units (drawn on first
    /// use).
    fn draws(&mut self, variant: Variant, units: Unit) -> &[Vec<u16>] {
        let (args, scene) = (&self.args, &self.scene);
        self.draws.entry((variant, units)).or_insert_with(|| {
            let (_, mut rng) = Self::scene_and_rng(args);
            let truth = scene.cast(&bearings(variant), Pose::IDENTITY);
            let unit = range_unit(units);
            let noise = NoiseModel::gaussian(args.noise_sigma)
                .with_quantisation(unit)
                .with_dropout(args.dropout);
            (0..args.count)
                .map(|_| {
                    let raw = lms_scene::to_raw(&truth.noisy(&noise, &mut rng), unit);
                    if units == Unit::Decimetre {
                        raw.into_iter()
                            .map(|v| if v < 8183 { (v + 5) / 10 } else { v })
                            .collect()
                    } else {
                        raw
                    }
                })
                .collect()
        })
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        format!(
            "scene {} (seed {}, {} noisy draws sent in turn, noise {} m, dropout {})",
            self.args
                .scene
                .to_possible_value()
                .map_or_else(String::new, |v| v.get_name().to_string()),
            self.args.seed,
            self.args.count,
            self.args.noise_sigma,
            self.args.dropout
        )
    }
}

impl ScanSource for SceneSource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        let k = self.sent;
        self.sent = self.sent.wrapping_add(1);
        let draws = self.draws(variant, units);
        let Some(scan) = draws.get(k % draws.len().max(1)) else {
            return 0;
        };
        let n = scan.len().min(out.len());
        out[..n].copy_from_slice(&scan[..n]);
        n
    }
}

/// Field of a variant in the 180° frame, in 1/100 °: (first beam, step).
/// A 100° field covers 40°…140° (PROTOCOL.md §2).
fn field(variant: Variant) -> (u32, u32) {
    let fov = u32::from(variant.fov_deg());
    ((180 - fov) * 50, u32::from(variant.resolution_centideg()))
}

/// The scans of a CARMEN log as a scan source (see the module docs).
#[derive(Debug)]
pub struct ReplaySource {
    path: PathBuf,
    scans: Vec<lms_core::Frame>,
    /// The variant of the log's beams, and its beam count (180 and 360 are
    /// CARMEN's 181/361 without the last beam).
    variant: Variant,
    beams: usize,
    next: usize,
    /// Variants already announced on stderr.
    announced: HashSet<Variant>,
    /// Times the log started again from its first scan.
    pub loops: u64,
}

impl ReplaySource {
    /// Read a capture recorded by `host-bridge scan` (recognised by its
    /// magic) or a CARMEN log (error codes per file as `carmen` decides).
    pub fn open(path: &Path) -> Result<Self> {
        if crate::capture::is_capture(path).unwrap_or(false) {
            return Self::open_capture(path);
        }
        let log = carmen::read_log(path, UnitMode::Auto)?;
        let first = log
            .scans
            .first()
            .with_context(|| format!("{}: no FLASER scans", path.display()))?;
        let beams = first.frame.len();
        let variant = carmen::variant_for_beams(beams)
            .with_context(|| format!("{}: {beams} beams per scan", path.display()))?;
        if let Some(odd) = log.scans.iter().find(|s| s.frame.len() != beams) {
            bail!(
                "{}: line {} has {} beams, the first scan {beams}; one beam count per log",
                path.display(),
                odd.line,
                odd.frame.len()
            );
        }
        Ok(ReplaySource {
            path: path.to_path_buf(),
            scans: log.scans.into_iter().map(|s| s.frame).collect(),
            variant,
            beams,
            next: 0,
            announced: HashSet::new(),
            loops: 0,
        })
    }

    /// The `B0` scans of a capture, as frames in metres (so they can be
    /// resampled and re-expressed in the units the client asks for).
    fn open_capture(path: &Path) -> Result<Self> {
        let mut scans = Vec::new();
        for item in crate::capture::read_frames(path)? {
            let (_, frame, _) = item?;
            scans.push(frame);
        }
        let first = scans
            .first()
            .with_context(|| format!("{}: no B0 scans in the capture", path.display()))?;
        let beams = first.len();
        let variant = Variant::from_beams(beams)
            .with_context(|| format!("{}: {beams} values per scan", path.display()))?;
        if let Some(i) = scans.iter().position(|f| f.len() != beams) {
            bail!(
                "{}: scan {i} has {} values, the first {beams}; one variant per capture",
                path.display(),
                scans[i].len()
            );
        }
        Ok(ReplaySource {
            path: path.to_path_buf(),
            scans,
            variant,
            beams,
            next: 0,
            announced: HashSet::new(),
            loops: 0,
        })
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        format!(
            "replay of {} ({} scans of {} beams, {}, looping)",
            self.path.display(),
            self.scans.len(),
            self.beams,
            variant_name(self.variant)
        )
    }

    /// Say once per variant how the log's scans are turned into it.
    fn announce(&mut self, target: Variant) {
        if target == self.variant && self.beams == target.beams() {
            return;
        }
        if !self.announced.insert(target) {
            return;
        }
        let (_, res_s) = field(self.variant);
        let (_, res_t) = field(target);
        let mut how = if res_t > res_s {
            format!("every {}th beam of the log", res_t / res_s)
        } else if res_t < res_s {
            "the nearest beam of the log, repeated".to_string()
        } else {
            "the log's beams".to_string()
        };
        if target.fov_deg() < self.variant.fov_deg() {
            how.push_str(", 40°…140° only");
        }
        if self.beams < self.variant.beams() {
            how.push_str("; the 180° beam the log lacks is sent as not valid (8191)");
        }
        eprintln!(
            "host-bridge simulate: replay: the log has {}; {} scans are resampled: {how}",
            variant_name(self.variant),
            variant_name(target)
        );
    }
}

impl ScanSource for ReplaySource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        self.announce(variant);
        if self.scans.is_empty() {
            return 0;
        }
        if self.next >= self.scans.len() {
            self.next = 0;
            self.loops += 1;
        }
        let frame = &self.scans[self.next];
        self.next += 1;
        // The log's values in the sensor's units (the core's conversion).
        let values = MeasuredValues::from_frame(frame, units, RangeBits::Bits13, 0);
        let values = values.values();
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        let (first_s, res_s) = field(self.variant);
        let (first_t, res_t) = field(variant);
        for (i, slot) in out.iter_mut().enumerate() {
            // Angle of target beam i from the right (1/100 °), and the
            // nearest log beam (ties to the next one).
            let angle = first_t + i as u32 * res_t;
            *slot = angle
                .checked_sub(first_s)
                .map(|d| ((2 * d + res_s) / (2 * res_s)) as usize)
                .and_then(|j| values.get(j).copied())
                .unwrap_or(not_valid);
        }
        out.len()
    }

    fn supports(&self, variant: Variant) -> bool {
        let (first_s, _) = field(self.variant);
        let (first_t, _) = field(variant);
        first_t >= first_s
    }
}

/// Where `simulate` takes its scans from.
#[derive(Debug)]
pub enum Source {
    /// The built-in synthetic scene.
    Scene(SceneSource),
    /// A CARMEN log or a capture of `host-bridge scan`.
    Replay(ReplaySource),
}

impl Source {
    /// The source the options ask for.
    pub fn open(args: &SimulateArgs) -> Result<Self> {
        match &args.log {
            Some(path) => Ok(Source::Replay(ReplaySource::open(path)?)),
            None => Ok(Source::Scene(SceneSource::new(&args.scene)?)),
        }
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        match self {
            Source::Scene(s) => s.describe(),
            Source::Replay(r) => r.describe(),
        }
    }
}

impl ScanSource for Source {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        match self {
            Source::Scene(s) => s.next_scan(variant, units, out),
            Source::Replay(r) => r.next_scan(variant, units, out),
        }
    }

    fn supports(&self, variant: Variant) -> bool {
        match self {
            Source::Scene(s) => s.supports(variant),
            Source::Replay(r) => r.supports(variant),
        }
    }
}

// ---------------------------------------------------------------------------
// The line between the pty and the emulator

/// Noise for bytes sent at the wrong speed: xorshift32, never `STX`, `ACK`
/// or `NAK`.
#[derive(Debug)]
struct Scrambler(u32);

impl Scrambler {
    fn byte(&mut self, b: u8) -> u8 {
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

/// Bit errors and lost bytes on the line (`--bit-error-rate`,
/// `--drop-rate`): xorshift64*, one draw per bit and per byte.
#[derive(Debug)]
struct LineFaults {
    bit_error_rate: f64,
    drop_rate: f64,
    state: u64,
    bits_flipped: u64,
    bytes_dropped: u64,
}

impl LineFaults {
    fn new(bit_error_rate: f64, drop_rate: f64, seed: u64) -> Self {
        LineFaults {
            bit_error_rate,
            drop_rate,
            // Any non-zero state; splitmix-style spread of small seeds.
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            bits_flipped: 0,
            bytes_dropped: 0,
        }
    }

    fn active(&self) -> bool {
        self.bit_error_rate > 0.0 || self.drop_rate > 0.0
    }

    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `bytes` as they arrive at the other end of the line.
    fn apply(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(bytes.len());
        for &b in bytes {
            if self.drop_rate > 0.0 && self.uniform() < self.drop_rate {
                self.bytes_dropped += 1;
                continue;
            }
            let mut b = b;
            if self.bit_error_rate > 0.0 {
                for bit in 0..8 {
                    if self.uniform() < self.bit_error_rate {
                        b ^= 1 << bit;
                        self.bits_flipped += 1;
                    }
                }
            }
            out.push(b);
        }
        out
    }
}

/// Counters for the summary.
#[derive(Debug, Default)]
struct Counters {
    scans: u64,
    written: u64,
    no_client: u64,
    garbled_out: u64,
    dropped_in: u64,
    overrun: u64,
    connections: u64,
}

/// The pty side of the simulation.
struct Line {
    pty: Pty,
    connected: bool,
    /// The (client, sensor) speeds of the mismatch last reported.
    mismatch: Option<(Option<u32>, Baud)>,
    scrambler: Scrambler,
    /// Faults on the client → sensor and sensor → client directions, each
    /// with its own generator, so that what reaches the client depends only
    /// on the bytes sent, not on how the two directions interleave.
    faults: [LineFaults; 2],
    counters: Counters,
    verbose: bool,
    clock: Instant,
}

impl Line {
    fn log(&self, msg: impl std::fmt::Display) {
        if self.verbose {
            let t = self.clock.elapsed().as_secs_f64();
            eprintln!("[{t:9.3} s] {msg}");
        }
    }

    /// Update the connection state from the pty.
    fn check_connection(&mut self) -> Result<()> {
        let now = self.pty.client_connected()?;
        if now != self.connected {
            self.set_connected(now)?;
        }
        Ok(())
    }

    fn set_connected(&mut self, connected: bool) -> Result<()> {
        self.connected = connected;
        self.mismatch = None;
        if connected {
            self.counters.connections += 1;
            self.log("client connected");
        } else {
            // Nothing left by this client (or written to it as it closed)
            // may reach the next one. (Flushing when the next one connects
            // would race with its first request.)
            self.pty.flush()?;
            self.log("client disconnected");
        }
        Ok(())
    }

    /// `true` if the client's speed is the sensor's; reports changes.
    fn speeds_match(&mut self, sensor: Baud) -> Result<bool> {
        let client = self.pty.client_speed()?;
        if client == Some(sensor.bits_per_second()) {
            if self.mismatch.take().is_some() {
                self.log(format!(
                    "client and sensor both at {} Bd",
                    sensor.bits_per_second()
                ));
            }
            return Ok(true);
        }
        if self.mismatch != Some((client, sensor)) {
            self.mismatch = Some((client, sensor));
            let client =
                client.map_or_else(|| "a non-LMS speed".to_string(), |c| format!("{c} Bd"));
            self.log(format!(
                "client at {client}, sensor at {} Bd: the line carries only noise",
                sensor.bits_per_second()
            ));
        }
        Ok(false)
    }

    /// Read what the client sent and hand it to the sensor, if it can
    /// understand it.
    fn receive_from_client<S: ScanSource>(
        &mut self,
        lms: &mut Emulator<S>,
        now_us: u64,
    ) -> Result<()> {
        if !self.connected {
            return Ok(());
        }
        let mut buf = [0u8; 4096];
        loop {
            match self.pty.read(&mut buf)? {
                ReadOutcome::Data(n) => {
                    if self.speeds_match(lms.baud())? {
                        if self.faults[0].active() {
                            let arrived = self.faults[0].apply(&buf[..n]);
                            lms.receive(now_us, &arrived);
                        } else {
                            lms.receive(now_us, &buf[..n]);
                        }
                    } else {
                        self.counters.dropped_in += n as u64;
                    }
                }
                ReadOutcome::Empty => return Ok(()),
                ReadOutcome::Closed => return self.set_connected(false),
            }
        }
    }

    /// Write the sensor's bytes to the client (noise at the wrong speed).
    fn send_to_client(&mut self, bytes: &[u8], sensor: Baud) -> Result<()> {
        if !self.connected {
            self.counters.no_client += bytes.len() as u64;
            return Ok(());
        }
        let garbled: Vec<u8>;
        let mut rest = if self.speeds_match(sensor)? {
            if self.faults[1].active() {
                garbled = self.faults[1].apply(bytes);
                &garbled
            } else {
                bytes
            }
        } else {
            garbled = bytes.iter().map(|&b| self.scrambler.byte(b)).collect();
            self.counters.garbled_out += bytes.len() as u64;
            &garbled
        };
        while !rest.is_empty() {
            match self.pty.write(rest)? {
                WriteOutcome::Written(n) => {
                    self.counters.written += n as u64;
                    rest = &rest[n.min(rest.len())..];
                }
                WriteOutcome::Full => {
                    // The client is not reading: a UART would overrun.
                    self.counters.overrun += rest.len() as u64;
                    return Ok(());
                }
                WriteOutcome::Closed => return self.set_connected(false),
            }
        }
        Ok(())
    }
}

/// A symbolic link to the slave device, removed when dropped.
struct Link {
    path: PathBuf,
    target: PathBuf,
}

impl Link {
    fn create(path: &Path, target: &Path) -> Result<Link> {
        if let Ok(meta) = std::fs::symlink_metadata(path) {
            ensure!(
                meta.file_type().is_symlink(),
                "--link {}: exists and is not a symbolic link",
                path.display()
            );
            std::fs::remove_file(path)
                .with_context(|| format!("cannot replace {}", path.display()))?;
        }
        std::os::unix::fs::symlink(target, path)
            .with_context(|| format!("cannot create the link {}", path.display()))?;
        Ok(Link {
            path: path.to_path_buf(),
            target: target.to_path_buf(),
        })
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        // Only if it still points at our device.
        if std::fs::read_link(&self.path).is_ok_and(|t| t == self.target) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// What a request was, for the log.
fn describe(h: Handled) -> String {
    match h {
        Handled::InstallationMode { accepted: true } => "20 00: installation mode".into(),
        Handled::InstallationMode { accepted: false } => {
            "20 00: installation mode refused (bad password)".into()
        }
        Handled::Continuous => "20 24: continuous output".into(),
        Handled::OnRequest => "20 25: values on request (stream stopped)".into(),
        Handled::SetBaud(b) => format!(
            "20 {:02X}: switch to {} Bd after the reply",
            b.mode_byte(),
            b.bits_per_second()
        ),
        Handled::OneScan => "30 01: one scan".into(),
        Handled::Extra { command } => format!("{command:02X}: answered by the scan source"),
        Handled::Status => "31: status".into(),
        Handled::SensorType => "3A: sensor type".into(),
        Handled::SetVariant {
            angle_deg,
            resolution_centideg,
            accepted,
        } => format!(
            "3B: variant {angle_deg}°/{}° {}",
            f64::from(resolution_centideg) / 100.0,
            if accepted { "accepted" } else { "refused" }
        ),
        Handled::ReadConfig => "74: read configuration".into(),
        Handled::WriteConfig { accepted } => format!(
            "77: write configuration {}",
            if accepted {
                "accepted"
            } else {
                "refused (not in installation mode, or bad units)"
            }
        ),
        Handled::Reset => "10: reset".into(),
        Handled::Unknown { command, data_len } => {
            format!("{command:02X} with {data_len} data bytes: unknown, answered 92")
        }
    }
}

/// Run `host-bridge simulate`.
pub fn run(args: &SimulateArgs) -> Result<()> {
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
    let source = Source::open(args)?;
    let about = source.describe();
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("cannot install the signal handler")?;
    }

    let pty = Pty::open(Baud::B9600.bits_per_second())?;
    let link = match &args.link {
        Some(path) => Some(Link::create(path, pty.slave_path())?),
        None => None,
    };
    {
        let mut out = io::stdout().lock();
        writeln!(out, "{}", pty.slave_path().display())?;
        out.flush()?;
    }
    let mut banner = format!(
        "host-bridge simulate: LMS 2xx on {}",
        pty.slave_path().display()
    );
    if let Some(l) = &link {
        let _ = write!(banner, " (link {})", l.path.display());
    }
    if args.bit_error_rate > 0.0 || args.drop_rate > 0.0 {
        let _ = write!(
            banner,
            " with line faults (bit error rate {:e}, drop rate {:e}, seed {})",
            args.bit_error_rate, args.drop_rate, args.fault_seed
        );
    }
    eprintln!("{banner}; 9600 Bd, values on request; scans from {about}");

    let clock = Instant::now();
    let now_us = || u64::try_from(clock.elapsed().as_micros()).unwrap_or(u64::MAX);
    let settings = Settings {
        restart_us: (args.restart_delay * 1e6) as u64,
        ..Settings::default()
    };
    let mut lms = Emulator::new(source, settings, now_us());
    let mut line = Line {
        pty,
        connected: false,
        mismatch: None,
        scrambler: Scrambler(0x2545_F491),
        faults: [
            LineFaults::new(args.bit_error_rate, args.drop_rate, args.fault_seed),
            LineFaults::new(
                args.bit_error_rate,
                args.drop_rate,
                args.fault_seed ^ 0xA5A5_A5A5_A5A5_A5A5,
            ),
        ],
        counters: Counters::default(),
        verbose: args.verbose,
        clock,
    };
    let quit_after = args.quit_after.map(Duration::from_secs_f64);
    let mut out = [0u8; 4096];

    let reason = loop {
        if stop.load(Ordering::Relaxed) {
            break "signal";
        }
        if quit_after.is_some_and(|q| clock.elapsed() >= q) {
            break "--quit-after";
        }
        if args.scans.is_some_and(|n| line.counters.scans >= n) {
            break "--scans";
        }
        line.check_connection()?;

        // Sleep until the sensor has something to do or the client writes.
        let now = now_us();
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

        let now = now_us();
        line.receive_from_client(&mut lms, now)?;
        loop {
            // `transmit` stops right after a baud switch: every byte of a
            // batch went at the rate before the call.
            let rate = lms.baud();
            let n = lms.transmit(now, &mut out);
            if n == 0 {
                break;
            }
            line.send_to_client(&out[..n], rate)?;
        }
        while let Some(event) = lms.next_event() {
            match event {
                Event::ScanSent { .. } => line.counters.scans += 1,
                Event::Request(h) => {
                    if let Handled::SetVariant {
                        angle_deg,
                        resolution_centideg,
                        accepted: false,
                    } = h
                    {
                        if let Some(v) = Variant::from_fov_res(angle_deg, resolution_centideg) {
                            eprintln!(
                                "host-bridge simulate: refused variant {}: the scan source \
                                 cannot produce it",
                                variant_name(v)
                            );
                        }
                    }
                    line.log(format!("request {}", describe(h)));
                }
                Event::BaudSwitched { from, to } => line.log(format!(
                    "line switched {} -> {} Bd",
                    from.bits_per_second(),
                    to.bits_per_second()
                )),
                Event::PowerOnSent => line.log("power-on telegram 90 sent (9600 Bd)"),
                Event::BadChecksum => line.log("bad checksum: NAK"),
                Event::IgnoredAddress { address } => {
                    line.log(format!("telegram for address {address:#04x} ignored"))
                }
                Event::StreamStarted => line.log("continuous output started"),
                Event::StreamStopped => line.log("continuous output stopped"),
                Event::Restarting => line.log(format!(
                    "reset: power-on telegram in {} s",
                    args.restart_delay
                )),
            }
        }
    };

    if reason == "--scans" {
        // The master's close would drop what the client has not read yet:
        // keep the device open (sending nothing more) until the client
        // closes it, at most LINGER.
        let until = Instant::now() + LINGER;
        while Instant::now() < until && !stop.load(Ordering::Relaxed) && line.connected {
            std::thread::sleep(IDLE_WAIT);
            line.check_connection()?;
        }
    }

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
    eprintln!("{summary}");
    drop(link);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_source_matches_extract_and_covers_all_variants() {
        let args = SceneArgs {
            count: 3,
            ..SceneArgs::default()
        };
        let mut src = SceneSource::new(&args).unwrap();
        let frames = crate::synthetic::frames(&args).unwrap();
        let mut out = [0u16; 401];
        for k in 0..4 {
            let n = src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut out[..361]);
            assert_eq!(n, 361);
            let f = &frames[k % 3].frame;
            for (j, (&v, &r)) in out.iter().zip(f.ranges()).enumerate() {
                if f.beams()[j].is_valid() {
                    assert_eq!(f32::from(v) / 1000.0, r, "scan {k} beam {j}");
                } else {
                    assert_eq!(v, 8191);
                }
            }
        }
        for v in Variant::ALL {
            for units in [Unit::Centimetre, Unit::Millimetre] {
                let n = src.next_scan(v, units, &mut out[..v.beams()]);
                assert_eq!(n, v.beams());
                let valid: Vec<_> = out[..n].iter().filter(|&&x| x < 8183).collect();
                assert!(valid.len() > n * 9 / 10, "{v:?} {units:?}");
                // The room is within 8 m: < 800 cm, < 8000 mm.
                let limit = if units == Unit::Millimetre { 8000 } else { 800 };
                assert!(valid.iter().all(|&&x| x > 0 && x < limit));
            }
        }
        // Straight ahead is beam 90 at 1° and beam 50 at 100°/1°: one ray.
        let mut a = [0u16; 181];
        let mut b = [0u16; 101];
        let quiet = SceneArgs {
            noise_sigma: 0.0,
            dropout: 0.0,
            ..args
        };
        let mut src = SceneSource::new(&quiet).unwrap();
        src.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut a);
        src.next_scan(Variant::Fov100Res100, Unit::Centimetre, &mut b);
        assert_eq!(a[90], b[50]);
        assert_eq!(&a[40..=140], &b[..]);
    }

    fn log_path(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/carmen")
            .join(name)
    }

    #[test]
    fn replay_resamples_and_refuses() {
        // Intel: 180 beams at 1° (the 181st missing).
        let mut src = ReplaySource::open(&log_path("intel-corrected.log.gz")).unwrap();
        assert_eq!(src.variant, Variant::Fov180Res100);
        assert!(Variant::ALL.iter().all(|&v| src.supports(v)));
        let mut cm = [0u16; 181];
        src.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut cm);
        assert_eq!(cm[180], 8191);
        // Second scan at 0.5°: even beams are the log's, odd ones repeat
        // the next.
        src.next = 0;
        let mut half = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Centimetre, &mut half);
        for j in 0..180 {
            assert_eq!(half[2 * j], cm[j]);
            assert_eq!(half[2 * j + 1], cm[j + 1]);
        }
        src.next = 0;
        let mut narrow = [0u16; 101];
        src.next_scan(Variant::Fov100Res100, Unit::Centimetre, &mut narrow);
        assert_eq!(&narrow[..], &cm[40..=140]);

        // CSAIL: 361 beams; 1° takes every 2nd.
        let mut src = ReplaySource::open(&log_path("csail-corrected.log.gz")).unwrap();
        let mut full = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut full);
        src.next = 0;
        let mut coarse = [0u16; 181];
        src.next_scan(Variant::Fov180Res100, Unit::Millimetre, &mut coarse);
        for j in 0..181 {
            assert_eq!(coarse[j], full[2 * j]);
        }

        // A 100° log cannot give 180°.
        let src = ReplaySource {
            variant: Variant::Fov100Res50,
            beams: 201,
            ..src
        };
        assert!(!src.supports(Variant::Fov180Res50));
        assert!(src.supports(Variant::Fov100Res25));
    }

    #[test]
    fn scrambled_bytes_never_look_like_framing() {
        let mut s = Scrambler(0x2545_F491);
        for _ in 0..10 {
            for b in 0..=255u8 {
                assert!(!matches!(s.byte(b), 0x02 | 0x06 | 0x15));
            }
        }
    }
}
