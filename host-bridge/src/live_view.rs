//! `--foxglove [ADDR]`: a live view of the scans and their features in
//! Foxglove, over the Foxglove WebSocket protocol.
//!
//! [`LiveView`] serves the protocol on `ADDR` (default
//! [`DEFAULT_ADDR`], `127.0.0.1:8765`) with the Foxglove SDK's server, in
//! a context of its own, and advertises the three channels of the ROS 2
//! output ([`crate::ros2::messages::CHANNELS`]: the scan as
//! `sensor_msgs/msg/LaserScan`, the features for display as
//! `visualization_msgs/msg/MarkerArray`, the features for programs as
//! `lms_features_msgs/msg/Features`), schema encoding `ros2msg`, message
//! encoding `cdr`: the same messages, byte for byte, as an MCAP file of
//! `extract -o out.mcap`. In Foxglove: open a connection, Foxglove
//! WebSocket, `ws://localhost:8765`.
//!
//! Publishing never waits: a message is encoded only for a channel some
//! client has subscribed to ([`LiveView::watched`] says whether any has),
//! and handed to the server's queue of each client, which drops the
//! oldest messages when a slow client lets it fill. With no client a
//! frame costs three lock-free reads.
//!
//! The server answers the subprotocols `foxglove.sdk.v1` and
//! `foxglove.sdk.v1.1` (the SDK's names for the protocol; a client that
//! offers only the older name `foxglove.websocket.v1` is refused with HTTP
//! 400). No TLS, no authentication: serve on a loopback address unless the
//! network is trusted.
//!
//! [`LiveFeed`] computes the features of live frames off the caller's
//! thread (`scan`), [`StreamView`] picks the scans out of a sensor's byte
//! stream for it (`simulate`, `coprocessor`), and [`Replay`] plays a file's
//! frames at their own times ([`Pacer`]) and shows them (`extract
//! --realtime`).

use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{anyhow, Result};
use clap::Args;
use foxglove::{
    Context, PartialMetadata, RawChannel, Schema, WebSocketServer, WebSocketServerHandle,
};
use lms_core::telegram::{Direction, Event, Framer, Handshake, MeasuredView, RangeBits};
use lms_core::{Extractor, Features, Frame, ValidParams};

use crate::input::InputFrame;
use crate::input::InputScan;
use crate::ros2::messages::{self, Channel, Stamp};
use crate::ros2::rosbag2_out::stamp_for;

/// Where `--foxglove` serves without an address.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// Count-word bit 13 of a `B0`: a partial scan (not shown: its beams are
/// a quarter of a scan at an offset).
const PARTIAL_SCAN_BIT: u16 = 0x2000;

/// `--foxglove [ADDR]` of `simulate`, `scan`, `coprocessor` and `extract`.
#[derive(Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct FoxgloveArgs {
    /// Serve the scans and features live to Foxglove (WebSocket protocol) at
    /// ADDR, HOST:PORT or PORT [default: 127.0.0.1:8765]; in Foxglove open a
    /// connection to ws://ADDR. Port 0 picks a free port (printed on stderr).
    /// extract: with --realtime, playing from when a client subscribes
    #[arg(
        long,
        value_name = "ADDR",
        num_args = 0..=1,
        default_missing_value = DEFAULT_ADDR,
        value_parser = address,
        help_heading = "Live view"
    )]
    pub foxglove: Option<Address>,
}

/// A host and a port to serve on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Address {
    /// Host name or IP address (IPv6 without brackets).
    pub host: String,
    /// TCP port (0: any free port).
    pub port: u16,
}

