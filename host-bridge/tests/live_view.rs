//! `--foxglove`: the live view, seen by a WebSocket client of our own
//! (`tungstenite`) speaking the Foxglove protocol as Foxglove does.
//!
//! * `extract --realtime --foxglove` on a shared log: the server info, the
//!   three channels advertised (`cdr`, `ros2msg`, the ROS 2 type names),
//!   and after subscribing, message data on the subscribed channels only,
//!   each payload byte for byte the ROS 2 message the encoders make of the
//!   same frame and its features (what `extract -o x.mcap` writes).
//! * `simulate --foxglove` and `scan --foxglove` at once: both show the
//!   scans that go between them, with features.
//! * A client offering only the older subprotocol name is refused; the
//!   command line's mistakes are errors.
//!
//! Every server binds port 0 (a free port, read from stderr), so tests run
//! in parallel.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, ChildStderr, Command, Stdio};
use std::time::{Duration, Instant};

use host_bridge::options::{ParamArgs, UnitArg};
use host_bridge::ros2::{laser_scan, messages, rosbag2_out::stamp_for};
use lms_core::{Extractor, Frame};
use serde_json::Value;
use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

mod common;
use common::BIN;

/// The subprotocol the Foxglove SDK's server speaks.
const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// A child process killed when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Read `stderr` until the live view's address shows up; the lines read
/// so far on failure.
fn served_url(stderr: &mut BufReader<ChildStderr>) -> String {
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        let n = stderr.read_line(&mut line).unwrap();
        assert!(n > 0, "no Foxglove address on stderr:\n{seen}");
        seen.push_str(&line);
        if let Some(at) = line.find("Foxglove live view on ws://") {
            let url = &line[at + "Foxglove live view on ".len()..];
            return url.split_whitespace().next().unwrap().to_string();
        }
    }
}

/// A Foxglove client: the handshake, the advertised channels, subscriptions.
struct Client {
    ws: WebSocket<MaybeTlsStream<TcpStream>>,
    /// Advertised channels by topic.
    channels: HashMap<String, Value>,
    /// Subscription id → topic.
    subscribed: HashMap<u32, String>,
}

impl Client {
    /// Connect offering `protocols`; the server info and the three channels
    /// read.
    fn connect(url: &str) -> Client {
        let mut request = url.into_client_request().unwrap();
        request
            .headers_mut()
            .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
        let (mut ws, response) = tungstenite::connect(request).expect("cannot connect");
        assert_eq!(
            response.headers()["Sec-WebSocket-Protocol"],
            SUBPROTOCOL,
            "negotiated subprotocol"
        );
        if let MaybeTlsStream::Plain(s) = ws.get_mut() {
            s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        }
        let first = json(ws.read().unwrap());
        assert_eq!(first["op"], "serverInfo", "{first}");
        let mut channels = HashMap::new();
        while channels.len() < messages::CHANNELS.len() {
            let msg = ws.read().unwrap();
            if !msg.is_text() {
                continue;
            }
            let op = json(msg);
            if op["op"] == "advertise" {
                for c in op["channels"].as_array().unwrap() {
                    channels.insert(c["topic"].as_str().unwrap().to_string(), c.clone());
                }
            }
        }
        Client {
            ws,
            channels,
            subscribed: HashMap::new(),
        }
    }

    /// Every channel as the ROS 2 output writes it.
    fn check_channels(&self) {
        for c in messages::CHANNELS {
            let a = &self.channels[c.topic];
            assert_eq!(a["encoding"], "cdr", "{a}");
            assert_eq!(a["schemaEncoding"], "ros2msg", "{a}");
            assert_eq!(a["schemaName"], c.type_name, "{a}");
            assert_eq!(a["schema"], c.schema, "{}: schema text", c.topic);
        }
    }

    fn subscribe(&mut self, topics: &[&str]) {
        let subs: Vec<Value> = topics
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let id = i as u32 + 1;
                self.subscribed.insert(id, t.to_string());
                serde_json::json!({"id": id, "channelId": self.channels[*t]["id"]})
            })
            .collect();
        let op = serde_json::json!({"op": "subscribe", "subscriptions": subs});
        self.ws.send(Message::text(op.to_string())).unwrap();
    }

    /// Message data until every subscribed topic has `n` payloads (or the
    /// deadline): payloads by topic.
    fn receive(&mut self, n: usize, within: Duration) -> HashMap<String, Vec<Vec<u8>>> {
        let mut got: HashMap<String, Vec<Vec<u8>>> = HashMap::new();
        let end = Instant::now() + within;
        let enough = |got: &HashMap<String, Vec<Vec<u8>>>, subs: &HashMap<u32, String>| {
            subs.values()
                .all(|t| got.get(t).is_some_and(|v| v.len() >= n))
        };
        while !enough(&got, &self.subscribed) && Instant::now() < end {
            let Message::Binary(data) = self.ws.read().unwrap() else {
                continue;
            };
            assert_eq!(data[0], 0x01, "binary op: message data");
            let sub = u32::from_le_bytes(data[1..5].try_into().unwrap());
            let topic = self
                .subscribed
                .get(&sub)
                .unwrap_or_else(|| panic!("data for subscription {sub}, not one of ours"));
            got.entry(topic.clone())
                .or_default()
                .push(data[13..].to_vec());
        }
        got
    }
}

