//! `host-bridge plot` end to end: the figures of a built-in scene frame and
//! of a real CARMEN frame hold exactly the features `extract` reports for
//! the same frame (counted in the SVG text), PNG output is a real PNG, and
//! bad arguments fail with a message.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use host_bridge::plot::{
    EDGE, ILL_CONDITIONED, LINE_COLOURS, MAHALANOBIS_SIZE, PASS_COLOURS, RAW, SCAN_SIZE, TAU,
    WELL_CONDITIONED,
};
use plotters::style::RGBColor;
use serde_json::Value;

mod common;
use common::{csail, run, stderr};

fn ok(args: &[&str]) -> Output {
    let o = run(args);
    assert!(o.status.success(), "{args:?} failed: {}", stderr(&o));
    o
}

/// A fresh scratch directory for this test process and `name`.
fn scratch(name: &str) -> PathBuf {
    common::scratch("plot", name)
}

/// The one JSON record `extract` writes for `args`.
fn extract(args: &[&str]) -> Value {
    let mut all = vec!["extract"];
    all.extend_from_slice(args);
    let o = ok(&all);
    let text = String::from_utf8(o.stdout).unwrap();
    let mut lines = text.lines();
    let rec: Value = serde_json::from_str(lines.next().expect("no record")).unwrap();
    assert!(lines.next().is_none(), "more than one record");
    rec
}

fn hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Every element of an SVG text: tag name and attributes.
fn elements(svg: &str) -> Vec<(String, HashMap<String, String>)> {
    let mut out = Vec::new();
    for piece in svg.split('<').skip(1) {
        let Some(end) = piece.find('>') else { continue };
        let body = piece[..end].trim_end_matches('/');
        let (name, mut rest) = body.split_once(' ').unwrap_or((body, ""));
        let mut attrs = HashMap::new();
        while let Some(eq) = rest.find("=\"") {
            let key = rest[..eq].trim().to_string();
            let after = &rest[eq + 2..];
            let close = after.find('"').expect("unclosed attribute");
            attrs.insert(key, after[..close].to_string());
            rest = &after[close + 1..];
        }
        out.push((name.to_string(), attrs));
    }
    out
}

fn attr<'a>(a: &'a HashMap<String, String>, k: &str) -> &'a str {
    a.get(k).map_or("", String::as_str)
}

fn point_count(a: &HashMap<String, String>) -> usize {
    attr(a, "points").split_whitespace().count()
}

fn non_null(v: &Value) -> usize {
    v.as_array()
        .unwrap()
        .iter()
        .filter(|x| !x.is_null())
        .count()
}

fn read_svg(path: &Path, size: (u32, u32)) -> String {
    let svg = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    assert!(svg.len() > 1000, "{} is nearly empty", path.display());
    assert!(svg.contains("<svg"), "{} is not an SVG", path.display());
    assert!(
        svg.contains(&format!("width=\"{}\" height=\"{}\"", size.0, size.1)),
        "{}: unexpected size",
        path.display()
    );
    svg
}