/// `--foxglove`'s value: `HOST:PORT`, `[IPv6]:PORT` or a bare `PORT` (on
/// 127.0.0.1).
pub fn address(s: &str) -> Result<Address, String> {
    let s = s.trim();
    let bad = || {
        format!(
            "`{s}` is not an address to serve on: give HOST:PORT (e.g. {DEFAULT_ADDR}) or a \
             port (a log or capture goes before --foxglove, or write --foxglove=ADDR)"
        )
    };
    if let Ok(port) = s.parse::<u16>() {
        return Ok(Address {
            host: "127.0.0.1".into(),
            port,
        });
    }
    let (host, port) = s.rsplit_once(':').ok_or_else(bad)?;
    let port = port.parse::<u16>().map_err(|_| bad())?;
    let host = host
        .strip_prefix('[')
        .and_then(|h| h.strip_suffix(']'))
        .unwrap_or(host);
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | ':' | '_');
    if host.is_empty() || !host.chars().all(plain) {
        return Err(bad());
    }
    Ok(Address {
        host: host.to_string(),
        port,
    })
}

/// The Foxglove WebSocket server and its three channels (see the
/// [module docs](self)). Dropping it stops the server.
pub struct LiveView {
    server: Option<WebSocketServerHandle>,
    /// Kept for the channels' lifetime (they log into it).
    _context: Arc<Context>,
    scan: Arc<RawChannel>,
    markers: Arc<RawChannel>,
    features: Arc<RawChannel>,
    url: String,
    published: AtomicU64,
}

impl std::fmt::Debug for LiveView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveView")
            .field("url", &self.url)
            .field("published", &self.published)
            .finish()
    }
}

/// One channel of `context` as the ROS 2 output writes it.
fn channel(context: &Arc<Context>, c: &Channel) -> Result<Arc<RawChannel>> {
    context
        .channel_builder(c.topic)
        .message_encoding("cdr")
        .schema(Schema::new(c.type_name, "ros2msg", c.schema.as_bytes()))
        .build_raw()
        .map_err(|e| anyhow!("cannot make the channel {}: {e}", c.topic))
}

impl LiveView {
    /// Serve on `addr` (see the [module docs](self)); `name` is the
    /// server's name shown by Foxglove. An address that cannot be bound
    /// is an error naming it.
    pub fn start(addr: &Address, name: &str) -> Result<LiveView> {
        let context = Context::new();
        let scan = channel(&context, &messages::SCAN)?;
        let markers = channel(&context, &messages::MARKERS)?;
        let features = channel(&context, &messages::FEATURES)?;
        let server = WebSocketServer::new()
            .context(&context)
            .name(name)
            .bind(addr.host.clone(), addr.port)
            .start_blocking()
            .map_err(|e| {
                anyhow!(
                    "--foxglove {}:{}: cannot serve there: {e}",
                    addr.host,
                    addr.port
                )
            })?;
        let host = if addr.host.contains(':') {
            format!("[{}]", addr.host)
        } else {
            addr.host.clone()
        };
        let url = format!("ws://{host}:{}", server.port());
        Ok(LiveView {
            server: Some(server),
            _context: context,
            scan,
            markers,
            features,
            url,
            published: AtomicU64::new(0),
        })
    }

    /// [`LiveView::start`] if `args` ask for it, saying where on stderr
    /// (`who`: the command, e.g. `host-bridge simulate`).
    pub fn from_args(args: &FoxgloveArgs, who: &str) -> Result<Option<LiveView>> {
        let Some(addr) = &args.foxglove else {
            return Ok(None);
        };
        let view = LiveView::start(addr, who)?;
        eprintln!("{}", view.banner(who));
        Ok(Some(view))
    }

    /// The line that says where the view is served.
    pub fn banner(&self, who: &str) -> String {
        let topics: Vec<&str> = messages::CHANNELS.iter().map(|c| c.topic).collect();
        format!(
            "{who}: Foxglove live view on {} (topics {}): in Foxglove, open a connection to it",
            self.url,
            topics.join(", ")
        )
    }

    /// `ws://HOST:PORT` of the server (the port it bound, for port 0).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The port the server bound.
    pub fn port(&self) -> u16 {
        self.server.as_ref().map_or(0, WebSocketServerHandle::port)
    }

