//! `host-bridge extract` end to end: real CARMEN frames in, JSON Lines out,
//! every float bit-exact to what `lms_core` computes; bad input fails with a
//! message naming the file and line.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use lms_core::carmen;
use lms_core::{Extractor, Frame, Unit};
use serde_json::Value;

mod common;
use common::{run, shared_log as data};

/// A fresh scratch directory for this test process and `name`.
fn scratch(name: &str) -> PathBuf {
    common::scratch("extract", name)
}

/// The first `count` FLASER frames of a cm log through the core's CARMEN
/// reader directly (not the tool's file handling): 361 beams, codes
/// ≥ 81.83 m invalid.
fn first_frames(path: &Path, count: usize) -> Vec<Frame> {
    let text = || BufReader::new(flate2::read::MultiGzDecoder::new(File::open(path).unwrap()));
    let unit = carmen::decide_unit(text()).unwrap();
    assert_eq!(unit, Unit::Centimetre);
    let frames: Vec<Frame> = carmen::Reader::new(text(), unit)
        .take(count)
        .map(|scan| scan.unwrap().frame)
        .collect();
    assert!(frames.iter().all(|f| f.len() == 361));
    frames
}

/// Bits of a JSON number read back as f32 (`None` for `null`).
fn f32_of(v: &Value) -> Option<u32> {
    if v.is_null() {
        return None;
    }
    let x = v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"));
    Some((x as f32).to_bits())
}

fn assert_f32(v: &Value, expected: f32, what: &str) {
    assert_eq!(
        f32_of(v),
        Some(expected.to_bits()),
        "{what}: JSON {v} vs library {expected:?}"
    );
}

fn assert_mat(v: &Value, expected: [[f32; 2]; 2], what: &str) {
    for (i, row) in expected.iter().enumerate() {
        for (k, &e) in row.iter().enumerate() {
            assert_f32(&v[i][k], e, &format!("{what}[{i}][{k}]"));
        }
    }
}

/// Every number token of a JSON line (keys are strings, so they are skipped).
fn number_tokens(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| "[]{},:".contains(c) || c.is_whitespace())
        .filter(|t| t.starts_with(|c: char| c == '-' || c.is_ascii_digit()))
}

