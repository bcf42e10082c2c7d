//! ROS 2 bags as input (`host_bridge::ros2::bag_in`): bags written here
//! with the `mcap` crate (no Python), read through `input::open_topic` and
//! the `extract` command: geometry mapping, invalid beams and their
//! reasons, topic choice, stamps and frame ids, a file cut at every chunk
//! boundary and inside chunks, rosbag2 folders with missing files, and
//! frames bit-identical to the same ranges in a CARMEN log.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use host_bridge::carmen::{parse_log, UnitMode};
use host_bridge::input::{self, InputScan, Kind, ReadOptions, ScanFile};
use host_bridge::options::UnitArg;
use host_bridge::ros2::bag_in::BagScans;
use host_bridge::ros2::laser_scan::{self, Header, LaserScan, Time, SCHEMA_NAME, SCHEMA_TEXT};
use lms_core::{Beam, Invalid, Unit, Variant};
use mcap::records::MessageHeader;
use mcap::{Compression, WriteOptions};

mod common;
use common::{run, stderr};

fn scratch(name: &str) -> PathBuf {
    common::scratch("ros2-input", name)
}

/// The range code of beam `j` of scan `k` (cm): every value 0.50 … 80.49 m.
fn code(j: usize, k: usize) -> i64 {
    ((37 * j + 11 * k) % 8000 + 50) as i64
}

/// Scan `k` of `variant`: ranges `code / 100` m, a stamp and a frame id.
fn scan(variant: Variant, beams: usize, k: usize) -> LaserScan {
    let g = variant.geometry();
    LaserScan {
        header: Header {
            stamp: Time {
                sec: 1_700_000_000 + k as i32,
                nanosec: 125_000_000,
            },
            frame_id: format!("laser_{k}"),
        },
        angle_min: g.first_bearing,
        angle_max: g.bearing(beams - 1),
        angle_increment: g.step,
        time_increment: 0.0,
        scan_time: 0.2,
        range_min: 0.0,
        range_max: 81.82,
        ranges: (0..beams)
            .map(|j| (code(j, k) as f64 / 100.0) as f32)
            .collect(),
        intensities: Vec::new(),
    }
}

/// A channel of a bag: topic, schema name, message encoding.
struct Chan<'a>(&'a str, &'a str, &'a str);

const SCAN: Chan = Chan("/scan", SCHEMA_NAME, "cdr");

/// Write an MCAP file at `path`: `messages` (channel index, CDR bytes)
/// in chunks of `per_chunk` messages, compressed or not. The summary
/// (chunk offsets) is returned.
fn write_mcap(
    path: &Path,
    chans: &[Chan],
    zstd: bool,
    per_chunk: usize,
    messages: &[(usize, Vec<u8>)],
) -> mcap::Summary {
    let options = WriteOptions::new()
        .compression(zstd.then_some(Compression::Zstd))
        .chunk_size(None)
        .profile("ros2");
    let mut w = options
        .create(BufWriter::new(File::create(path).unwrap()))
        .unwrap();
    let ids: Vec<u16> = chans
        .iter()
        .map(|c| {
            let schema = w
                .add_schema(c.1, "ros2msg", SCHEMA_TEXT.as_bytes())
                .unwrap();
            w.add_channel(schema, c.0, c.2, &BTreeMap::new()).unwrap()
        })
        .collect();
    for (i, (chan, data)) in messages.iter().enumerate() {
        let header = MessageHeader {
            channel_id: ids[*chan],
            sequence: i as u32,
            log_time: 1_000 + i as u64,
            publish_time: 1_000 + i as u64,
        };
        w.write_to_known_channel(&header, data).unwrap();
        if (i + 1) % per_chunk == 0 {
            w.flush().unwrap();
        }
    }
    w.finish().unwrap()
}

/// An MCAP file of `n` scans of `variant` on `/scan`.
fn scans_bag(path: &Path, variant: Variant, beams: usize, n: usize) {
    let messages: Vec<_> = (0..n)
        .map(|k| (0, laser_scan::encode(&scan(variant, beams, k))))
        .collect();
    write_mcap(path, &[SCAN], true, 4, &messages);
}