    /// `true` if a client has subscribed to any channel: only then is a
    /// frame worth computing for the view.
    pub fn watched(&self) -> bool {
        self.scan.has_sinks() || self.markers.has_sinks() || self.features.has_sinks()
    }

    /// Frames published while a client was subscribed.
    pub fn published(&self) -> u64 {
        self.published.load(Ordering::Relaxed)
    }

    /// Publish one frame and its features on every subscribed channel
    /// (never waits; nothing is encoded for a channel nobody watches).
    /// The message's log time is now; `stamp` goes into the headers.
    pub fn publish(&self, stamp: &Stamp, frame: &Frame, features: &Features) {
        if !self.watched() {
            return;
        }
        let meta = PartialMetadata::with_log_time(now_ns());
        if self.scan.has_sinks() {
            self.scan
                .log_with_meta(&messages::scan_cdr(stamp, frame), meta);
        }
        if self.markers.has_sinks() {
            self.markers
                .log_with_meta(&messages::markers_cdr(stamp, frame, features), meta);
        }
        if self.features.has_sinks() {
            self.features
                .log_with_meta(&messages::features_cdr(stamp, features), meta);
        }
        self.published.fetch_add(1, Ordering::Relaxed);
    }

    /// Wait until a client subscribes, or `stop` is set (then `false`).
    pub fn wait_for_client(&self, stop: &AtomicBool) -> bool {
        while !self.watched() {
            if stop.load(Ordering::Relaxed) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        true
    }
}

impl Drop for LiveView {
    /// Stop the server: every client is told and disconnected; waits at
    /// most [`STOP_WAIT`] for the server's tasks.
    fn drop(&mut self) {
        let Some(server) = self.server.take() else {
            return;
        };
        let shutdown = server.stop();
        let (done, wait) = std::sync::mpsc::channel();
        let waiter = std::thread::spawn(move || {
            shutdown.wait_blocking();
            let _ = done.send(());
        });
        if wait.recv_timeout(STOP_WAIT).is_ok() {
            let _ = waiter.join();
        }
    }
}

/// Longest wait for the server to stop when a [`LiveView`] is dropped.
pub const STOP_WAIT: Duration = Duration::from_secs(1);

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// A stamp of now with `frame_id` ([`messages::DEFAULT_FRAME_ID`] if `None`).
pub fn stamp_now(frame_id: Option<&str>) -> Stamp {
    Stamp {
        ns: i64::try_from(now_ns()).unwrap_or(i64::MAX),
        frame_id: frame_id.unwrap_or(messages::DEFAULT_FRAME_ID).to_string(),
    }
}

/// Longest wait between two frames of a replay: a longer gap in the input's
/// times (a paused recording) is shortened to this.
pub const MAX_GAP: Duration = Duration::from_secs(2);

/// Replays frames at their own times: [`Pacer::wait`] returns when the
/// frame of time `t` is due, `t − t₀` after the first frame's call.
/// Times that go backwards start the clock again at that frame; a gap
/// longer than [`MAX_GAP`] counts as `MAX_GAP`.
#[derive(Debug)]
pub struct Pacer {
    stop: Arc<AtomicBool>,
    /// The wall-clock instant of the input time `origin.1`.
    origin: Option<(Instant, i64)>,
    last: i64,
    /// Gaps shortened to [`MAX_GAP`].
    pub gaps_cut: u64,
}

impl Pacer {
    /// A pacer that gives up waiting once `stop` is set.
    pub fn new(stop: Arc<AtomicBool>) -> Self {
        Pacer {
            stop,
            origin: None,
            last: 0,
            gaps_cut: 0,
        }
    }