/// The header stamp (ns) of a CDR message that starts with a
/// `std_msgs/Header` (after the 4-byte encapsulation header).
fn stamp_ns(cdr: &[u8]) -> i64 {
    let sec = i32::from_le_bytes(cdr[4..8].try_into().unwrap());
    let nanosec = u32::from_le_bytes(cdr[8..12].try_into().unwrap());
    i64::from(sec) * 1_000_000_000 + i64::from(nanosec)
}

fn json(msg: Message) -> Value {
    serde_json::from_str(msg.to_text().unwrap()).unwrap()
}

/// Frames of a log as `extract` reads them, with its parameters.
fn log_frames(path: &Path, count: usize) -> (Vec<Frame>, lms_core::ValidParams) {
    let file = host_bridge::input::open(path, UnitArg::Auto).unwrap();
    let (params, _) = host_bridge::defaults::for_file(&file, &ParamArgs::default())
        .unwrap()
        .unwrap();
    let frames = file.take(count).map(|s| s.unwrap().frame).collect();
    (frames, params.validate().unwrap())
}

#[test]
fn extract_replays_a_log_into_foxglove_as_the_ros2_output_writes_it() {
    let log = common::shared_log("intel-corrected.log.gz");
    let out = common::scratch("live", "extract").join("replay.jsonl");
    let mut child = Command::new(BIN)
        .arg("extract")
        .arg(&log)
        .args([
            "--frames",
            "0..900",
            "--realtime",
            "--foxglove",
            "127.0.0.1:0",
        ])
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let running = Running(child);
    let url = served_url(&mut stderr);
    let mut client = Client::connect(&url);
    client.check_channels();
    // Markers not subscribed: none may arrive.
    client.subscribe(&[messages::SCAN.topic, messages::FEATURES.topic]);
    let got = client.receive(10, Duration::from_secs(30));
    drop(client);
    // Ctrl-C: the replay ends after the frame in hand, cleanly.
    let mut running = running;
    let pid = nix::unistd::Pid::from_raw(i32::try_from(running.0.id()).unwrap());
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).unwrap();
    let status = running.0.wait().unwrap();
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    assert!(status.success(), "{status}: {rest}");
    assert!(rest.contains("--realtime: stopped by a signal"), "{rest}");
    let written = std::fs::read_to_string(&out).unwrap().lines().count();

    let scans = &got[messages::SCAN.topic];
    let features = &got[messages::FEATURES.topic];
    assert!(scans.len() >= 10 && features.len() >= 10, "{got:?}");
    let (frames, params) = log_frames(&log, 900);
    let mut ex = Extractor::new();
    // Each message names its frame by its header stamp: the frame's index
    // at the scan period (Intel: 180 beams, one frame per 13.333 ms).
    let mut both = 0;
    for (topic, payloads) in [
        (messages::SCAN.topic, scans),
        (messages::FEATURES.topic, features),
    ] {
        for payload in payloads {
            let ns = stamp_ns(payload);
            let index = usize::try_from(ns / 13_333_000).unwrap();
            let frame = &frames[index];
            let stamp = stamp_for(index, frame, None, None, None);
            assert_eq!(stamp.ns, ns, "{topic}: the stamp of frame {index}");
            let expected = match topic == messages::SCAN.topic {
                true => messages::scan_cdr(&stamp, frame),
                false => messages::features_cdr(&stamp, ex.run(frame, &params)),
            };
            assert_eq!(payload, &expected, "{topic}: frame {index}");
        }
    }
    for f in features {
        both += usize::from(scans.iter().any(|s| stamp_ns(s) == stamp_ns(f)));
    }
    assert!(both >= 5, "scans and features of the same frames: {both}");
    // Every frame shown was written to the JSON Lines first.
    let last = features
        .iter()
        .map(|f| stamp_ns(f) / 13_333_000)
        .max()
        .unwrap();
    assert!(written > usize::try_from(last).unwrap(), "{written} lines");
    assert!(!got.contains_key(messages::MARKERS.topic));
}