/// The scan figure shows exactly the record's lines, corners (by class),
/// edge points and valid raw points (legend samples: one of each marker).
fn check_scan_svg(svg: &str, rec: &Value) {
    let els = elements(svg);
    let line_colours: Vec<String> = LINE_COLOURS.iter().map(|&c| hex(c)).collect();
    let fitted = els
        .iter()
        .filter(|(n, a)| {
            n == "polyline"
                && point_count(a) == 2
                && attr(a, "stroke-width") == "4"
                && line_colours.iter().any(|c| c == attr(a, "stroke"))
        })
        .count();
    let lines = rec["lines"].as_array().unwrap().len();
    assert_eq!(fitted, lines, "fitted line polylines");

    let corners = rec["corners"].as_array().unwrap();
    let well = corners
        .iter()
        .filter(|c| c["well_conditioned"].as_bool().unwrap())
        .count();
    let diamonds = |c: RGBColor| {
        els.iter()
            .filter(|(n, a)| {
                n == "polygon"
                    && point_count(a) == 4
                    && attr(a, "opacity") == "1"
                    && attr(a, "fill") == hex(c)
            })
            .count()
    };
    assert_eq!(
        diamonds(WELL_CONDITIONED),
        well + 1,
        "well-conditioned corners"
    );
    assert_eq!(
        diamonds(ILL_CONDITIONED),
        corners.len() - well + 1,
        "ill-conditioned corners"
    );
    // One translucent ellipse per corner (none is out of view here).
    let ellipses = els
        .iter()
        .filter(|(n, a)| n == "polygon" && attr(a, "opacity") == "0.15")
        .count();
    assert_eq!(ellipses, corners.len(), "covariance ellipses");

    let star_lines = els
        .iter()
        .filter(|(n, a)| n == "line" && attr(a, "stroke") == hex(EDGE))
        .count();
    let edges = rec["edges"].as_array().unwrap().len();
    assert_eq!(star_lines, 3 * (edges + 1), "edge stars (3 lines each)");

    let raw = els
        .iter()
        .filter(|(n, a)| n == "circle" && attr(a, "fill") == hex(RAW))
        .count();
    assert_eq!(raw, non_null(&rec["ranges"]) + 1, "raw points");
    // The sensor: a black triangle.
    assert!(els
        .iter()
        .any(|(n, a)| n == "polygon" && point_count(a) == 3 && attr(a, "fill") == "#000000"));
}

/// Points of the `D` curves drawn in `colour` (polylines and lone dots).
fn curve_points(els: &[(String, HashMap<String, String>)], colour: RGBColor) -> usize {
    let c = hex(colour);
    els.iter()
        .map(|(n, a)| match n.as_str() {
            "polyline" if attr(a, "stroke") == c => point_count(a),
            "circle" if attr(a, "fill") == c => 1,
            _ => 0,
        })
        .sum()
}

/// The `D` figure has one point per valid window for each pass and the τ line.
fn check_mahalanobis_svg(svg: &str, valid_pass1: usize, valid_last: usize) {
    let els = elements(svg);
    assert_eq!(curve_points(&els, PASS_COLOURS[0]), valid_pass1, "pass 1");
    assert_eq!(curve_points(&els, PASS_COLOURS[1]), valid_last, "last pass");
    assert!(
        els.iter()
            .filter(|(n, a)| n == "polyline" && attr(a, "stroke") == hex(TAU))
            .count()
            > 10,
        "no dashed tau line"
    );
    assert!(svg.contains("τ = 12"), "tau not named");
}