    /// Sleep until the frame of input time `t_ns` is due; `false` if
    /// `stop` was set meanwhile.
    pub fn wait(&mut self, t_ns: i64) -> bool {
        let now = Instant::now();
        let (start, t0) = match self.origin {
            None => {
                self.origin = Some((now, t_ns));
                self.last = t_ns;
                return !self.stop.load(Ordering::Relaxed);
            }
            Some(o) => o,
        };
        let step = t_ns.saturating_sub(self.last);
        let max = i64::try_from(MAX_GAP.as_nanos()).unwrap_or(i64::MAX);
        if step < 0 || step > max {
            // Restart the clock at the previous frame's due time.
            let prev_due = start + Duration::from_nanos(self.last.saturating_sub(t0).max(0) as u64);
            let gap = if step < 0 { 0 } else { max };
            if step > max {
                self.gaps_cut += 1;
            }
            self.origin = Some((prev_due, t_ns.saturating_sub(gap)));
        }
        self.last = t_ns;
        let (start, t0) = self.origin.unwrap_or((now, t_ns));
        let due = start + Duration::from_nanos(t_ns.saturating_sub(t0).max(0) as u64);
        while !self.stop.load(Ordering::Relaxed) {
            let left = due.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return true;
            }
            std::thread::sleep(left.min(Duration::from_millis(50)));
        }
        false
    }
}

/// The scans in a sensor's byte stream: feed it what the sensor sends,
/// get each complete `B0` as a frame (partial scans and damaged telegrams
/// are skipped and counted).
pub struct ScanTap {
    framer: Box<Framer>,
    /// `B0` telegrams taken.
    pub scans: u64,
    /// `B0` telegrams skipped: partial scans, or values that make no frame.
    pub skipped: u64,
}

impl std::fmt::Debug for ScanTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScanTap")
            .field("scans", &self.scans)
            .field("skipped", &self.skipped)
            .finish()
    }
}

impl Default for ScanTap {
    fn default() -> Self {
        ScanTap {
            framer: Box::new(Framer::new(Direction::SensorToHost, Handshake::Expected)),
            scans: 0,
            skipped: 0,
        }
    }
}

impl ScanTap {
    /// Feed `bytes` sent by the sensor; `bits` are the range bits of its
    /// measuring mode. Calls `on_frame` for each complete scan.
    pub fn feed(&mut self, mut bytes: &[u8], bits: RangeBits, mut on_frame: impl FnMut(Frame)) {
        loop {
            let feed = self.framer.feed(bytes);
            bytes = feed.remaining;
            let Some(event) = feed.event else { break };
            let Event::Telegram(t) = event else { continue };
            let Ok(view) = MeasuredView::parse(&t) else {
                continue; // not a scan
            };
            if view.scan_flags() & PARTIAL_SCAN_BIT != 0 {
                self.skipped += 1;
                continue;
            }
            match view.to_frame(bits) {
                Ok(frame) => {
                    self.scans += 1;
                    on_frame(frame);
                }
                Err(_) => self.skipped += 1,
            }
        }
    }
}

/// Frames waiting for the [`LiveFeed`]'s worker; more are dropped (counted).
const FEED_QUEUE: usize = 16;

/// One frame for the worker.
struct Job {
    stamp: Stamp,
    frame: Box<Frame>,
}

/// A [`LiveView`] fed from a live source: [`LiveFeed::send`] hands a frame
/// to a worker thread, which runs the std pipeline on it and publishes the
/// frame with its features. The caller never waits: with the worker busy
/// the frame is dropped and counted ([`LiveFeed::dropped`]); with no client
/// subscribed nothing is sent at all. Dropping it stops the worker and the
/// server.
pub struct LiveFeed {
    view: Arc<LiveView>,
    jobs: Option<SyncSender<Job>>,
    worker: Option<JoinHandle<()>>,
    dropped: u64,
}

impl std::fmt::Debug for LiveFeed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveFeed")
            .field("view", &self.view)
            .field("dropped", &self.dropped)
            .finish()
    }
}