fn open(path: &Path, topic: Option<&str>) -> anyhow::Result<ScanFile> {
    let options = ReadOptions {
        unit: UnitArg::Auto,
        keep_damaged: false,
    };
    input::open_topic(path, options, topic)
}

fn read_all(path: &Path, topic: Option<&str>) -> Vec<InputScan> {
    open(path, topic)
        .unwrap()
        .collect::<anyhow::Result<Vec<_>>>()
        .unwrap()
}

fn error_of<T: std::fmt::Debug>(r: anyhow::Result<T>) -> String {
    format!("{:#}", r.unwrap_err())
}

#[test]
fn every_lms_geometry_maps_to_its_variant() {
    let dir = scratch("geometry");
    let cases = [
        (Variant::Fov180Res100, 181),
        (Variant::Fov180Res100, 180),
        (Variant::Fov180Res50, 361),
        (Variant::Fov180Res50, 360),
        (Variant::Fov100Res100, 101),
        (Variant::Fov100Res50, 201),
        (Variant::Fov100Res25, 401),
    ];
    for (variant, beams) in cases {
        let path = dir.join(format!("{beams}.mcap"));
        scans_bag(&path, variant, beams, 3);
        let scans = read_all(&path, None);
        assert_eq!(scans.len(), 3);
        for s in &scans {
            assert_eq!(s.frame.len(), beams);
            assert_eq!(s.frame.geometry(), variant.geometry(), "{beams}");
        }
    }
}

