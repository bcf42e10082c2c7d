//! Every input is read exactly once: pipes, FIFOs and standard input give
//! the frames of the file; `-o` refuses the input under any name; a damaged
//! gzip stream fails (or is kept with `--keep-damaged`) while a cut one
//! keeps its complete scans; damage that does not stop the reading (a
//! byte order mark, a keyword one edit from `FLASER`, a capture's time
//! running backwards, a duplicated record) is warned about with its line
//! or byte offset; a long bad token is quoted short.

use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use lms_core::telegram::MeasuredValues;
use lms_core::Unit;

mod common;
use common::{run, shared_log, stderr, stdout, BIN};

fn scratch(name: &str) -> PathBuf {
    common::scratch("input-once", name)
}

/// The Intel log (cm, 180 beams), or a failure naming it.
fn intel() -> PathBuf {
    let log = shared_log("intel-corrected.log.gz");
    assert!(log.is_file(), "no shared log at {}", log.display());
    log
}

/// The text of a gzip log.
fn gunzip(path: &Path) -> Vec<u8> {
    let mut text = Vec::new();
    flate2::read::MultiGzDecoder::new(File::open(path).unwrap())
        .read_to_end(&mut text)
        .unwrap();
    text
}

/// `sh -c SCRIPT` with `$BIN` and `$LOG` set.
fn sh(script: &str, log: &Path) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(script)
        .env("BIN", BIN)
        .env("LOG", log)
        .output()
        .expect("cannot start sh")
}

/// `host-bridge ARGS` with `input` on standard input.
fn with_stdin(args: &[&str], input: &Path) -> Output {
    Command::new(BIN)
        .args(args)
        .stdin(Stdio::from(File::open(input).unwrap()))
        .output()
        .unwrap()
}

/// `host-bridge ARGS` reading `input` through a FIFO at `fifo` (written
/// by a thread).
fn through_fifo(args: &[&str], fifo: &Path, input: &Path) -> Output {
    let made = Command::new("mkfifo").arg(fifo).status().unwrap();
    assert!(made.success(), "mkfifo {}", fifo.display());
    let (fifo_w, input) = (fifo.to_path_buf(), input.to_path_buf());
    let writer = std::thread::spawn(move || {
        let bytes = std::fs::read(input).unwrap();
        // A reader that fails early closes the FIFO: not this test's error.
        let _ = File::create(fifo_w).and_then(|mut f| f.write_all(&bytes));
    });
    let out = Command::new(BIN).args(args).output().unwrap();
    writer.join().unwrap();
    out
}

fn ok(out: &Output, what: &str) -> Vec<u8> {
    assert!(out.status.success(), "{what}: {}", stderr(out));
    out.stdout.clone()
}