impl LiveFeed {
    /// Publish `view`'s frames with the features `params` give.
    pub fn new(view: LiveView, params: ValidParams) -> Result<LiveFeed> {
        let view = Arc::new(view);
        let (jobs, queue) = mpsc::sync_channel::<Job>(FEED_QUEUE);
        let shown = Arc::clone(&view);
        let worker = std::thread::Builder::new()
            .name("foxglove-feed".into())
            .spawn(move || {
                let mut ex = Box::new(Extractor::new());
                for job in queue {
                    ex.run(&job.frame, &params);
                    shown.publish(&job.stamp, &job.frame, ex.features());
                }
            })
            .map_err(|e| anyhow!("cannot start the live view's thread: {e}"))?;
        Ok(LiveFeed {
            view,
            jobs: Some(jobs),
            worker: Some(worker),
            dropped: 0,
        })
    }

    /// [`LiveView::from_args`] fed with the features of `params`; `None`
    /// without `--foxglove`.
    pub fn from_args(
        args: &FoxgloveArgs,
        who: &str,
        params: ValidParams,
    ) -> Result<Option<LiveFeed>> {
        LiveView::from_args(args, who)?
            .map(|view| LiveFeed::new(view, params))
            .transpose()
    }

    /// The view.
    pub fn view(&self) -> &LiveView {
        &self.view
    }

    /// `true` if a client has subscribed ([`LiveView::watched`]).
    pub fn watched(&self) -> bool {
        self.view.watched()
    }

    /// Frames dropped because the worker was still busy with earlier ones.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Hand `frame` over to be shown (never waits; see the type's docs).
    pub fn send(&mut self, stamp: Stamp, frame: Frame) {
        if !self.view.watched() {
            return;
        }
        let Some(jobs) = &self.jobs else { return };
        let job = Job {
            stamp,
            frame: Box::new(frame),
        };
        match jobs.try_send(job) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => self.dropped += 1,
            // The worker is gone (it cannot fail but by a panic): no view.
            Err(TrySendError::Disconnected(_)) => self.jobs = None,
        }
    }

    /// One line for a summary: frames shown, and dropped if any.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "Foxglove live view {}: {} frames published",
            self.view.url(),
            self.view.published()
        );
        if self.dropped > 0 {
            s.push_str(&format!(
                ", {} dropped (the feature thread was busy)",
                self.dropped
            ));
        }
        s
    }
}

impl Drop for LiveFeed {
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

/// The live view of a sensor's byte stream: its scans ([`ScanTap`]) shown
/// with their features ([`LiveFeed`]), stamped when they are complete.
/// While no client is subscribed the bytes are not even framed.
#[derive(Debug)]
pub struct StreamView {
    /// The feed the scans go to.
    pub feed: LiveFeed,
    tap: ScanTap,
    tapping: bool,
}

impl StreamView {
    /// [`LiveFeed::from_args`] on a sensor's bytes; `None` without
    /// `--foxglove`.
    pub fn from_args(
        args: &FoxgloveArgs,
        who: &str,
        params: ValidParams,
    ) -> Result<Option<StreamView>> {
        Ok(
            LiveFeed::from_args(args, who, params)?.map(|feed| StreamView {
                feed,
                tap: ScanTap::default(),
                tapping: false,
            }),
        )
    }

    /// Bytes the sensor sent, with the range bits of its measuring mode.
    pub fn sensor_bytes(&mut self, bytes: &[u8], bits: RangeBits) {
        if !self.feed.watched() {
            self.tapping = false;
            return;
        }
        if !self.tapping {
            // A client came: start framing afresh.
            self.tap.framer.discard();
            self.tapping = true;
        }
        let feed = &mut self.feed;
        self.tap
            .feed(bytes, bits, |frame| feed.send(stamp_now(None), frame));
    }