#[test]
fn a_client_offering_only_the_older_subprotocol_name_is_refused() {
    let mut child = Command::new(BIN)
        .args(["extract", "--count", "100000", "--realtime"])
        .args(["--foxglove", "127.0.0.1:0", "-o", "/dev/null"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let _running = Running(child);
    let url = served_url(&mut stderr);
    let mut request = url.as_str().into_client_request().unwrap();
    request.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    match tungstenite::connect(request) {
        Err(tungstenite::Error::Http(response)) => assert_eq!(response.status(), 400),
        Err(e) => panic!("expected HTTP 400, got {e}"),
        Ok(_) => panic!("a client offering only foxglove.websocket.v1 was accepted"),
    }
    // The server still serves the protocol's current name.
    Client::connect(&url).check_channels();
}

/// `simulate` as a child: its pty on stdout, stderr read line by line.
fn simulate() -> (Running, String, BufReader<ChildStderr>) {
    let mut child = Command::new(BIN)
        .args([
            "simulate",
            "--quit-after",
            "60",
            "--foxglove",
            "127.0.0.1:0",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut pty = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut pty)
        .unwrap();
    let stderr = BufReader::new(child.stderr.take().unwrap());
    (Running(child), pty.trim().to_string(), stderr)
}

#[test]
fn simulate_and_scan_show_the_scans_between_them() {
    let (_sim, pty, mut sim_err) = simulate();
    assert!(pty.starts_with("/dev/"), "simulate printed {pty:?}");
    let sim_url = served_url(&mut sim_err);
    let mut sim_view = Client::connect(&sim_url);
    sim_view.subscribe(&[messages::SCAN.topic, messages::MARKERS.topic]);

    let mut scan = Command::new(BIN)
        .args(["scan", "--port", &pty, "--scans", "2000", "--no-save"])
        .args(["--variant", "180/1", "--foxglove", "127.0.0.1:0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut scan_err = BufReader::new(scan.stderr.take().unwrap());
    let scan = Running(scan);
    let scan_url = served_url(&mut scan_err);
    let mut scan_view = Client::connect(&scan_url);
    scan_view.check_channels();
    scan_view.subscribe(&[messages::SCAN.topic, messages::FEATURES.topic]);

    let seen_by_scan = scan_view.receive(5, Duration::from_secs(40));
    let seen_by_sim = sim_view.receive(5, Duration::from_secs(20));
    drop(scan);
    for (who, got) in [("scan", &seen_by_scan), ("simulate", &seen_by_sim)] {
        for (topic, payloads) in got.iter() {
            assert!(payloads.len() >= 5, "{who}: {topic}: {}", payloads.len());
        }
        assert_eq!(got.len(), 2, "{who}: {:?}", got.keys());
        for scan in &got[messages::SCAN.topic] {
            let scan = laser_scan::decode(scan).unwrap();
            // 180°/1° as scan sets it.
            assert_eq!(scan.ranges.len(), 181, "{who}");
            assert_eq!(scan.header.frame_id, messages::DEFAULT_FRAME_ID);
        }
    }
    // The markers of a frame start with the DELETEALL marker.
    for m in &seen_by_sim[messages::MARKERS.topic] {
        let count = u32::from_le_bytes(m[4..8].try_into().unwrap());
        assert!(count >= 1);
    }
}

#[test]
fn coprocessor_shows_the_sensors_scans_with_their_features() {
    let (_sim, pty, _sim_err) = simulate();
    let link = common::scratch("live", "cop").join("lms");
    let mut cop = Command::new(BIN)
        .args(["coprocessor", "--sensor", &pty, "--link"])
        .arg(&link)
        .args(["--quit-after", "60", "--status-every", "0"])
        .args(["--foxglove", "127.0.0.1:0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut cop_err = BufReader::new(cop.stderr.take().unwrap());
    let _cop = Running(cop);
    let mut view = Client::connect(&served_url(&mut cop_err));
    view.check_channels();
    view.subscribe(&[messages::SCAN.topic, messages::FEATURES.topic]);
    // No client on the link: the co-processor streams the sensor anyway.
    let got = view.receive(5, Duration::from_secs(40));
    let scans = &got[messages::SCAN.topic];
    let features = &got[messages::FEATURES.topic];
    assert!(scans.len() >= 5 && features.len() >= 5, "{got:?}");
    for scan in scans {
        // Brought up at 180°/0.5° (the default --variant).
        assert_eq!(laser_scan::decode(scan).unwrap().ranges.len(), 361);
    }
    let paired = features
        .iter()
        .filter(|f| scans.iter().any(|s| stamp_ns(s) == stamp_ns(f)))
        .count();
    assert!(paired >= 3, "features of the scans shown: {paired}");
}

/// Run `host-bridge ARGS`; its stderr, asserting a failure.
fn fails(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().unwrap();
    assert!(!out.status.success(), "{args:?} succeeded");
    let mut err = String::new();
    out.stderr.as_slice().read_to_string(&mut err).unwrap();
    err
}

#[test]
fn the_command_line_mistakes_are_errors() {
    let log = common::shared_log("intel-corrected.log.gz");
    let log = log.to_str().unwrap();
    let e = fails(&["extract", log, "--foxglove"]);
    assert!(e.contains("add --realtime"), "{e}");
    let e = fails(&["extract", "--realtime", "--foxglove", log]);
    assert!(
        e.contains("is not an address") && e.contains("--foxglove=ADDR"),
        "{e}"
    );
    let mcap = common::scratch("live", "cli").join("x.mcap");
    let e = fails(&["extract", log, "--realtime", "-o", mcap.to_str().unwrap()]);
    assert!(e.contains("--realtime writes JSON Lines"), "{e}");
    // A port already taken: a clear error naming it.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let e = fails(&["extract", log, "--realtime", "--foxglove", &addr]);
    assert!(
        e.contains(&format!("--foxglove {addr}: cannot serve there")),
        "{e}"
    );
}
