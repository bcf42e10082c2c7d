//! The ROS 2 outputs: `extract -o x.mcap`, `extract --format rosbag2`, and
//! the live recordings of `scan -o x.mcap` and `coprocessor -o x.mcap`.
//!
//! The files are read back with the `mcap` crate and the CDR messages with
//! a reader written here from the CDR rules (not the writer's code); the
//! values are compared with the JSON Lines of the same run. The Python
//! readers (`mcap-ros2-support`, `rosbags`) check the same outputs in
//! tools/ros2/check_outputs.py.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use host_bridge::extract::{CornerRecord, FrameRecord, LineRecord};
use host_bridge::ros2::laser_scan;
use host_bridge::ros2::messages::{self, Stamp, CHANNELS, FEATURES};

use common::{run, BIN};

fn scratch(name: &str) -> PathBuf {
    common::scratch("ros2-output", name)
}

fn ok(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A CDR body read by the alignment rules: each value aligned on its size
/// from the start of the body (after the 4-byte encapsulation header).
struct Cdr<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> Cdr<'a> {
    fn new(message: &'a [u8]) -> Self {
        assert_eq!(message[..4], [0, 1, 0, 0], "little-endian CDR header");
        Cdr {
            body: &message[4..],
            at: 0,
        }
    }
    fn take(&mut self, n: usize) -> &'a [u8] {
        self.at = self.at.div_ceil(n.min(8)) * n.min(8);
        let b = &self.body[self.at..self.at + n];
        self.at += n;
        b
    }
    fn u8(&mut self) -> u8 {
        let b = &self.body[self.at];
        self.at += 1;
        *b
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take(2).try_into().unwrap())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        let b = &self.body[self.at..self.at + n];
        self.at += n;
        assert_eq!(b.last(), Some(&0), "NUL-terminated");
        String::from_utf8(b[..n - 1].to_vec()).unwrap()
    }
    /// `std_msgs/Header`: (ns, frame id).
    fn header(&mut self) -> (i64, String) {
        let sec = i64::from(self.i32());
        let nanosec = i64::from(self.u32());
        (sec * 1_000_000_000 + nanosec, self.string())
    }
    fn done(&self) {
        assert_eq!(self.at, self.body.len(), "bytes left after the message");
    }
}

/// A decoded `lms_features_msgs/msg/Features`, in extract's record types.
struct Decoded {
    header: (i64, String),
    lines: Vec<LineRecord>,
    corners: Vec<CornerRecord>,
    edges: Vec<u16>,
    stats: lms_core::Stats,
}

fn decode_features(message: &[u8]) -> Decoded {
    let mut r = Cdr::new(message);
    let header = r.header();
    let lines = (0..r.u32())
        .map(|_| {
            let (alpha, rr) = (r.f32(), r.f32());
            let c = [r.f32(), r.f32(), r.f32(), r.f32()];
            let (first, last, points) = (r.u16(), r.u16(), r.u16());
            let chi2 = r.f32();
            let e = [r.f32(), r.f32(), r.f32(), r.f32()];
            LineRecord {
                alpha,
                r: rr,
                cov: [[c[0], c[1]], [c[2], c[3]]],
                first,
                last,
                points,
                chi2,
                endpoints: [[e[0], e[1]], [e[2], e[3]]],
            }
        })
        .collect();
    let corners = (0..r.u32())
        .map(|_| {
            let (x, y) = (r.f32(), r.f32());
            let c = [r.f32(), r.f32(), r.f32(), r.f32()];
            let angle_deg = r.f32();
            let (wc, line_a, line_b) = (r.u8(), r.u8(), r.u8());
            assert!(wc <= 1, "a bool is 0 or 1");
            CornerRecord {
                x,
                y,
                cov: [[c[0], c[1]], [c[2], c[3]]],
                angle_deg,
                well_conditioned: wc == 1,
                line_a,
                line_b,
            }
        })
        .collect();
    let edges = (0..r.u32()).map(|_| r.u16()).collect();
    let counters: Vec<u16> = lms_core::Stats::FIELDS.iter().map(|_| r.u16()).collect();
    r.done();
    Decoded {
        header,
        lines,
        corners,
        edges,
        stats: lms_core::Stats::from_fields(&counters),
    }
}