    /// [`LiveFeed::summary`], with the partial scans skipped if any.
    pub fn summary(&self) -> String {
        let mut s = self.feed.summary();
        if self.tap.skipped > 0 {
            s.push_str(&format!(
                ", {} partial or unreadable scans not shown",
                self.tap.skipped
            ));
        }
        s
    }
}

/// Where a replay's times come from (said once on stderr).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// The stamps of a ROS 2 bag's messages.
    Stamps,
    /// The record times of a capture.
    CaptureTimes,
    /// The LMS scan period of the frame's variant, one frame after the
    /// other: a CARMEN log (its timestamps are not usable in every log:
    /// all zero in one, 6 significant digits in another) or a synthetic
    /// scene.
    ScanPeriod,
}

impl Clock {
    /// The clock of a scan of a file.
    pub fn of(scan: &InputScan) -> Clock {
        match (scan.stamp_ns, scan.time_us) {
            (Some(_), _) => Clock::Stamps,
            (None, Some(_)) => Clock::CaptureTimes,
            (None, None) => Clock::ScanPeriod,
        }
    }

    /// What it is, for stderr.
    fn describe(self, frame: &Frame) -> String {
        match self {
            Clock::Stamps => "at the stamps of the bag's messages".into(),
            Clock::CaptureTimes => "at the capture's record times".into(),
            Clock::ScanPeriod => {
                let period = stamp_for(1, frame, None, None, None).ns;
                format!(
                    "one scan every {:.1} ms, the LMS scan period of {} beams \
                     (CARMEN logs and scenes carry no usable times)",
                    period as f64 / 1e6,
                    frame.len()
                )
            }
        }
    }
}

/// A frame of a file with its stamp ([`stamp_for`]) and its clock.
pub type Timed = (InputFrame, Stamp, Clock);

/// A scan of a file as a [`Timed`] frame.
pub fn timed(scan: InputScan) -> Timed {
    let (clock, stamp) = (Clock::of(&scan), scan.stamp());
    (scan.into_frame(), stamp, clock)
}

/// `extract --realtime [--foxglove]`: the frames played at their own times
/// ([`Replay::due`], a [`Pacer`]), and with `--foxglove` shown in Foxglove
/// as they are processed ([`Replay::show`]; the replay starts when a client
/// has subscribed). SIGINT and SIGTERM end it after the frame in hand.
pub struct Replay {
    who: String,
    pacer: RefCell<Pacer>,
    view: Option<LiveView>,
    stop: Arc<AtomicBool>,
    /// The stamp of the frame in hand.
    current: RefCell<Option<Stamp>>,
    said: Cell<bool>,
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replay")
            .field("view", &self.view)
            .field("stopped", &self.stopped())
            .finish()
    }
}

impl Replay {
    /// Start the view if `args` ask for it and wait for its first client
    /// (`who`: the command, for stderr).
    pub fn start(args: &FoxgloveArgs, who: &str) -> Result<Replay> {
        let stop = crate::stop::stop_flag()?;
        let view = LiveView::from_args(args, who)?;
        if let Some(v) = &view {
            eprintln!("{who}: waiting for a Foxglove client to subscribe (Ctrl-C to give up)");
            v.wait_for_client(&stop);
        }
        Ok(Replay {
            who: who.to_string(),
            pacer: RefCell::new(Pacer::new(Arc::clone(&stop))),
            view,
            stop,
            current: RefCell::new(None),
            said: Cell::new(false),
        })
    }

    /// `true` once a signal ended the replay.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The frame once it is due (an error at once); `None` once stopped.
    pub fn due(&self, item: Result<Timed>) -> Option<Result<InputFrame>> {
        let (frame, stamp, clock) = match item {
            Ok(t) => t,
            Err(e) => return Some(Err(e)),
        };
        if !self.said.replace(true) {
            eprintln!("{}: --realtime: {}", self.who, clock.describe(&frame.frame));
        }
        if !self.pacer.borrow_mut().wait(stamp.ns) {
            return None;
        }
        *self.current.borrow_mut() = Some(stamp);
        Some(Ok(frame))
    }

