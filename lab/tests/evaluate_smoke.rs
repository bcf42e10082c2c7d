//! `lms-lab evaluate` end to end with a tiny count: the report is
//! written with its sections and tables (and no findings prose: that is
//! the hand-written docs/evaluation/FINDINGS.md, which the committed report
//! links), the figures exist when a font is available, and bad options
//! fail with a message.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_lms-lab");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "lms-lab-evaluate-test-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn csail() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/carmen/csail-corrected.log.gz")
}

#[test]
fn evaluate_a_tiny_evaluation_writes_the_report() {
    let out = scratch("out");
    // One real log, if the data is there (linked into a folder of its own).
    let data = scratch("data");
    let have_log = csail().is_file();
    if have_log {
        std::fs::copy(csail(), data.join("csail-corrected.log.gz")).unwrap();
    }
    let o = Command::new(BIN)
        .args([
            "evaluate",
            "--scans",
            "2",
            "--scale-scans",
            "1",
            "--sigmas",
            "0.01,0.02",
        ])
        .args(["--real-every", "100", "--data"])
        .arg(&data)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("cannot start lms-lab");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "evaluate failed: {stderr}");
    assert!(stderr.contains("wrote"), "{stderr}");
    let md = std::fs::read_to_string(out.join("README.md")).unwrap();
    for needle in [
        "## Summary: the goals at σ = 10 mm and 20 mm",
        "### The defaults (`Params::DEFAULT`, no flags) against the goals",
        "| plain Gaussian (sections 1–2) | 10 mm |",
        "| plain Gaussian (sections 1–2) | 20 mm |",
        "| realistic sensor model (section 7) | 10 mm |",
        "| realistic sensor model (section 7) | 20 mm |",
        "### Every method at σ = 20 mm",
        "| TruePos (resolvable walls) | ≥ 0.95 |",
        "| FalsePos (neutral lines left out) | ≤ 0.05 |",
        "it is **neutral**, neither true nor false",
        "| σΔα / CRB | ≤ 1.2 |",
        "| mean corner NEES | 1.8 … 2.2 |",
        "### Against the baselines at σ ≥ 10 mm",
        "## 1. Accuracy against ground truth",
        "### Detection",
        "### Line accuracy",
        "### Corners",
        "## 2. Where the lines go",
        "### Corner evidence in one window",
        "### One change at a time",
        "## 3. Scale space: passes and q",
        "**Against passes (q = 0).**",
        "## 4. Real scans",
        "## 7. Synthetic scenes from the realistic sensor model",
        "[FINDINGS.md](FINDINGS.md)",
        "## Reproduce",
        "cargo run --release -p lms-lab -- evaluate -o docs/evaluation",
    ] {
        assert!(md.contains(needle), "report lacks {needle:?}");
    }
    // The findings are written by hand (docs/evaluation/FINDINGS.md), not
    // generated: the report holds tables, figures and captions only.
    for prose in ["## Findings", "### F1.", "### Proposed changes", "## Setup"] {
        assert!(!md.contains(prose), "report writes prose {prose:?}");
    }
    // Every main method has a row per σ in the detection table.
    for m in [
        lms_lab::SPEC,
        lms_lab::DEFAULTS,
        "fit_shared_points = false",
        "split-and-merge (4σ)",
        "Gaussian mask (s = 1.35)",
    ] {
        for s in ["10 mm", "20 mm"] {
            assert!(md.contains(&format!("| {s} | {m} |")), "no row {s} {m}");
        }
    }
    // 2 scans × 4 families × 2 noise levels.
    assert!(
        md.contains("(4 families × 2 noise levels = 16 scans"),
        "{}",
        &md[..600]
    );
    if have_log {
        assert!(md.contains("| csail-corrected.log.gz | 5 × 361 (cm) | spec (--preset paper) |"));
        // The map-derived truth: the map from all 406 frames, 5 scored,
        // against the settled truth by default (no `verified` column, the
        // settled columns in the method tables).
        assert!(md.contains("## 5. Real scans against map-derived truth"));
        assert!(md.contains("against the settled truth (`TruthConfig::settled`"));
        assert!(
            md.contains("| log | frames | map walls | counted pieces / frame |\n"),
            "truth table"
        );
        assert!(
            md.contains("| csail-corrected.log.gz (cm) | 5 |"),
            "truth table"
        );
        assert!(md.contains(
            "| method | TruePos | ≥ 1 m | 0.5–1 m | < 0.5 m | FalsePos | unexplained | neutral |"
        ));
        assert!(
            !md.contains("| verified |"),
            "a legacy column under the settled truth"
        );
        assert!(!md.contains("| FalsePos on walls |"), "a legacy column");
        assert!(md.contains(&format!(
            "| csail-corrected.log.gz · {} |",
            lms_lab::realtruth::NO_FLAGS
        )));
        assert!(md.contains(&format!(
            "| csail-corrected.log.gz · {} |",
            lms_lab::realtruth::V2_NO_FLAGS
        )));
        assert!(md.contains("## 6. Sensor model fitted to the real logs"));
        assert!(
            md.contains("| csail-corrected.log.gz | 361 | 10 |"),
            "fit table"
        );
    }
    if host_bridge::plot::find_font().is_some() {
        for f in [
            "accuracy-vs-sigma.svg",
            "corner-evidence.svg",
            "scale-passes.svg",
            "scale-q.svg",
        ] {
            let svg = std::fs::read_to_string(out.join(f)).unwrap();
            assert!(svg.starts_with("<svg") && svg.contains("<polyline"), "{f}");
            assert!(md.contains(&format!("]({f})")), "{f} not linked");
        }
        if have_log {
            let real: Vec<_> = std::fs::read_dir(&out)
                .unwrap()
                .filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with("real-csail"))
                .collect();
            assert_eq!(real.len(), 1);
            let truth = std::fs::read_dir(&out)
                .unwrap()
                .filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with("truth-csail"))
                .count();
            assert_eq!(truth, 1);
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn the_committed_report_links_the_hand_written_findings() {
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/evaluation");
    let report = std::fs::read_to_string(docs.join("README.md")).unwrap();
    let findings = std::fs::read_to_string(docs.join("FINDINGS.md")).unwrap();
    assert!(report.contains("[FINDINGS.md](FINDINGS.md)"));
    for anchor in ["## Reading the tables", "## Findings and proposals"] {
        assert!(findings.contains(anchor), "FINDINGS.md lacks {anchor:?}");
    }
}

#[test]
fn evaluate_with_the_legacy_truth_says_so_in_reproduce() {
    let out = scratch("legacy");
    let o = Command::new(BIN)
        .args(["evaluate", "--scans", "1", "--scale-scans", "1"])
        .args(["--sigmas", "0.02", "--no-real", "--no-plots"])
        .args(["--truth", "legacy", "-o"])
        .arg(&out)
        .output()
        .expect("cannot start lms-lab");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("README.md")).unwrap();
    assert!(
        md.contains("evaluate -o docs/evaluation --scans 1 --scale-scans 1 --truth legacy\n"),
        "{}",
        &md[md.find("## Reproduce").unwrap_or(0)..]
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn evaluate_bad_options_fail_with_a_message() {
    let out = scratch("bad");
    for (args, want) in [
        (vec!["--scans", "0"], "--scans"),
        (vec!["--sigmas", "-0.01"], "--sigmas"),
        (vec!["--dropout", "2"], "--dropout"),
        (vec!["--truth", "slam"], "--truth"),
    ] {
        let o = Command::new(BIN)
            .arg("evaluate")
            .args(&args)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{args:?} accepted");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains(want), "{args:?}: {e}");
    }
    let _ = std::fs::remove_dir_all(&out);
}
