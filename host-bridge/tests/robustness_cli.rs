//! Robustness from the user's side: every command reads logs and captures
//! alike, cut files keep their complete scans, no argument panics, and the
//! messages say what happened (`scan` and the sensor search are in
//! `scan_e2e.rs`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use host_bridge::capture::CaptureWriter;
use host_bridge::client::{Client, Timeouts};
use host_bridge::emulated_link::EmulatedLink;
use host_bridge::scan::{run_session, Plan};
use lms_core::telegram::Baud;

mod common;
use common::{csail, run, stderr, stdout, BIN};

fn scratch(name: &str) -> PathBuf {
    common::scratch("robustness", name)
}

/// A capture of `n` 180°/0.5° scans from the emulated sensor.
fn capture_of(path: &Path, n: usize) -> Vec<u8> {
    let mut client = Client::new(EmulatedLink::default(), Baud::B9600, Timeouts::default());
    let mut w = CaptureWriter::new(Vec::new()).unwrap();
    run_session(
        &mut client,
        &Plan {
            scans: n,
            ..Plan::default()
        },
        |_, t, scan| {
            w.write(t.as_micros() as u64, &scan.telegram)
                .map_err(anyhow::Error::new)
        },
    )
    .unwrap();
    let bytes = w.finish().unwrap();
    std::fs::write(path, &bytes).unwrap();
    bytes
}

/// A CARMEN line of `n` equal ranges.
fn flaser(n: usize, ranges: &[&str]) -> String {
    format!("FLASER {n} {} 0 0 0 0 0 0 1.5 host 1.5\n", ranges.join(" "))
}

fn fails(args: &[&str], needles: &[&str]) -> String {
    let out = run(args);
    let err = stderr(&out);
    assert!(!out.status.success(), "{args:?} succeeded: {err}");
    assert_ne!(out.status.code(), Some(101), "{args:?} panicked: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err:?} lacks {n:?}");
    }
    err
}