    /// Show the frame in hand with its features (with `--foxglove`).
    pub fn show(&self, input: &InputFrame, features: &Features) {
        if let (Some(view), Some(stamp)) = (&self.view, self.current.borrow().as_ref()) {
            view.publish(stamp, &input.frame, features);
        }
    }

    /// One line for stderr: a stop by a signal, gaps shortened, frames shown.
    pub fn summary(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.stopped() {
            parts.push("stopped by a signal".to_string());
        }
        let cut = self.pacer.borrow().gaps_cut;
        if cut > 0 {
            parts.push(format!(
                "{cut} gaps longer than {} s shortened to it",
                MAX_GAP.as_secs()
            ));
        }
        if let Some(v) = &self.view {
            parts.push(format!(
                "Foxglove live view {}: {} frames published",
                v.url(),
                v.published()
            ));
        }
        (!parts.is_empty()).then(|| format!("{}: --realtime: {}", self.who, parts.join("; ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::telegram::MeasuredValues;
    use lms_core::Unit;

    #[test]
    fn addresses() {
        let a = |s| address(s).map(|a| (a.host, a.port));
        assert_eq!(a("127.0.0.1:8765"), Ok(("127.0.0.1".into(), 8765)));
        assert_eq!(a("9000"), Ok(("127.0.0.1".into(), 9000)));
        assert_eq!(a("0.0.0.0:0"), Ok(("0.0.0.0".into(), 0)));
        assert_eq!(a("[::1]:8765"), Ok(("::1".into(), 8765)));
        assert_eq!(a("localhost:8765"), Ok(("localhost".into(), 8765)));
        for bad in [
            "log.gz",
            "host:port",
            ":8765",
            "a b:1",
            "127.0.0.1:65536",
            "",
        ] {
            let e = address(bad).unwrap_err();
            assert!(e.contains("not an address"), "{bad}: {e}");
        }
    }

    /// A `B0` of 181 values in mm, `flags` in the count word.
    fn b0(flags: u16) -> Vec<u8> {
        let words: Vec<u16> = (0..181).map(|j| 1000 + j).collect();
        let mut v = MeasuredValues::from_raw(&words, Unit::Millimetre, 0x10).unwrap();
        v.set_scan_flags(flags);
        let mut buf = vec![0u8; v.buffer_len()];
        let n = v.emit(0, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    #[test]
    fn the_tap_takes_whole_scans_across_chunks_and_skips_partial_ones() {
        let mut tap = ScanTap::default();
        let mut bytes = vec![0x55, 0x02, 0x99]; // noise, a false STX
        bytes.extend(b0(0));
        bytes.extend(b0(PARTIAL_SCAN_BIT));
        bytes.extend(b0(0));
        let mut frames = Vec::new();
        for chunk in bytes.chunks(100) {
            tap.feed(chunk, RangeBits::Bits13, |f| frames.push(f));
        }
        assert_eq!(frames.len(), 2);
        assert_eq!((tap.scans, tap.skipped), (2, 1));
        assert_eq!(frames[0].len(), 181);
        assert_eq!(frames[0].ranges()[7], 1.007);
    }

    #[test]
    fn the_pacer_shortens_long_gaps_and_restarts_on_times_going_back() {
        let stop = Arc::new(AtomicBool::new(false));
        let mut pacer = Pacer::new(Arc::clone(&stop));
        assert!(pacer.wait(5_000_000_000));
        // Backwards: due at once (no wait), the clock starts again.
        assert!(pacer.wait(1_000_000_000));
        assert_eq!(pacer.gaps_cut, 0);
        // A gap of an hour counts as MAX_GAP; stopped: no wait at all.
        stop.store(true, Ordering::Relaxed);
        assert!(!pacer.wait(3_600_000_000_000));
        assert_eq!(pacer.gaps_cut, 1);
    }
}