/// One decoded `visualization_msgs/msg/Marker`: (ns, id, type, action, points).
fn decode_marker(r: &mut Cdr) -> (String, i32, i32, i32, Vec<[f64; 3]>) {
    r.header();
    let ns = r.string();
    let (id, kind, action) = (r.i32(), r.i32(), r.i32());
    for _ in 0..7 + 3 {
        r.f64(); // pose, scale
    }
    for _ in 0..4 {
        r.f32(); // color
    }
    // lifetime 0 (forever: the next DELETEALL removes it), not frame-locked.
    assert_eq!((r.i32(), r.u32(), r.u8()), (0, 0, 0));
    let points = (0..r.u32()).map(|_| [r.f64(), r.f64(), r.f64()]).collect();
    for _ in 0..r.u32() * 4 {
        r.f32(); // colors
    }
    r.string(); // texture_resource
    r.header(); // texture
    r.string();
    for _ in 0..r.u32() {
        r.u8();
    }
    for _ in 0..r.u32() * 2 {
        r.f32(); // uv_coordinates
    }
    // text, mesh_resource, mesh_file.filename: none.
    assert_eq!([r.string(), r.string(), r.string()], ["", "", ""]);
    for _ in 0..r.u32() {
        r.u8();
    }
    r.u8(); // mesh_use_embedded_materials
    (ns, id, kind, action, points)
}

/// Every message of an MCAP file, by topic, in file order.
fn messages_by_topic(bytes: &[u8]) -> Vec<(String, u64, Vec<u8>)> {
    mcap::MessageStream::new(bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.into_owned())
        })
        .collect()
}

/// The embedded schema of `/features` is the shipped .msg files, each
/// after its `MSG:` line; every file of the package is embedded.
#[test]
fn features_schema_is_the_shipped_msg_files() {
    let dir = common::workspace().join("ros2/lms_features_msgs/msg");
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    let separator = format!("\n{}\nMSG: ", "=".repeat(80));
    let mut sections = FEATURES.schema.split(separator.as_str());
    assert_eq!(sections.next().unwrap(), read("Features.msg"));
    let mut embedded = vec!["Features.msg".to_string()];
    for section in sections {
        let (name, text) = section.split_once('\n').unwrap();
        if let Some(msg) = name.strip_prefix("lms_features_msgs/") {
            assert_eq!(text, read(&format!("{msg}.msg")), "{name}");
            embedded.push(format!("{msg}.msg"));
        }
    }
    let mut shipped: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    shipped.sort();
    embedded.sort();
    assert_eq!(embedded, shipped);
    // Every type named in a section has its own section.
    for needed in ["std_msgs/Header", "builtin_interfaces/Time"] {
        assert!(
            FEATURES.schema.contains(&format!("MSG: {needed}\n")),
            "{needed}"
        );
    }
}

/// Stats.msg lists every counter of the library, in order; the package
/// builds every .msg file and carries the workspace's version.
#[test]
fn interface_package_matches_the_library() {
    let pkg = common::workspace().join("ros2/lms_features_msgs");
    let stats = std::fs::read_to_string(pkg.join("msg/Stats.msg")).unwrap();
    let fields: Vec<&str> = stats
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.strip_prefix("uint16 ").expect(l))
        .collect();
    let names: Vec<&str> = lms_core::Stats::FIELDS.iter().map(|(n, _)| *n).collect();
    assert_eq!(fields, names);
    let cmake = std::fs::read_to_string(pkg.join("CMakeLists.txt")).unwrap();
    for e in std::fs::read_dir(pkg.join("msg")).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(cmake.contains(&format!("\"msg/{name}\"")), "{name}");
    }
    let xml = std::fs::read_to_string(pkg.join("package.xml")).unwrap();
    let version = format!("<version>{}</version>", env!("CARGO_PKG_VERSION"));
    assert!(xml.contains(&version), "package.xml lacks {version}");
}