/// `plot` and `verify --replay` read captures (and `extract`
/// does): the same frame gives the same record.
#[test]
fn plot_and_verify_read_captures() {
    let dir = scratch("captures");
    let cap = dir.join("room.lmscap");
    capture_of(&cap, 3);
    let cap_s = cap.to_str().unwrap();
    let out = run(&[
        "plot",
        cap_s,
        "--frame",
        "2",
        "--figure",
        "scan",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let svg = std::fs::read_to_string(dir.join("frame-2-scan.svg")).unwrap();
    assert!(
        svg.contains("room.lmscap (capture)"),
        "the title names the capture"
    );
    let err = fails(
        &["plot", cap_s, "--frame", "3"],
        &["--frame 3 is out of range", "capture has 3 scans"],
    );
    assert!(!err.contains("FLASER"), "{err}");
    let out = run(&["verify", "--host", "--replay", cap_s, "--timeout", "60"]);
    assert!(out.status.success(), "{}{}", stdout(&out), stderr(&out));
    let text = format!("{}{}", stdout(&out), stderr(&out));
    assert!(
        text.contains("3 frames 0.. of") && text.contains("capture"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A cut log keeps its complete scans and says where; the
/// reading stops after the selected frames (a damaged line 3 is never read
/// with `--frames 0..2` and a forced unit).
#[test]
fn cut_logs_are_salvaged_and_reading_stops_after_the_selection() {
    let dir = scratch("cut-log");
    let good = flaser(181, &["1.50"; 181]);
    let text = format!("{good}{good}{good}");
    let log = dir.join("cut.log");
    std::fs::write(&log, &text[..text.len() - 300]).unwrap();
    let out = run(&["extract", log.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert_eq!(stdout(&out).lines().count(), 2);
    assert!(
        err.contains("cut at line 3") && err.contains("the 2 complete scans"),
        "{err}"
    );
    // A cut gzip stream: the lines before the cut are read.
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    for _ in 0..50 {
        gz.write_all(good.as_bytes()).unwrap();
    }
    let gz = gz.finish().unwrap();
    let gzlog = dir.join("cut.log.gz");
    std::fs::write(&gzlog, &gz[..gz.len() / 2]).unwrap();
    let out = run(&["extract", gzlog.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let n = stdout(&out).lines().count();
    assert!((1..50).contains(&n), "{n} frames");
    assert!(
        err.contains("the log is cut at line") && err.contains("data end early"),
        "{err}"
    );
    // Streaming: a bad line after the selection is never read.
    let bad = dir.join("bad-after.log");
    std::fs::write(&bad, format!("{good}{good}FLASER 181 x\n{good}")).unwrap();
    let out = run(&[
        "extract",
        bad.to_str().unwrap(),
        "--unit",
        "cm",
        "--frames",
        "0..2",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(stdout(&out).lines().count(), 2);
    fails(
        &["extract", bad.to_str().unwrap(), "--unit", "cm"],
        &["line 3"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Durations and counts are checked when the arguments are read;
/// nothing panics.
#[test]
fn no_argument_panics() {
    for (args, needle) in [
        (&["simulate", "--quit-after", "1e30"][..], "0..=1e9"),
        (&["simulate", "--restart-delay", "nan"][..], "0..=1e9"),
        (
            &["verify", "--count", "2", "--timeout", "1e30"][..],
            "0..=1e9",
        ),
        (&["verify", "--timeout", "1e19"][..], "0..=1e9"),
        (&["extract", "--count", "20000000"][..], "1..=100000"),
        (
            &["extract", "--frames", "18446744073709551615"][..],
            "too large",
        ),
        (&["extract", "--iterations", "1000000"][..], "1..=1000"),
        (
            &["extract", "--set", "min_points=2"][..],
            "min_points must be at least 3",
        ),
        (
            &["extract", "--set", "split_depth=17"][..],
            "split_depth must be at most 16",
        ),
        (
            &["extract", "--set", "split_depth=300"][..],
            "split_depth must be a whole number 0..=255",
        ),
        (
            &["verify", "--qemu", "/bin/sh"][..],
            "not a 32-bit little-endian ARM ELF",
        ),
        (
            &["verify", "--qemu", "/etc/hostname"][..],
            "not an ELF file",
        ),
        // The firmware runs the defaults: a parameter it does not echo is
        // refused by name, not reported as mismatches scan after scan.
        (
            &["verify", "--qemu", "--set", "merge_anchor_gate=inf"][..],
            "merge_anchor_gate=inf would be checked",
        ),
        (
            &[
                "verify",
                "--ports",
                "/dev/null",
                "/dev/null",
                "--set",
                "turn_offsets=false",
            ][..],
            "turn_offsets=false would be checked",
        ),
        // The merges' F test is a host-only option; its threshold is checked.
        (
            &[
                "verify",
                "--host",
                "--count",
                "1",
                "--set",
                "merge_f_test=20",
            ][..],
            "merge_f_test: the co-processor does not run it",
        ),
        (
            &["extract", "--set", "merge_f_test=-1"][..],
            "merge_f_test must be finite and >= 0",
        ),
    ] {
        let out = run(args);
        let err = stderr(&out);
        assert_ne!(out.status.code(), Some(101), "{args:?} panicked: {err}");
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// One 3-decimal value does not turn a cm log into mm; the
/// decision names the value and suggests --unit; a genuine 32.76 m stays
/// a distance.
#[test]
fn unit_detection_explains_itself() {
    let dir = scratch("unit");
    let mut odd = vec!["1.50"; 181];
    odd[5] = "2.125";
    odd[6] = "32.76";
    let log = dir.join("mixed.log");
    std::fs::write(
        &log,
        format!("{}{}", flaser(181, &["1.5"; 181]), flaser(181, &odd)),
    )
    .unwrap();
    let out = run(&["extract", log.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("ambiguous, read as cm"), "{err}");
    assert!(
        err.contains("\"2.125\", line 2, beam 5") && err.contains("--unit"),
        "{err}"
    );
    let second: serde_json::Value =
        serde_json::from_str(stdout(&out).lines().nth(1).unwrap()).unwrap();
    assert_eq!(
        second["ranges"][6].as_f64().map(|r| (r * 100.0).round()),
        Some(3276.0)
    );
    // A mm log with a value above 32.767 m: the error says how the unit was decided.
    let mut mm = vec!["1.505"; 181];
    mm[9] = "40.125";
    let log = dir.join("mm.log");
    std::fs::write(&log, flaser(181, &mm)).unwrap();
    fails(
        &["extract", log.to_str().unwrap()],
        &[
            "line 1",
            "above the largest LMS value",
            "read in mm",
            "\"1.505\", line 1, beam 0",
            "--unit cm",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Empty files, binary garbage and unsupported captures are
/// named for what they are, without a word about --frames.
#[test]
fn files_without_scans_are_explained() {
    let dir = scratch("no-scans");
    let cases: [(&str, &[u8], &str); 4] = [
        ("empty.log", b"", "is empty"),
        (
            "garbage.bin",
            &[0xde, 0xad, 0xbe, 0xef, 0, 1, 2, 3, 0xff, b'\n', 7],
            "holds no scans: none of its 2 lines is a FLASER line",
        ),
        (
            "v2.lmscap",
            b"LMSCAP02\x00\x00",
            "capture format \"LMSCAP02\" is not supported",
        ),
        (
            "params.log",
            b"PARAM a 1\nODOM 1 2 3\n",
            "none of its 2 lines is a FLASER line",
        ),
    ];
    for (name, bytes, needle) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        for cmd in ["extract", "plot"] {
            let err = fails(
                &[
                    cmd,
                    path.to_str().unwrap(),
                    "-o",
                    dir.join("out").to_str().unwrap(),
                ],
                &[needle],
            );
            assert!(!err.contains("--frames"), "{cmd} {name}: {err}");
        }
    }
    // An empty capture (magic only).
    let path = dir.join("magic.lmscap");
    std::fs::write(&path, b"LMSCAP01").unwrap();
    fails(
        &["extract", path.to_str().unwrap()],
        &["holds no scans: a capture with 0 records"],
    );
    fails(&["extract", dir.to_str().unwrap()], &["is a directory"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The smaller items.
#[test]
fn smaller_items() {
    let dir = scratch("smaller");
    // extract x.log -o x.log would destroy the input.
    let log = dir.join("x.log");
    let text = flaser(181, &["1.50"; 181]);
    std::fs::write(&log, &text).unwrap();
    fails(
        &[
            "extract",
            log.to_str().unwrap(),
            "-o",
            log.to_str().unwrap(),
        ],
        &["that is the input file"],
    );
    assert_eq!(std::fs::read_to_string(&log).unwrap(), text);
    // A write error names the output.
    if Path::new("/dev/full").exists() {
        fails(
            &["extract", "-o", "/dev/full", "--count", "50"],
            &["cannot write /dev/full", "No space left"],
        );
    }
    // A sigma no LMS has: a warning.
    let out = run(&["extract", "--sigma", "1e30"]);
    assert!(out.status.success());
    assert!(
        stderr(&out).contains("--sigma 1000000000000000000000000000000 m is far above"),
        "{}",
        stderr(&out)
    );
    // A reader that closes the pipe early: not an error, said once.
    let mut child = Command::new(BIN)
        .args(["extract", csail().to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 100];
    std::io::Read::read_exact(child.stdout.as_mut().unwrap(), &mut first).unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("(output closed early)"), "{err}");
    assert!(!err.contains("Broken pipe: Broken pipe"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