#[test]
fn real_log_round_trips_bit_exactly() {
    let log = data("csail-corrected.log.gz");
    let out = run(&["extract", log.to_str().unwrap(), "--frames", "0..4"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("4 frames"), "summary: {stderr}");
    let stdout = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 4);

    // Numbers are printed as the shortest f32 decimals, not widened to f64.
    for line in &lines {
        for t in number_tokens(line) {
            let x: f32 = t.parse().unwrap_or_else(|_| panic!("bad number {t}"));
            if t.contains(['.', 'e', 'E']) {
                assert_eq!(serde_json::to_string(&x).unwrap(), t, "not f32-shortest");
            }
        }
    }

    let frames = first_frames(&log, 4);
    // With no flags, the defaults for the data: a cm log in 1 cm steps
    // without fill values (σ = 0.01 m, max_range 81.83 m).
    let params = lms_core::DataProfile::of(Unit::Centimetre, lms_core::RangeMode::Bits13).params();
    assert_eq!((params.sigma, params.max_range), (0.01, 81.83));
    let mut ex = Extractor::new();
    let mut total_lines = 0;
    for (index, (line, frame)) in lines.iter().zip(&frames).enumerate() {
        let rec: Value = serde_json::from_str(line).expect("valid JSON");
        for key in [
            "frame",
            "n",
            "ranges",
            "smoothed",
            "mahalanobis",
            "edges",
            "segments",
            "lines",
            "corners",
            "stats",
        ] {
            assert!(rec.get(key).is_some(), "frame {index}: no {key:?}");
        }
        assert_eq!(rec["frame"], index);
        assert_eq!(rec["n"], 361);

        let mut trace = lms_core::Trace::new();
        ex.run_traced(frame, &params.validate().unwrap(), &mut trace);
        let beams = frame.beams();
        let ranges = rec["ranges"].as_array().unwrap();
        let smoothed = rec["smoothed"].as_array().unwrap();
        assert_eq!((ranges.len(), smoothed.len()), (361, 361));
        for j in 0..361 {
            if beams[j].is_valid() {
                assert_f32(&ranges[j], frame.ranges()[j], &format!("ranges[{j}]"));
                assert_f32(&smoothed[j], ex.smoothed()[j], &format!("smoothed[{j}]"));
            } else {
                assert!(ranges[j].is_null() && smoothed[j].is_null(), "beam {j}");
            }
        }
        let d = rec["mahalanobis"].as_array().unwrap();
        assert_eq!(d.len(), 359);
        let mut nulls = 0;
        for (i, &expected) in trace.mahalanobis().iter().enumerate() {
            if expected.is_finite() {
                assert_f32(&d[i], expected, &format!("mahalanobis[{i}]"));
            } else {
                assert!(d[i].is_null(), "mahalanobis[{i}]");
                nulls += 1;
            }
        }
        assert!(nulls > 0, "frame {index} has invalid windows");

        let f = ex.features();
        let edges: Vec<u64> = f.edges().iter().map(|e| e as u64).collect();
        let got: Vec<u64> = rec["edges"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        assert_eq!(got, edges);
        let segs: Vec<Value> = f
            .segments()
            .iter()
            .map(|s| serde_json::json!([s.first, s.last]))
            .collect();
        assert_eq!(rec["segments"].as_array().unwrap(), &segs);

        let lines_json = rec["lines"].as_array().unwrap();
        assert_eq!(lines_json.len(), f.lines().len());
        for (k, (l, lj)) in f.lines().iter().zip(lines_json).enumerate() {
            let w = format!("frame {index} line {k}");
            assert_f32(&lj["alpha"], l.alpha, &w);
            assert_f32(&lj["r"], l.r, &w);
            assert_mat(&lj["cov"], l.cov.to_array(), &w);
            assert_f32(&lj["chi2"], l.chi2, &w);
            assert_mat(&lj["endpoints"], l.endpoints, &w);
            assert_eq!(lj["first"], l.first);
            assert_eq!(lj["last"], l.last);
            assert_eq!(lj["points"], l.points);
        }
        total_lines += f.lines().len();

        let corners_json = rec["corners"].as_array().unwrap();
        assert_eq!(corners_json.len(), f.corners().len());
        for (k, (c, cj)) in f.corners().iter().zip(corners_json).enumerate() {
            let w = format!("frame {index} corner {k}");
            assert_f32(&cj["x"], c.x, &w);
            assert_f32(&cj["y"], c.y, &w);
            assert_mat(&cj["cov"], c.cov.to_array(), &w);
            assert_f32(&cj["angle_deg"], c.angle_deg, &w);
            assert_eq!(cj["well_conditioned"], c.well_conditioned);
        }
        assert_eq!(rec["stats"]["valid_beams"], f.stats().valid_beams);
        assert_eq!(rec["stats"]["invalid_windows"], f.stats().invalid_windows);
        assert_eq!(rec["stats"]["merges"], f.stats().merges);
    }
    assert!(total_lines > 0);

    // The typed reader of the same records agrees.
    for line in &lines {
        let _: host_bridge::extract::FrameRecord = serde_json::from_str(line).unwrap();
    }
}

#[test]
fn output_file_matches_stdout_and_params_apply() {
    let log = data("csail-corrected.log.gz");
    let dir = scratch("output");
    let file = dir.join("out.jsonl");
    let args = ["extract", log.to_str().unwrap(), "--frames", "2..=3"];
    let a = run(&[
        &args[..],
        &["--iterations", "1", "-o", file.to_str().unwrap()],
    ]
    .concat());
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    assert!(a.stdout.is_empty());
    let b = run(&[&args[..], &["--iterations", "1"]].concat());
    assert_eq!(std::fs::read(&file).unwrap(), b.stdout);
    let first: Value =
        serde_json::from_slice(b.stdout.split(|&c| c == b'\n').next().unwrap()).unwrap();
    assert_eq!(first["frame"], 2);

    // One pass gives other D than the default 30.
    let c = run(&args);
    assert_ne!(b.stdout, c.stdout);

    // Per-turn extraction (0.5° log: two mirror turns) gives other lines;
    // the co-processor paths refuse it by name.
    let d = run(&[&args[..], &["--set", "per_turn=true"]].concat());
    assert!(d.status.success(), "{}", String::from_utf8_lossy(&d.stderr));
    let lines = |out: &[u8]| -> Vec<Value> {
        out.split(|&c| c == b'\n')
            .filter(|l| !l.is_empty())
            .map(|l| serde_json::from_slice::<Value>(l).unwrap()["lines"].clone())
            .collect()
    };
    assert_ne!(lines(&c.stdout), lines(&d.stdout));
    let e = run(&["verify", "--host", "--count", "1", "--set", "per_turn=true"]);
    assert!(!e.status.success());
    assert!(
        String::from_utf8_lossy(&e.stderr).contains("per_turn: the co-processor does not run it")
    );
    let _ = std::fs::remove_dir_all(dir);
}

fn flaser(n: usize, value: &str) -> String {
    let ranges = vec![value; n].join(" ");
    format!("FLASER {n} {ranges} 0 0 0 0 0 0 1.5 host 1.5\n")
}

/// Run extract on a log with the given text; return (success, stderr).
fn extract_text(name: &str, text: &str) -> (bool, String, PathBuf) {
    let dir = scratch(name);
    let path = dir.join(format!("{name}.log"));
    std::fs::write(&path, text).unwrap();
    let out = run(&["extract", path.to_str().unwrap(), "--iterations", "1"]);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        path,
    )
}