#[test]
fn builtin_scene_frame() {
    let dir = scratch("scene");
    let out = dir.join("plots"); // created by the tool
    let o = ok(&[
        "plot",
        "--frame",
        "2",
        "--count",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    let msg = stderr(&o);
    assert!(msg.contains("0 out of view"), "{msg}");

    let rec = extract(&["--count", "3", "--frames", "2"]);
    let pass1 = extract(&["--count", "3", "--frames", "2", "--iterations", "1"]);
    assert!(rec["lines"].as_array().unwrap().len() >= 4, "{rec}");
    assert!(!rec["corners"].as_array().unwrap().is_empty());

    let scan = read_svg(&out.join("frame-2-scan.svg"), SCAN_SIZE);
    check_scan_svg(&scan, &rec);
    assert!(scan.contains("Frame 2"), "title");
    let d = read_svg(&out.join("frame-2-mahalanobis.svg"), MAHALANOBIS_SIZE);
    check_mahalanobis_svg(
        &d,
        non_null(&pass1["mahalanobis"]),
        non_null(&rec["mahalanobis"]),
    );
    assert!(d.contains("after pass 1 and 5"), "title names the passes");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Frame 76: ≥ 8 lines and both well- and ill-conditioned corners with the
/// v2 defaults for the data (frame 269 was used before the collinear merge
/// removed its ill-conditioned corner).
#[test]
fn csail_frame_svg_and_png() {
    let log = csail();
    let log = log.to_str().unwrap();
    let dir = scratch("csail");
    let d = dir.to_str().unwrap();
    ok(&["plot", log, "--frame", "76", "-o", d]);
    let rec = extract(&[log, "--frames", "76"]);
    let pass1 = extract(&[log, "--frames", "76", "--iterations", "1"]);
    assert!(rec["lines"].as_array().unwrap().len() >= 8, "{rec}");
    let corners = rec["corners"].as_array().unwrap();
    assert!(corners.iter().any(|c| c["well_conditioned"] == true));
    assert!(corners.iter().any(|c| c["well_conditioned"] == false));
    let scan = read_svg(&dir.join("frame-76-scan.svg"), SCAN_SIZE);
    check_scan_svg(&scan, &rec);
    assert!(
        scan.contains("csail-corrected.log.gz"),
        "source in the title"
    );
    let dfig = read_svg(&dir.join("frame-76-mahalanobis.svg"), MAHALANOBIS_SIZE);
    check_mahalanobis_svg(
        &dfig,
        non_null(&pass1["mahalanobis"]),
        non_null(&rec["mahalanobis"]),
    );

    // Other passes, and PNG straight from the tool.
    let o = ok(&[
        "plot",
        log,
        "--frame",
        "76",
        "--passes",
        "5,2,40",
        "--iterations",
        "40",
        "--format",
        "png",
        "-o",
        d,
    ]);
    assert!(
        stderr(&o).contains("D after pass 2, 5, 40"),
        "{}",
        stderr(&o)
    );
    for (name, (w, h)) in [("scan", SCAN_SIZE), ("mahalanobis", MAHALANOBIS_SIZE)] {
        let png = std::fs::read(dir.join(format!("frame-76-{name}.png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{name}: not a PNG");
        let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
        assert_eq!((be(16), be(20)), (w, h), "{name}: size");
        assert!(png.len() > 20_000, "{name}: suspiciously small PNG");
    }

    // A file name picks the format; the second figure goes beside it.
    let file = dir.join("sub/fig.svg");
    ok(&["plot", log, "--frame", "3", "-o", file.to_str().unwrap()]);
    assert!(file.is_file());
    assert!(dir.join("sub/fig-mahalanobis.svg").is_file());
    let only = dir.join("only.png");
    ok(&[
        "plot",
        log,
        "--frame",
        "3",
        "--figure",
        "mahalanobis",
        "-o",
        only.to_str().unwrap(),
    ]);
    assert!(only.is_file());
    assert!(!dir.join("only-mahalanobis.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

fn fails(args: &[&str], expected: &[&str]) {
    let o = run(args);
    assert!(!o.status.success(), "{args:?} succeeded");
    let msg = stderr(&o);
    for e in expected {
        assert!(msg.contains(e), "{args:?}: message {msg:?} lacks {e:?}");
    }
}

#[test]
fn bad_arguments_fail_with_a_message() {
    let log = csail();
    let log = log.to_str().unwrap();
    let dir = scratch("bad");
    let d = dir.to_str().unwrap();
    fails(
        &["plot", log, "--frame", "100000", "-o", d],
        &["--frame 100000 is out of range", "406 FLASER frames"],
    );
    fails(
        &["plot", "--frame", "10", "-o", d],
        &["--frame 10 is out of range", "10 frames"],
    );
    fails(&["plot", "--passes", "1,x", "-o", d], &["bad passes list"]);
    fails(
        &["plot", "--passes", "0", "-o", d],
        &["passes count from 1"],
    );
    fails(
        &["plot", "--passes", "1,6", "-o", d],
        &["pass 6 is beyond the 5 passes"],
    );
    fails(
        &["plot", "-o", "x.svg", "--format", "png"],
        &["x.svg is a .svg file but --format is png"],
    );
    fails(
        &["plot", "--ellipse-scale", "0", "-o", d],
        &["--ellipse-scale"],
    );
    // An output directory below a regular file cannot be created.
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let below = file.join("plots");
    fails(
        &["plot", "-o", below.to_str().unwrap()],
        &["cannot create the output directory"],
    );
    // Nothing was written for the failures.
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1, "{left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