/// `extract` through a pipe (`-`), standard input, a FIFO and `<(…)`
/// gives the file's frames byte for byte, gzip and plain, auto and forced
/// unit.
#[test]
fn pipes_fifos_and_standard_input_give_the_frames_of_the_file() {
    let dir = scratch("pipes");
    let gz = intel();
    let plain = dir.join("intel.log");
    std::fs::write(&plain, gunzip(&gz)).unwrap();
    for (log, tag) in [(&gz, "gz"), (&plain, "plain")] {
        let l = log.to_str().unwrap();
        let file = ok(&run(&["extract", l]), "file");
        assert_eq!(stdout(&run(&["extract", l])).lines().count(), 910);
        let piped = sh(r#"cat "$LOG" | "$BIN" extract -"#, log);
        assert_eq!(ok(&piped, "pipe"), file, "{tag}: pipe");
        assert!(
            stderr(&piped).contains("910 scans read"),
            "{}",
            stderr(&piped)
        );
        let stdin = with_stdin(&["extract", "/dev/stdin"], log);
        assert_eq!(ok(&stdin, "/dev/stdin"), file, "{tag}: /dev/stdin");
        let piped = sh(r#"cat "$LOG" | "$BIN" extract /dev/stdin"#, log);
        assert_eq!(
            ok(&piped, "pipe to /dev/stdin"),
            file,
            "{tag}: pipe, /dev/stdin"
        );
        let fifo = dir.join(format!("fifo-{tag}"));
        let f = fifo.to_str().unwrap();
        assert_eq!(
            ok(&through_fifo(&["extract", f], &fifo, log), "fifo"),
            file,
            "{tag}: FIFO"
        );
        // A forced unit through a pipe: the same frames as from the file.
        let cm_file = ok(&run(&["extract", l, "--unit", "cm"]), "file cm");
        let cm = sh(r#"cat "$LOG" | "$BIN" extract - --unit cm"#, log);
        assert_eq!(ok(&cm, "stdin cm"), cm_file, "{tag}: --unit cm");
    }
    if common::on_path("bash") {
        let out = Command::new("bash")
            .arg("-c")
            .arg(r#""$BIN" extract <(cat "$LOG") --frames 0..50"#)
            .env("BIN", BIN)
            .env("LOG", &gz)
            .output()
            .unwrap();
        let want = ok(
            &run(&["extract", gz.to_str().unwrap(), "--frames", "0..50"]),
            "file",
        );
        assert_eq!(ok(&out, "<(cat log)"), want);
    }
}

/// `plot` and `verify --replay` read standard input too.
#[test]
fn plot_and_verify_read_standard_input() {
    let dir = scratch("plot-verify");
    let log = intel();
    let svg = dir.join("scan.svg");
    let out = with_stdin(
        &[
            "plot",
            "-",
            "--frame",
            "3",
            "--figure",
            "scan",
            "-o",
            svg.to_str().unwrap(),
        ],
        &log,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let from_file = dir.join("file.svg");
    let l = log.to_str().unwrap();
    let out = run(&[
        "plot",
        l,
        "--frame",
        "3",
        "--figure",
        "scan",
        "-o",
        from_file.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The same figure, but for the input's name in its title.
    let piped = std::fs::read_to_string(&svg).unwrap();
    let file = std::fs::read_to_string(&from_file).unwrap();
    assert!(piped.len() > 1000);
    assert_eq!(
        piped.replace("- (cm", "LOG (cm"),
        file.replace("intel-corrected.log.gz (cm", "LOG (cm")
    );
    // verify plays the same frames from standard input as from the file
    // (whether the co-processor run then passes is verify's own tests').
    let plays = |o: &Output, name: &str| {
        let err = stderr(o);
        let about = err
            .lines()
            .find(|l| l.contains("sensor side plays"))
            .unwrap_or_else(|| panic!("no 'plays' line: {err}"))
            .replace(&format!("of {name} ("), "of INPUT (");
        assert!(
            about.contains("4 frames 0..4 of INPUT (181 beams, CARMEN log, cm"),
            "{about}"
        );
        about
    };
    let piped = with_stdin(
        &["verify", "--host", "--replay", "-", "--frames", "0..4"],
        &log,
    );
    let file = run(&["verify", "--host", "--replay", l, "--frames", "0..4"]);
    assert_eq!(plays(&piped, "-"), plays(&file, l));
}

/// `-o` naming the input through a hard link (or a symlink) is refused
/// before anything is written: the input stays as it was.
#[test]
fn a_hard_linked_output_is_refused_and_the_input_untouched() {
    let dir = scratch("hardlink");
    let input = dir.join("intel.log");
    let text = gunzip(&intel());
    std::fs::write(&input, &text).unwrap();
    let link = dir.join("link.jsonl");
    std::fs::hard_link(&input, &link).unwrap();
    let sym = dir.join("sym.jsonl");
    std::os::unix::fs::symlink(&input, &sym).unwrap();
    for out in [&link, &sym] {
        let o = run(&[
            "extract",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains("that is the input file"),
            "{}",
            stderr(&o)
        );
        assert_eq!(std::fs::read(&input).unwrap(), text, "the input changed");
    }
    // Standard input redirected from the file is the file as well.
    let o = with_stdin(&["extract", "-", "-o", link.to_str().unwrap()], &input);
    assert!(!o.status.success());
    assert_eq!(std::fs::read(&input).unwrap(), text, "the input changed");
    // Another file is written.
    let other = dir.join("other.jsonl");
    let o = run(&[
        "extract",
        input.to_str().unwrap(),
        "--frames",
        "0..2",
        "-o",
        other.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&other).unwrap().lines().count(), 2);
}

/// A gzip log whose checksum fails is an error (no frame written), or,
/// with `--keep-damaged`, kept with a warning; a flip inside the deflate
/// data fails too; a stream cut before its trailer keeps its complete
/// scans as a cut.
#[test]
fn a_damaged_gzip_fails_and_a_cut_one_keeps_its_scans() {
    let dir = scratch("gzip");
    let bytes = std::fs::read(intel()).unwrap();
    let crc = dir.join("crc.log.gz");
    let mut b = bytes.clone();
    let at = b.len() - 6; // inside the CRC-32 of the trailer
    b[at] ^= 0x01;
    std::fs::write(&crc, &b).unwrap();
    let mid = dir.join("mid.log.gz");
    let mut b = bytes.clone();
    b[bytes.len() / 2] ^= 0x01;
    std::fs::write(&mid, &b).unwrap();
    for damaged in [&crc, &mid] {
        let o = run(&["extract", damaged.to_str().unwrap()]);
        assert!(!o.status.success(), "{}", stderr(&o));
        assert_ne!(o.status.code(), Some(101));
        let err = stderr(&o);
        assert!(err.contains("gzip data are damaged"), "{err}");
        assert!(err.contains("--keep-damaged"), "{err}");
        assert!(o.stdout.is_empty(), "frames written before the failure");
    }
    let o = run(&["extract", crc.to_str().unwrap(), "--keep-damaged"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("may carry altered ranges"),
        "{}",
        stderr(&o)
    );
    assert_eq!(stdout(&o).lines().count(), 910);
    // Through a pipe as well.
    let o = sh(r#"cat "$LOG" | "$BIN" extract -"#, &crc);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("gzip data are damaged"),
        "{}",
        stderr(&o)
    );

    let cut = dir.join("cut.log.gz");
    std::fs::write(&cut, &bytes[..bytes.len() * 3 / 4]).unwrap();
    let o = run(&["extract", cut.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("the log is cut at line"), "{err}");
    assert!(!err.contains("damaged"), "{err}");
    let frames = stdout(&o).lines().count();
    assert!(frames > 500 && frames < 910, "{frames} frames");
}

/// A log line.
fn flaser(keyword: &str, ranges: &str) -> String {
    let n = ranges.split(' ').count();
    format!("{keyword} {n} {ranges} 0 0 0 0 0 0 1.5 host 1.5\n")
}

/// A first-line byte order mark is read through with a warning; a keyword
/// one edit from `FLASER` is warned about with its line (the rear laser's
/// `RLASER` is not); a flood of them is cut to a few lines and a count.
#[test]
fn a_byte_order_mark_and_damaged_keywords_are_warned_with_their_line() {
    let dir = scratch("keywords");
    let ranges = vec!["2.50"; 181].join(" ");
    let mut text = String::from("\u{feff}");
    text += &flaser("FLASER", &ranges); // line 1
    text += &flaser("FLASEQ", &ranges); // line 2
    text += "ODOM 0 0 0 0 0 0 1.5 host 1.5\n"; // line 3
    text += &flaser("FLASR", &ranges); // line 4
    text += &flaser("FFLASER", &ranges); // line 5
    text += &flaser("RLASER", &ranges); // line 6
    text += &flaser("FLASER", &ranges); // line 7
    let log = dir.join("bom.log");
    std::fs::write(&log, &text).unwrap();
    let o = run(&["extract", log.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).lines().count(), 2, "the BOM line is a scan");
    let err = stderr(&o);
    assert!(
        err.contains("line 1 starts with a UTF-8 byte order mark"),
        "{err}"
    );
    for (line, word) in [(2, "FLASEQ"), (4, "FLASR"), (5, "FFLASER")] {
        assert!(
            err.contains(&format!(
                "line {line}: the record keyword \"{word}\" is one edit from FLASER"
            )),
            "{err}"
        );
    }
    assert!(!err.contains("RLASER"), "{err}");

    let mut flood = flaser("FLASER", &ranges);
    for _ in 0..50 {
        flood += &flaser("FLASEQ", &ranges);
    }
    let log = dir.join("flood.log");
    std::fs::write(&log, flood).unwrap();
    let err = stderr(&run(&["extract", log.to_str().unwrap()]));
    assert_eq!(err.matches("one edit from FLASER").count(), 10, "{err}");
    assert!(
        err.contains("40 more warnings like these not shown"),
        "{err}"
    );
}

/// A 181-beam `B0` telegram.
fn b0(seed: u16) -> Vec<u8> {
    let words: Vec<u16> = (0..181).map(|j| (j * 7 + seed) % 8000 + 1).collect();
    let v = MeasuredValues::from_raw(&words, Unit::Millimetre, 0x10).unwrap();
    let mut buf = vec![0u8; v.buffer_len()];
    let n = v.emit(0, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// One capture record.
fn record(time_us: u64, telegram: &[u8]) -> Vec<u8> {
    let mut r = time_us.to_le_bytes().to_vec();
    r.extend_from_slice(&(telegram.len() as u16).to_le_bytes());
    r.extend_from_slice(telegram);
    r
}

/// A capture's time running backwards and a duplicated record are read,
/// and warned about with the record and its byte offset.
#[test]
fn a_capture_whose_time_runs_backwards_or_repeats_is_warned() {
    let dir = scratch("capture");
    let (a, b, c) = (b0(1), b0(2), b0(3));
    let mut bytes = b"LMSCAP01".to_vec();
    let second = bytes.len() + 10 + a.len();
    bytes.extend(record(1_000, &a));
    bytes.extend(record(2_000, &b));
    let third = bytes.len();
    bytes.extend(record(2_000, &b)); // a duplicate
    let fourth = bytes.len();
    bytes.extend(record(500, &c)); // earlier than its predecessor
    let cap = dir.join("odd.lmscap");
    std::fs::write(&cap, &bytes).unwrap();
    assert_eq!(second, 8 + 10 + a.len());
    let o = run(&["extract", cap.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).lines().count(), 4, "every record is read");
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "record 2 at byte {third} duplicates the previous record"
        )),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "record 3 at byte {fourth}: time_us 500 is earlier"
        )),
        "{err}"
    );
    // The same through standard input.
    let piped = with_stdin(&["extract", "-"], &cap);
    assert_eq!(ok(&piped, "capture on stdin"), o.stdout);
    assert!(
        stderr(&piped).contains("runs backwards"),
        "{}",
        stderr(&piped)
    );
}

/// A 5 000-digit token is quoted by its start and its length.
#[test]
fn a_long_bad_token_is_quoted_short() {
    let dir = scratch("token");
    let mut ranges = vec!["2.50".to_string(); 181];
    ranges[3] = format!("{}x", "7".repeat(4999));
    let log = dir.join("long.log");
    std::fs::write(&log, flaser("FLASER", &ranges.join(" "))).unwrap();
    let o = run(&["extract", log.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("\"7777777777777777…\" (5000 characters)"),
        "{err}"
    );
    assert!(err.len() < 400, "{} characters: {err}", err.len());
}

/// An empty standard input says so.
#[test]
fn an_empty_pipe_is_named() {
    let empty = scratch("empty").join("empty.log");
    std::fs::write(&empty, b"").unwrap();
    let o = with_stdin(&["extract", "-"], &empty);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("standard input is empty"),
        "{}",
        stderr(&o)
    );
}