#[test]
fn plain_mm_log_is_read() {
    let mut text = String::from("# a comment\nODOM 0 0 0 0 0 0 1 host 1\n");
    text += &flaser(181, "2.125");
    text += &flaser(181, "32.767");
    let (ok, err, path) = extract_text("mm", &text);
    assert!(ok, "{err}");
    assert!(err.contains("2 frames") && err.contains("mm"), "{err}");
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn bad_logs_fail_naming_the_line() {
    let good = flaser(361, "2.00");
    let cases = [
        (
            "malformed",
            format!("PARAM a b\n{good}{}", flaser(361, "2.0x")),
            "line 3",
            "malformed number",
        ),
        (
            "count",
            flaser(361, "2.00").replacen("FLASER 361", "FLASER 360", 1),
            "line 1",
            "n = 360",
        ),
        (
            "unsupported",
            format!("{good}{good}\n{}", flaser(270, "2.00")),
            "line 4",
            "unsupported beam count n = 270",
        ),
        (
            "bad_n",
            "FLASER many 1 2 3\n".to_string(),
            "line 1",
            "malformed beam count",
        ),
    ];
    for (name, text, line, what) in cases {
        let (ok, err, path) = extract_text(name, &text);
        assert!(!ok, "{name}: accepted");
        assert!(err.contains(line), "{name}: {err}");
        assert!(err.contains(what), "{name}: {err}");
        assert!(err.contains(&*path.to_string_lossy()), "{name}: {err}");
        let _ = std::fs::remove_dir_all(path.parent().unwrap());
    }
}

#[test]
fn bad_arguments_fail() {
    let log = data("csail-corrected.log.gz");
    let log = log.to_str().unwrap();
    let missing = run(&["extract", "/nonexistent/dir/scan.log"]);
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/dir/scan.log"));

    for (args, what) in [
        (vec!["--frames", "5..2"], "frame range"),
        (vec!["--frames", "x"], "frame range"),
        (vec!["--frames", "1000.."], "selects no frame"),
        (vec!["--sigma", "-1"], "sigma"),
        (vec!["--iterations", "0"], "iterations"),
        (vec!["--tau", "0"], "tau"),
        (vec!["--q", "-0.5"], "q must be"),
        (
            vec!["--set", "arc_chain=1"],
            "arc_chain must be 0 (off) or at least 2",
        ),
        (
            vec![
                "--set",
                "arc_min_turn_deg=40",
                "--set",
                "arc_max_turn_deg=5",
            ],
            "arc_min_turn_deg <= arc_max_turn_deg",
        ),
        (
            vec!["--set", "arc_turn_deg=5"],
            "no parameter `arc_turn_deg`",
        ),
        (vec!["--set", "split-depth=3"], "did you mean split_depth?"),
        (vec!["--set", "split_depth"], "give NAME=VALUE"),
        (vec!["--set", "merge=yes"], "merge must be true or false"),
        (
            vec!["--preset", "v1"],
            "possible values: default, v3.2, v3.1, v3.0, v2, paper",
        ),
        (
            vec!["--params", "/nonexistent/p.toml"],
            "/nonexistent/p.toml: cannot read",
        ),
        (
            vec!["--min-points", "4"],
            "unexpected argument '--min-points'",
        ),
    ] {
        let out = run(&[&["extract", log][..], &args[..]].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} accepted");
        assert!(err.contains(what), "{args:?}: {err}");
    }
}

#[test]
fn synthetic_scene_is_the_default() {
    let out = run(&["extract", "--count", "3", "--seed", "5"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("scene room") && stderr.contains("3 frames"),
        "{stderr}"
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let records: Vec<host_bridge::extract::FrameRecord> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(records.len(), 3);
    for (k, r) in records.iter().enumerate() {
        assert_eq!((r.frame, r.n), (k, 361));
        // The room with a box: several walls and at least one corner.
        assert!(r.lines.len() >= 3, "frame {k}: {} lines", r.lines.len());
        assert!(!r.corners.is_empty(), "frame {k}: no corner");
    }
    // Same seed, same output; the scene and seed options conflict with a log.
    let again = run(&["extract", "--count", "3", "--seed", "5"]);
    assert_eq!(again.stdout, text.as_bytes());
    let log = data("csail-corrected.log.gz");
    let both = run(&["extract", log.to_str().unwrap(), "--seed", "5"]);
    assert!(!both.status.success());
}

/// `json` without the `"rejected_arc":0` of each record's `stats` (always 0
/// with arcs kept): the JSON as pinned without that counter.
fn without_arc_counter(json: &[u8]) -> Vec<u8> {
    const TEXT: &[u8] = b",\"rejected_arc\":0";
    let mut out = Vec::with_capacity(json.len());
    let mut rest = json;
    while let Some(at) = rest.windows(TEXT.len()).position(|w| w == TEXT) {
        out.extend_from_slice(&rest[..at]);
        rest = &rest[at + TEXT.len()..];
    }
    out.extend_from_slice(rest);
    out
}

/// `extract LOG` (defaults) on every shared log gives exactly the JSON it
/// gave when these digests were pinned (FNV-1a-64 of stdout): no field, no
/// bit of any float may change. Re-pin only for an intended change (see
/// tools/feature-bits/tests/digests.rs). Pinned too: the defaults less some
/// of their additions, set with `--set`, a parameter file and `--preset`,
/// as tools/feature-bits/tests/digests.rs pins them: `--preset v3.0`
/// (the merges refitting every beam between the lines), and pairs of lines kept,
/// and no anchor gate or turn offsets too, and consecutive windows with no
/// split budget too, and arcs kept too, and `--preset v2`; the last two
/// bit for bit with the counter `rejected_arc` (always 0 there) taken out
/// of the text.
#[test]
fn extract_json_of_every_shared_log_is_pinned() {
    // (log stem, defaults, v3.0, pairs kept, no anchor gate, consecutive
    // windows, arcs kept, v2)
    type Pin = (&'static str, u64, u64, u64, u64, u64, u64, u64);
    const PINNED: [Pin; 7] = [
        (
            "acapulco-corrected",
            0x42d71018507ca20e,
            0xa3f8776617088897,
            0x04250938a78912fa,
            0xc40701c7d173c357,
            0xc40701c7d173c357,
            0xc3929d878ccb4e2c,
            0x57c75f8ec1c303b5,
        ),
        (
            "belgioioso-corrected",
            0x2f0b292422c6bf20,
            0x0b4302b0290ca5d1,
            0x0b4302b0290ca5d1,
            0xe5cd3416cf912913,
            0xe6b583dc85e6a459,
            0xf040b3b3779f54d2,
            0x8278d002b8a1be54,
        ),
        (
            "csail-corrected",
            0x1334903b473a4a1a,
            0xd6ad46dc5e78fb06,
            0xd6ad46dc5e78fb06,
            0x83fc1a76c6ce7327,
            0xa727593897fecdd7,
            0x58b0bf50f0e89679,
            0xb7f8a060b9e10ff7,
        ),
        (
            "freiburg-101-corrected",
            0x9523471d051096cd,
            0xead9bdb3cf37d669,
            0xead9bdb3cf37d669,
            0x18db85e23d9855b4,
            0x86d65186b7903ee6,
            0x9e0878902dbd72e4,
            0x1320a15056d12c34,
        ),
        (
            "freiburg-campus-corrected",
            0x54b520eae02b1a23,
            0x3238531ce147315d,
            0x37ae5dcfab6bf12d,
            0x9e9f56de6baafb1e,
            0x91a67e96d6d10d7c,
            0xcecb39abe31b6188,
            0xe9180309d1d94bfd,
        ),
        (
            "intel-corrected",
            0x47658bc763f09b8b,
            0xbebe5ac352b47944,
            0x4abed1f79912e32e,
            0x739aa99c0dab50e2,
            0x739aa99c0dab50e2,
            0x3c92353e51c89fd0,
            0xb01af4ea833f3820,
        ),
        (
            "orebro-corrected",
            0x0b5c130c11f0bb7d,
            0x582be87adeaa59c8,
            0x582be87adeaa59c8,
            0x23de0131a1d3b95d,
            0x23de0131a1d3b95d,
            0xd80fb2ca8bb9f702,
            0x80d2cbbb04049e68,
        ),
    ];
    let mut wrong = Vec::new();
    // Each set: the one before, less one more addition of the defaults.
    let v3_0 = ["--preset", "v3.0"];
    let pairs = ["--preset", "v3.0", "--set", "arc_pairs=false"];
    let gate = [
        &pairs[..],
        &[
            "--set",
            "merge_anchor_gate=inf",
            "--set",
            "turn_offsets=false",
        ],
    ]
    .concat();
    let windows = [
        &gate[..],
        &[
            "--set",
            "same_turn_windows=false",
            "--set",
            "split_budget=0",
        ],
    ]
    .concat();
    // Arcs kept, written as v2 and back what v2 leaves out, in a file.
    let dir = scratch("pinned");
    let file = dir.join("arcs-kept.toml");
    std::fs::write(
        &file,
        "preset = \"v2\"\n# v2 and the footprint and bridge merge:\nfootprint = 0.003\n\
         bridge_merge = true\n",
    )
    .unwrap();
    let arcs = ["--params", file.to_str().unwrap()];
    let v2 = ["--preset", "v2"];
    for (
        stem,
        pinned,
        pinned_v3_0,
        pinned_pairs,
        pinned_gate,
        pinned_windows,
        pinned_arcs,
        pinned_v2,
    ) in PINNED
    {
        let path = data(&format!("{stem}.log.gz"));
        let path = path.to_str().unwrap();
        for (flags, pinned, counter) in [
            (&[][..], pinned, true),
            (&v3_0[..], pinned_v3_0, true),
            (&pairs[..], pinned_pairs, true),
            (&gate[..], pinned_gate, true),
            (&windows[..], pinned_windows, true),
            (&arcs[..], pinned_arcs, false),
            (&v2[..], pinned_v2, false),
        ] {
            let out = run(&[&["extract", path][..], flags].concat());
            assert!(out.status.success(), "{stem}: {}", common::stderr(&out));
            let text = if counter {
                std::borrow::Cow::Borrowed(&out.stdout[..])
            } else {
                std::borrow::Cow::Owned(without_arc_counter(&out.stdout))
            };
            let digest = feature_bits::digest_of(&text[..]).unwrap();
            println!(
                "{stem} {flags:?}: {} bytes, digest 0x{digest:016x}",
                text.len()
            );
            if digest != pinned {
                wrong.push(format!(
                    "{stem} {flags:?}: 0x{digest:016x}, pinned 0x{pinned:016x}"
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "extract output changed:\n{}",
        wrong.join("\n")
    );
}

/// `--set` reaches the core (CSAIL is a 0.5° log) for the footprint, the
/// bridge merge, same-turn windows, the anchor gate and the turn offsets;
/// the default values change nothing; a bad value is refused naming the
/// parameter.
#[test]
fn settings_reach_the_core() {
    let log = data("csail-corrected.log.gz");
    let args = ["extract", log.to_str().unwrap(), "--frames", "0..200"];
    let digest = |flags: &[&str]| {
        let out = run(&[&args[..], flags].concat());
        assert!(out.status.success(), "{}", common::stderr(&out));
        feature_bits::digest_of(&out.stdout[..]).unwrap()
    };
    let default = digest(&[]);
    for setting in [
        "footprint=0.005",
        "bridge_merge=false",
        "same_turn_windows=false",
        "merge_anchor_gate=inf",
        "turn_offsets=false",
    ] {
        assert_ne!(
            digest(&["--set", setting]),
            default,
            "{setting} changed nothing"
        );
    }
    assert_eq!(
        digest(&["--set", "footprint=0.003"]),
        default,
        "0.003 rad is the default"
    );
    assert_eq!(
        digest(&["--set", "merge_anchor_gate=13.81551", "--preset", "default"]),
        default,
        "chi2_2 at 99.9 % is the default"
    );
    // The everyday flag wins over --set.
    assert_eq!(
        digest(&["--sigma", "0.01", "--set", "sigma=0.02"]),
        digest(&["--sigma", "0.01"])
    );
    for (setting, says) in [
        ("footprint=-0.001", "footprint must be finite and >= 0"),
        ("merge_anchor_gate=0", "merge_anchor_gate must be > 0"),
        ("merge_anchor_gate=-1", "merge_anchor_gate must be > 0"),
        (
            "merge_anchor_gate=nan",
            "merge_anchor_gate must be a number",
        ),
        (
            "merge_anchor_gate=wide",
            "merge_anchor_gate must be a number",
        ),
    ] {
        let bad = run(&[&args[..], &["--set", setting]].concat());
        assert!(!bad.status.success(), "{setting} accepted");
        assert!(
            common::stderr(&bad).contains(says),
            "{setting}: {}",
            common::stderr(&bad)
        );
    }
}

/// `extract LOG`'s parameters without flags (`defaults::for_log`) are the
/// ones `feature-bits` derives from its own survey of the log
/// (`per_data_params`), whose no_std feature bits are pinned in
/// tools/feature-bits/tests/digests.rs: the pinned bits are what a user
/// gets with no flags.
#[test]
fn per_data_defaults_match_the_pinned_feature_bits() {
    for stem in [
        "acapulco-corrected",
        "belgioioso-corrected",
        "csail-corrected",
        "freiburg-101-corrected",
        "freiburg-campus-corrected",
        "intel-corrected",
        "orebro-corrected",
    ] {
        let path = data(&format!("{stem}.log.gz"));
        let args = host_bridge::options::ParamArgs::default();
        let (ours, _) =
            host_bridge::defaults::for_log(&path, host_bridge::options::UnitArg::Auto, &args)
                .unwrap()
                .unwrap();
        let theirs = feature_bits::per_data_params(&path).unwrap();
        assert_eq!(ours, theirs, "{stem}");
    }
}