/// `extract -o x.mcap` on the CSAIL log: profile ros2, zstd chunks, a
/// summary with indexes and statistics, three channels; every `/features`
/// equals the JSON Lines record of the same frame, every `/scan` its
/// ranges, and every marker array starts with DELETEALL.
#[test]
fn extract_mcap_matches_the_json_lines() {
    let dir = scratch("csail");
    let log = common::csail();
    let (mcap, jsonl) = (dir.join("csail.mcap"), dir.join("csail.jsonl"));
    ok(&run(&[
        "extract",
        log.to_str().unwrap(),
        "-o",
        mcap.to_str().unwrap(),
    ]));
    ok(&run(&[
        "extract",
        log.to_str().unwrap(),
        "-o",
        jsonl.to_str().unwrap(),
    ]));
    let bytes = std::fs::read(&mcap).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    assert!(!summary.chunk_indexes.is_empty());
    assert!(summary
        .chunk_indexes
        .iter()
        .all(|c| c.compression == "zstd"));
    let stats = summary.stats.expect("statistics");
    assert_eq!(stats.channel_count, 3);
    let mut topics: Vec<(String, String, String)> = summary
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().unwrap();
            (c.topic.clone(), s.name.clone(), s.encoding.clone())
        })
        .collect();
    topics.sort();
    let mut expected: Vec<_> = CHANNELS
        .iter()
        .map(|c| {
            (
                c.topic.to_string(),
                c.type_name.to_string(),
                "ros2msg".to_string(),
            )
        })
        .collect();
    expected.sort();
    assert_eq!(topics, expected);
    assert!(summary
        .channels
        .values()
        .all(|c| c.message_encoding == "cdr"));
    let header_profile = &bytes[8..];
    assert!(
        header_profile.windows(4).take(64).any(|w| w == b"ros2"),
        "header profile ros2"
    );

    let records: Vec<FrameRecord> = std::fs::read_to_string(&jsonl)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let all = messages_by_topic(&bytes);
    assert_eq!(stats.message_count, all.len() as u64);
    assert_eq!(all.len(), 3 * records.len());
    for (k, rec) in records.iter().enumerate() {
        let frame = &all[3 * k..3 * k + 3];
        let topics: Vec<&str> = frame.iter().map(|m| m.0.as_str()).collect();
        assert_eq!(topics, ["/scan", "/features/markers", "/features"]);
        // Stamps: one scan period apart (26.667 ms at 0.5°), from 0.
        assert_eq!(frame[0].1, k as u64 * 26_667_000);
        assert!(frame.iter().all(|m| m.1 == frame[0].1));
        // The scan: ranges as in the JSON, invalid beams not finite.
        let scan = laser_scan::decode(&frame[0].2).unwrap();
        assert_eq!(scan.header.frame_id, "laser");
        assert_eq!(scan.header.stamp.as_nanos() as u64, frame[0].1);
        assert_eq!(scan.ranges.len(), rec.ranges.len());
        for (r, j) in scan.ranges.iter().zip(&rec.ranges) {
            match j {
                Some(v) => assert_eq!(r, v),
                None => assert!(!r.is_finite()),
            }
        }
        // The features, value for value.
        let d = decode_features(&frame[2].2);
        assert_eq!(d.header, (frame[0].1 as i64, "laser".to_string()));
        assert_eq!(d.lines, rec.lines, "frame {k}");
        assert_eq!(d.corners, rec.corners, "frame {k}");
        assert_eq!(d.edges, rec.edges, "frame {k}");
        assert_eq!(d.stats, *rec.stats, "frame {k}");
        // Markers: DELETEALL first; one LINE_LIST with two points a line.
        let mut r = Cdr::new(&frame[1].2);
        let markers: Vec<_> = (0..r.u32()).map(|_| decode_marker(&mut r)).collect();
        r.done();
        assert_eq!(markers[0].3, 3, "DELETEALL first");
        let drawn = markers.iter().find(|m| m.0 == "lines");
        assert_eq!(drawn.map_or(0, |m| m.4.len()), 2 * rec.lines.len());
        let ellipses = markers.iter().filter(|m| m.0 == "corner_ellipses");
        assert_eq!(ellipses.clone().count(), rec.corners.len());
        // A closed ring around its corner.
        for (e, c) in ellipses.zip(&rec.corners) {
            assert_eq!(e.4.first(), e.4.last());
            let mean_x = e.4[1..].iter().map(|p| p[0]).sum::<f64>() / (e.4.len() - 1) as f64;
            assert!(
                (mean_x - f64::from(c.x)).abs() < 1e-6,
                "{mean_x} vs {}",
                c.x
            );
        }
    }
    // Read back as input (extract's bag input): the same features.
    let again = run(&["extract", mcap.to_str().unwrap()]);
    ok(&again);
    let again: Vec<FrameRecord> = String::from_utf8(again.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(again.len(), records.len());
    for (a, b) in again.iter().zip(&records) {
        assert_eq!(
            (&a.lines, &a.corners, &a.edges),
            (&b.lines, &b.corners, &b.edges)
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--format` and the extension: `.mcap` chooses MCAP, `--format jsonl`
/// keeps JSON Lines (the same bytes as on standard output); an MCAP to
/// standard output is refused, and so is a rosbag2 folder that holds files.
#[test]
fn format_choice_and_refusals() {
    let dir = scratch("format");
    let json_named_mcap = dir.join("really-json.mcap");
    let args = ["extract", "--count", "3"];
    let stdout = run(&args);
    ok(&stdout);
    let out = run(&[
        &args[..],
        &["--format", "jsonl", "-o", json_named_mcap.to_str().unwrap()],
    ]
    .concat());
    ok(&out);
    assert_eq!(std::fs::read(&json_named_mcap).unwrap(), stdout.stdout);
    let out = run(&[&args[..], &["--format", "mcap"]].concat());
    assert!(!out.status.success());
    let full = dir.join("full");
    std::fs::create_dir(&full).unwrap();
    std::fs::write(full.join("x"), "x").unwrap();
    let out = run(&[
        &args[..],
        &["--format", "rosbag2", "-o", full.to_str().unwrap()],
    ]
    .concat());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not empty"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--format rosbag2`: metadata.yaml beside NAME_0.mcap, with the counts,
/// the time span and the topics of the file, and the same YAML in the
/// MCAP's `rosbag2` metadata record.
#[test]
fn rosbag2_folder_describes_its_mcap() {
    let dir = scratch("bag");
    let bag = dir.join("scene_bag");
    ok(&run(&[
        "extract",
        "--count",
        "5",
        "--format",
        "rosbag2",
        "-o",
        bag.to_str().unwrap(),
    ]));
    let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
    let bytes = std::fs::read(bag.join("scene_bag_0.mcap")).unwrap();
    let all = messages_by_topic(&bytes);
    assert_eq!(all.len(), 15);
    let last = all.iter().map(|m| m.1).max().unwrap();
    for needed in [
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n".to_string(),
        format!("  duration:\n    nanoseconds: {last}\n"),
        "  starting_time:\n    nanoseconds_since_epoch: 0\n  message_count: 15\n".to_string(),
        "  relative_file_paths:\n    - scene_bag_0.mcap\n".to_string(),
        "        name: /features\n        type: lms_features_msgs/msg/Features\n".to_string(),
        "        serialization_format: cdr\n".to_string(),
        "      message_count: 5\n".to_string(),
        "  compression_format: \"\"\n".to_string(),
    ] {
        assert!(yaml.contains(&needed), "{needed:?} not in\n{yaml}");
    }
    assert_eq!(
        yaml.matches("offered_qos_profiles: \"- history: 1").count(),
        3
    );
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert_eq!(summary.metadata_indexes.len(), 1);
    assert_eq!(summary.metadata_indexes[0].name, "rosbag2");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Library level: the CDR of a frame's messages, checked field by field.
#[test]
fn messages_of_a_wall() {
    let g = lms_core::Variant::Fov180Res100.geometry();
    let ranges: Vec<f32> = (0..181)
        .map(|j| {
            let c = g.bearing(j).cos();
            if c > 0.2 {
                2.0 / c
            } else {
                0.0
            }
        })
        .collect();
    let frame = lms_core::Frame::from_metres(g, &ranges).unwrap();
    let mut ex = lms_core::Extractor::new();
    let features = ex.run(&frame, &lms_core::ValidParams::DEFAULT).clone();
    let stamp = Stamp {
        ns: 1_700_000_000_250_000_000,
        frame_id: "lms".into(),
    };
    let d = decode_features(&messages::features_cdr(&stamp, &features));
    assert_eq!(d.header, (stamp.ns, "lms".to_string()));
    assert_eq!(d.lines.len(), features.lines().len());
    assert_eq!(d.lines[0].r, features.lines()[0].r);
    assert!((d.lines[0].r - 2.0).abs() < 1e-3);
    let scan = laser_scan::decode(&messages::scan_cdr(&stamp, &frame)).unwrap();
    assert_eq!(scan.angle_min, g.first_bearing);
    assert_eq!(scan.angle_increment, g.step);
    assert_eq!(scan.ranges.len(), 181);
    // Beams of range 0 (no distance) are not finite in the message.
    assert!(scan.ranges[0].is_nan() && scan.ranges[90] == ranges[90]);
    let bytes = messages::markers_cdr(&stamp, &frame, &features);
    let mut r = Cdr::new(&bytes);
    let markers: Vec<_> = (0..r.u32()).map(|_| decode_marker(&mut r)).collect();
    r.done();
    assert_eq!(markers[0].3, 3, "DELETEALL");
    assert_eq!(markers[1].0, "lines");
    assert_eq!(markers[1].2, 5, "LINE_LIST");
    assert_eq!(markers[1].4.len(), 2 * features.lines().len());
}

/// A running `host-bridge simulate` on a pseudo-terminal, killed when dropped.
struct Simulator {
    child: Child,
    pty: PathBuf,
}

impl Simulator {
    fn start(dir: &Path) -> Simulator {
        let mut child = Command::new(BIN)
            .args(["simulate", "--quit-after", "120"])
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(dir.join("simulate.log")).unwrap())
            .spawn()
            .expect("cannot start host-bridge simulate");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let pty = PathBuf::from(line.trim());
        assert!(pty.starts_with("/dev/"), "simulate printed {line:?}");
        Simulator { child, pty }
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `scan -o x.mcap` streaming from the simulator until the file holds
/// `bytes` (chunks reach the file whole, one a second).
fn recording_scan(sim: &Simulator, path: &Path, bytes: u64) -> Child {
    let child = Command::new(BIN)
        .args(["scan", "--port", sim.pty.to_str().unwrap()])
        .args(["--baud", "500000", "--scans", "100000", "-o"])
        .arg(path)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while std::fs::metadata(path).map_or(0, |m| m.len()) < bytes {
        assert!(Instant::now() < deadline, "nothing recorded");
        std::thread::sleep(Duration::from_millis(50));
    }
    child
}

fn signal(child: &Child, signal: nix::sys::signal::Signal) {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).unwrap());
    nix::sys::signal::kill(pid, signal).unwrap();
}

/// Messages readable by a linear read from the start, up to the first
/// error (a cut file ends in one).
fn readable(bytes: &[u8]) -> (usize, bool) {
    let mut n = 0;
    for m in mcap::MessageStream::new(bytes).unwrap() {
        match m {
            Ok(_) => n += 1,
            Err(_) => return (n, true),
        }
    }
    (n, false)
}

/// SIGKILL during a recording: no summary, but every chunk written before
/// the kill reads back (the linear reader and `extract`'s own bag input).
#[test]
fn killed_recording_keeps_its_complete_chunks() {
    let dir = scratch("kill");
    let sim = Simulator::start(&dir);
    let path = dir.join("killed.mcap");
    // Past the header, schemas and channels (about 5 kB): a chunk is in.
    let child = recording_scan(&sim, &path, 20_000);
    std::thread::sleep(Duration::from_millis(300));
    signal(&child, nix::sys::signal::Signal::SIGKILL);
    let _ = child.wait_with_output().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert!(matches!(mcap::Summary::read(&bytes), Ok(None) | Err(_)));
    let (n, _) = readable(&bytes);
    assert!(n >= 3, "{n} messages readable");
    let scans = messages_by_topic_lenient(&bytes)
        .iter()
        .filter(|t| t.as_str() == "/scan")
        .count();
    assert!(scans >= 1);
    // extract's own bag input reads the same scans.
    let out = run(&["extract", path.to_str().unwrap()]);
    ok(&out);
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), scans);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The topics of the messages readable before the first error.
fn messages_by_topic_lenient(bytes: &[u8]) -> Vec<String> {
    mcap::MessageStream::new(bytes)
        .unwrap()
        .map_while(|m| m.ok().map(|m| m.channel.topic.clone()))
        .collect()
}

/// SIGINT (and SIGTERM) during a recording: the session ends, the file is
/// finished: a summary with chunk indexes and statistics that count every
/// message, and `extract` reads it.
#[test]
fn interrupted_recording_is_finished() {
    let dir = scratch("int");
    let sim = Simulator::start(&dir);
    for (name, sig) in [
        ("int", nix::sys::signal::Signal::SIGINT),
        ("term", nix::sys::signal::Signal::SIGTERM),
    ] {
        let path = dir.join(format!("{name}.mcap"));
        let child = recording_scan(&sim, &path, 20_000);
        signal(&child, sig);
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("interrupted by a signal"), "{err}");
        assert!(
            err.contains("the scans so far are kept: recording:"),
            "{err}"
        );
        let bytes = std::fs::read(&path).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
        assert!(!summary.chunk_indexes.is_empty());
        let (n, cut) = readable(&bytes);
        assert!(!cut, "{name}: the file reads to its end");
        assert_eq!(summary.stats.unwrap().message_count, n as u64);
        assert_eq!(n % 3, 0);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `coprocessor -o x.mcap`: the sensor's scans with the co-processor's
/// features, finished at --quit-after.
#[test]
fn coprocessor_records_the_sensor() {
    let dir = scratch("cop");
    let sim = Simulator::start(&dir);
    let path = dir.join("cop.mcap");
    let out = run(&[
        "coprocessor",
        "--sensor",
        sim.pty.to_str().unwrap(),
        "--link",
        dir.join("link").to_str().unwrap(),
        "--status-every",
        "0",
        "--quit-after",
        "3",
        "-o",
        path.to_str().unwrap(),
    ]);
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("recording: "), "{err}");
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let all = messages_by_topic(&bytes);
    assert_eq!(summary.stats.unwrap().message_count, all.len() as u64);
    assert!(all.len() >= 30, "{} messages", all.len());
    for m in all.iter().filter(|m| m.0 == "/scan") {
        let scan = laser_scan::decode(&m.2).unwrap();
        assert_eq!(scan.ranges.len(), 361);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