#[test]
fn an_unsupported_geometry_is_an_error_naming_it() {
    let dir = scratch("bad-geometry");
    // A 270° scanner at 0.25°: 1081 ranges from -135°.
    let mut s = scan(Variant::Fov180Res100, 181, 0);
    s.angle_min = (-135f32).to_radians();
    s.angle_increment = 0.25f32.to_radians();
    s.ranges = vec![1.0; 1081];
    let path = dir.join("270.mcap");
    write_mcap(&path, &[SCAN], true, 4, &[(0, laser_scan::encode(&s))]);
    let all = |p: &Path| open(p, None).and_then(|f| f.collect::<anyhow::Result<Vec<_>>>());
    let err = error_of(all(&path));
    assert!(err.contains("unsupported scan geometry"), "{err}");
    assert!(err.contains("angle_min -135.000°"), "{err}");
    assert!(err.contains("angle_increment 0.2500°"), "{err}");
    assert!(err.contains("1081 ranges"), "{err}");
    // An LMS count with the wrong start angle.
    let mut s = scan(Variant::Fov180Res50, 361, 0);
    s.angle_min = 0.0;
    write_mcap(&path, &[SCAN], true, 4, &[(0, laser_scan::encode(&s))]);
    let err = error_of(all(&path));
    assert!(
        err.contains("angle_min 0.000°") && err.contains("361 ranges"),
        "{err}"
    );
    // Through the command: an error, no panic.
    let out = run(&["extract", path.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("unsupported scan geometry"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn invalid_ranges_are_counted_by_reason() {
    let dir = scratch("invalid");
    let mut s = scan(Variant::Fov180Res100, 181, 0);
    s.range_min = 0.1;
    s.range_max = 81.0;
    s.ranges[0] = f32::NAN;
    s.ranges[1] = f32::INFINITY;
    s.ranges[2] = f32::NEG_INFINITY;
    s.ranges[3] = 0.05; // below range_min
    s.ranges[4] = -1.0; // below range_min
    s.ranges[5] = 81.5; // above range_max
    s.ranges[6] = 81.91; // above range_max, the cm "no echo" code
    s.ranges[7] = 81.83; // above range_max, the cm "above maximum range" code
    let path = dir.join("invalid.mcap");
    write_mcap(&path, &[SCAN], false, 4, &[(0, laser_scan::encode(&s))]);
    let mut bag = BagScans::open(&path, None, None).unwrap();
    assert_eq!(bag.unit(), Unit::Centimetre);
    let frame = bag.next().unwrap().unwrap().frame;
    let beams = frame.beams();
    let invalid = |j: usize| beams[j];
    for j in 0..3 {
        assert_eq!(invalid(j), Beam::Invalid(Invalid::NotFinite));
    }
    assert_eq!(invalid(3), Beam::Invalid(Invalid::Zero));
    assert_eq!(invalid(4), Beam::Invalid(Invalid::Zero));
    assert_eq!(invalid(5), Beam::Invalid(Invalid::AboveMax));
    assert_eq!(invalid(6), Beam::Invalid(Invalid::NoEcho));
    assert_eq!(invalid(7), Beam::Invalid(Invalid::AboveMax));
    assert!(beams[8..].iter().all(|b| b.is_valid()));
    let counts = bag.invalid();
    assert_eq!(
        (counts.not_finite, counts.below_min, counts.above_max),
        (3, 2, 3)
    );
    assert_eq!(counts.total(), 8);
    // The command reports them on stderr.
    let out = run(&[
        "extract",
        path.to_str().unwrap(),
        "-o",
        dir.join("o.jsonl").to_str().unwrap(),
    ]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("1 scans of /scan: 8 invalid beams (2 below range_min, 3 above range_max, 3 not finite)"),
        "{err}"
    );
}

#[test]
fn the_unit_follows_range_max_or_unit() {
    let dir = scratch("unit");
    let mut s = scan(Variant::Fov180Res100, 181, 0);
    s.range_max = 8.182;
    s.ranges[0] = 1.2345;
    let path = dir.join("mm.mcap");
    write_mcap(&path, &[SCAN], true, 4, &[(0, laser_scan::encode(&s))]);
    let f = open(&path, None).unwrap();
    assert_eq!(
        *f.kind(),
        Kind::Bag {
            unit: Unit::Millimetre
        }
    );
    let first = read_all(&path, None).remove(0);
    // 1.2345 m as f32 is 1234.50005 mm: code 1235.
    assert_eq!(first.frame.ranges()[0], 1.235f32);
    let options = ReadOptions {
        unit: UnitArg::Cm,
        keep_damaged: false,
    };
    let f = input::open_topic(&path, options, None).unwrap();
    assert_eq!(
        *f.kind(),
        Kind::Bag {
            unit: Unit::Centimetre
        }
    );
    assert_eq!(
        f.into_iter().next().unwrap().unwrap().frame.ranges()[0],
        1.23f32
    );
}

#[test]
fn stamps_and_frame_ids_are_kept() {
    let dir = scratch("stamps");
    let path = dir.join("s.mcap");
    scans_bag(&path, Variant::Fov180Res50, 361, 5);
    for (k, s) in read_all(&path, None).iter().enumerate() {
        assert_eq!(s.index, k);
        assert_eq!(
            s.stamp_ns,
            Some((1_700_000_000 + k as i64) * 1_000_000_000 + 125_000_000)
        );
        assert_eq!(s.frame_id.as_deref(), Some(format!("laser_{k}").as_str()));
        assert_eq!(s.pose, None);
    }
}

#[test]
fn frames_are_bit_identical_to_the_same_ranges_in_a_carmen_log() {
    let dir = scratch("carmen");
    let path = dir.join("b.mcap");
    let n = 6;
    scans_bag(&path, Variant::Fov180Res50, 361, n);
    let mut log = String::new();
    for k in 0..n {
        let ranges: Vec<String> = (0..361)
            .map(|j| format!("{}.{:02}", code(j, k) / 100, code(j, k) % 100))
            .collect();
        log += &format!("FLASER 361 {} 0 0 0 0 0 0 1.0 host 1.0\n", ranges.join(" "));
    }
    // Codes at or above 81.83 m and zeros: invalid alike in both.
    let (_, carmen) = parse_log(log.as_bytes(), UnitMode::Centimetre).unwrap();
    let bag = read_all(&path, None);
    assert_eq!(bag.len(), carmen.len());
    for (b, c) in bag.iter().zip(&carmen) {
        assert_eq!(b.frame.geometry(), c.frame.geometry());
        assert_eq!(b.frame.beams(), c.frame.beams());
        let bits = |f: &lms_core::Frame| f.ranges().iter().map(|r| r.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&b.frame), bits(&c.frame));
    }
}

#[test]
fn the_topic_is_the_only_laser_scan_or_the_one_asked_for() {
    let dir = scratch("topics");
    let chans = [
        Chan("/front", SCHEMA_NAME, "cdr"),
        Chan("/rear", SCHEMA_NAME, "cdr"),
        Chan("/odom", "nav_msgs/msg/Odometry", "cdr"),
    ];
    let messages: Vec<_> = (0..9)
        .map(|i| {
            let beams = if i % 3 == 1 { 181 } else { 361 };
            let v = Variant::from_beams(beams).unwrap();
            (i % 3, laser_scan::encode(&scan(v, beams, i)))
        })
        .collect();
    let path = dir.join("two.mcap");
    write_mcap(&path, &chans, true, 2, &messages);
    let err = error_of(open(&path, None));
    assert!(
        err.contains("2 sensor_msgs/msg/LaserScan topics: /front, /rear; choose one with --topic"),
        "{err}"
    );
    let rear = read_all(&path, Some("/rear"));
    assert_eq!(rear.len(), 3);
    assert!(rear.iter().all(|s| s.frame.len() == 181));
    let front = read_all(&path, Some("/front"));
    assert_eq!(front.len(), 3);
    assert!(front.iter().all(|s| s.frame.len() == 361));
    let err = error_of(open(&path, Some("/odom")));
    assert!(
        err.contains("topic /odom holds nav_msgs/msg/Odometry"),
        "{err}"
    );
    let err = error_of(open(&path, Some("/nowhere")));
    assert!(
        err.contains("no topic /nowhere; its topics: /front"),
        "{err}"
    );
    // On the command line.
    let p = path.to_str().unwrap();
    let out = run(&[
        "extract",
        p,
        "--topic",
        "/rear",
        "-o",
        dir.join("r.jsonl").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("3 scans of /rear"),
        "{}",
        stderr(&out)
    );
    let out = run(&["extract", p]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("choose one with --topic"),
        "{}",
        stderr(&out)
    );
    // --topic on a CARMEN log is refused.
    let out = run(&[
        "extract",
        common::csail().to_str().unwrap(),
        "--topic",
        "/scan",
    ]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("is not a ROS 2 bag"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_bag_without_laser_scans_or_with_another_encoding_is_refused() {
    let dir = scratch("no-scans");
    let path = dir.join("odom.mcap");
    write_mcap(
        &path,
        &[Chan("/odom", "nav_msgs/msg/Odometry", "cdr")],
        true,
        4,
        &[(0, vec![0, 1, 0, 0])],
    );
    let err = error_of(open(&path, None));
    assert!(
        err.contains(
            "no sensor_msgs/msg/LaserScan topic; its topics: /odom (nav_msgs/msg/Odometry)"
        ),
        "{err}"
    );
    let path = dir.join("json.mcap");
    write_mcap(
        &path,
        &[Chan("/scan", SCHEMA_NAME, "json")],
        true,
        4,
        &[(0, b"{}".to_vec())],
    );
    let err = error_of(open(&path, None));
    assert!(
        err.contains("message encoding \"json\" is not supported"),
        "{err}"
    );
    // A damaged message: an error naming the scan, not a panic.
    let path = dir.join("short.mcap");
    let mut bytes = laser_scan::encode(&scan(Variant::Fov180Res100, 181, 0));
    bytes.truncate(100);
    write_mcap(&path, &[SCAN], true, 4, &[(0, bytes)]);
    let err = error_of(open(&path, None));
    assert!(err.contains("scan 0 of /scan"), "{err}");
}

/// The end offsets of the chunks of an MCAP file (its summary).
fn chunk_ends(summary: &mcap::Summary) -> Vec<u64> {
    summary
        .chunk_indexes
        .iter()
        .map(|c| c.chunk_start_offset + c.chunk_length)
        .collect()
}

/// Read `bytes` cut to `len` as a bag: the scans read (every one must be
/// `Ok`) and the cut message.
fn read_cut(dir: &Path, bytes: &[u8], len: usize) -> (usize, Option<String>) {
    let path = dir.join(format!("cut-{len}.mcap"));
    std::fs::write(&path, &bytes[..len]).unwrap();
    let mut file = match open(&path, None) {
        Ok(f) => f,
        // Cut before its first whole scan: the error says so.
        Err(e) => return (0, Some(format!("{e:#}"))),
    };
    let mut n = 0;
    for s in file.by_ref() {
        let s = s.unwrap_or_else(|e| panic!("cut at {len}: {e:#}"));
        assert_eq!(s.index, n);
        n += 1;
    }
    let cut = file.cut();
    std::fs::remove_file(&path).unwrap();
    (n, cut)
}

#[test]
fn a_file_cut_at_every_chunk_boundary_and_inside_chunks_keeps_its_complete_scans() {
    let dir = scratch("cut");
    let per_chunk = 3;
    let n = 12;
    for zstd in [true, false] {
        let path = dir.join("whole.mcap");
        let messages: Vec<_> = (0..n)
            .map(|k| (0, laser_scan::encode(&scan(Variant::Fov180Res100, 181, k))))
            .collect();
        let summary = write_mcap(&path, &[SCAN], zstd, per_chunk, &messages);
        let bytes = std::fs::read(&path).unwrap();
        let ends = chunk_ends(&summary);
        assert_eq!(ends.len(), n / per_chunk);
        let starts: Vec<u64> = summary
            .chunk_indexes
            .iter()
            .map(|c| c.chunk_start_offset)
            .collect();
        for (c, &end) in ends.iter().enumerate() {
            // At the chunk's end: its scans and those before are all read.
            let (got, cut) = read_cut(&dir, &bytes, end as usize);
            assert_eq!(
                got,
                (c + 1) * per_chunk,
                "zstd {zstd}: cut at the end of chunk {c}"
            );
            assert!(
                cut.is_some_and(|m| m.contains("cut")),
                "zstd {zstd}: chunk {c}"
            );
            // Inside the chunk: every scan of the chunks before it at least,
            // and without compression every message whole before the cut.
            for frac in [1, 2, 3] {
                let at = starts[c] + (end - starts[c]) * frac / 4;
                let (got, cut) = read_cut(&dir, &bytes, at as usize);
                assert!(
                    cut.as_ref().is_some_and(|m| m.contains("cut")),
                    "zstd {zstd}: inside chunk {c}: {cut:?}"
                );
                let before = c * per_chunk;
                if zstd {
                    assert!(
                        (before..before + per_chunk).contains(&got),
                        "chunk {c}: {got}"
                    );
                } else {
                    let whole = messages[..]
                        .iter()
                        .filter(|(_, data)| {
                            let pos = bytes.windows(data.len()).position(|w| w == &data[..]);
                            pos.is_some_and(|p| p + data.len() <= at as usize)
                        })
                        .count();
                    assert_eq!(got, whole, "uncompressed chunk {c} cut at {at}");
                }
            }
        }
        // Cut before the first message: no scans, said so.
        let err = error_of(
            std::fs::write(dir.join("head.mcap"), &bytes[..starts[0] as usize + 20])
                .map_err(anyhow::Error::new)
                .and_then(|_| open(&dir.join("head.mcap"), None)),
        );
        assert!(err.contains("cut"), "{err}");
    }
    // The command keeps the scans and says where the file is cut.
    let path = dir.join("whole.mcap");
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = run(&[
        "extract",
        cut.to_str().unwrap(),
        "-o",
        dir.join("c.jsonl").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("the file ends inside a record"),
        "{}",
        stderr(&out)
    );
}

/// A rosbag2 folder: `metadata.yaml` naming `names`, with the files of
/// `present` written (each 2 scans).
fn folder(dir: &Path, names: &[&str], present: &[&str]) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let list: String = names.iter().map(|n| format!("    - {n}\n")).collect();
    std::fs::write(
        dir.join("metadata.yaml"),
        format!(
            "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  \
             relative_file_paths:\n{list}  compression_format: \"\"\n  compression_mode: \"\"\n"
        ),
    )
    .unwrap();
    for (i, name) in present.iter().enumerate() {
        let messages: Vec<_> = (0..2)
            .map(|k| {
                (
                    0,
                    laser_scan::encode(&scan(Variant::Fov180Res50, 361, 2 * i + k)),
                )
            })
            .collect();
        write_mcap(&dir.join(name), &[SCAN], true, 4, &messages);
    }
    dir.to_path_buf()
}

#[test]
fn a_rosbag2_folder_is_read_in_order_and_missing_files_are_reported() {
    let dir = scratch("folder");
    let whole = folder(
        &dir.join("whole"),
        &["b_0.mcap", "b_1.mcap"],
        &["b_0.mcap", "b_1.mcap"],
    );
    let scans = read_all(&whole, None);
    assert_eq!(scans.len(), 4);
    let stamps: Vec<_> = scans.iter().map(|s| s.stamp_ns.unwrap()).collect();
    assert!(stamps.windows(2).all(|w| w[0] < w[1]), "{stamps:?}");
    // The metadata.yaml itself names the folder too.
    assert_eq!(read_all(&whole.join("metadata.yaml"), None).len(), 4);

    let part = folder(&dir.join("part"), &["b_0.mcap", "b_1.mcap"], &["b_0.mcap"]);
    let out = run(&[
        "extract",
        part.to_str().unwrap(),
        "-o",
        dir.join("p.jsonl").to_str().unwrap(),
    ]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("1 of the 2 files its metadata names are missing and skipped"),
        "{err}"
    );
    assert!(err.contains("b_1.mcap"), "{err}");
    assert!(err.contains("2 scans of /scan"), "{err}");

    let none = folder(&dir.join("none"), &["b_0.mcap"], &[]);
    let err = error_of(open(&none, None));
    assert!(
        err.contains("none of the 1 files it names is there"),
        "{err}"
    );

    let sqlite = dir.join("sqlite");
    std::fs::create_dir_all(&sqlite).unwrap();
    std::fs::write(
        sqlite.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n  relative_file_paths:\n    - b_0.db3\n",
    )
    .unwrap();
    let err = error_of(open(&sqlite, None));
    assert!(
        err.contains("storage \"sqlite3\" is not supported"),
        "{err}"
    );
}

#[test]
fn plot_verify_and_simulate_take_the_topic() {
    for sub in [&["plot"][..], &["verify"], &["simulate"]] {
        let mut args = sub.to_vec();
        args.push("--help");
        let out = run(&args);
        let help = common::stdout(&out);
        assert!(help.contains("--topic <NAME>"), "{sub:?}: {help}");
    }
    let dir = scratch("plot");
    let path = dir.join("p.mcap");
    scans_bag(&path, Variant::Fov180Res50, 361, 3);
    let out = run(&[
        "plot",
        path.to_str().unwrap(),
        "--topic",
        "/scan",
        "--frame",
        "2",
        "-o",
        dir.join("f.svg").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(dir.join("f.svg").is_file());
}

/// The records of a JSON Lines file without the log's `pose` (a bag has
/// none).
fn records(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("pose");
            v
        })
        .collect()
}

#[test]
fn the_features_of_extracts_own_mcap_output_read_back_are_the_logs() {
    let dir = scratch("round-trip");
    // csail: cm; orebro: mm ranges written under range_max 81.83 m.
    for log in ["csail-corrected.log.gz", "orebro-corrected.log.gz"] {
        let log = common::shared_log(log);
        let p = |name: &str| dir.join(name).to_str().unwrap().to_owned();
        let out = run(&["extract", log.to_str().unwrap(), "-o", &p("log.jsonl")]);
        assert!(out.status.success(), "{}", stderr(&out));
        let out = run(&["extract", log.to_str().unwrap(), "-o", &p("scans.mcap")]);
        assert!(out.status.success(), "{}", stderr(&out));
        let out = run(&["extract", &p("scans.mcap"), "-o", &p("bag.jsonl")]);
        assert!(out.status.success(), "{}", stderr(&out));
        let (a, b) = (
            records(&dir.join("log.jsonl")),
            records(&dir.join("bag.jsonl")),
        );
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x, y, "{}: frame {}", log.display(), x["frame"]);
        }
    }
}
