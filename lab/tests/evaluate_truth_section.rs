//! Section 5 of the report (`realtruth::markdown`, written alike by
//! `lms-lab evaluate` into README.md and `lms-lab truth` into
//! real-truth.md): its text and columns follow the truth the logs were
//! scored against — the settled truth's rules and columns, or the legacy
//! truth's `verified` share and FalsePos over all lines.

use host_bridge::carmen::Unit;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realtruth::{markdown, methods, LogTruth, RealTally, NO_FLAGS, ORACLE};

fn one_log(truth: TruthConfig) -> LogTruth {
    let mut tallies = vec![RealTally::default(); methods().len()];
    // The no-flags method: 10 counted pieces (4 of ≥ 1 m), 8 found; 12 lines:
    // 8 true, 2 false, 1 unexplained, 1 neutral.
    tallies[0] = RealTally {
        frames: 2,
        pieces: 10,
        matched: 8,
        pieces_1m: 4,
        matched_1m: 4,
        lines: 12,
        lines_matched: 9,
        lines_true: 8,
        lines_false: 2,
        lines_unexplained: 1,
        lines_neutral: 1,
        ..RealTally::default()
    };
    LogTruth {
        name: "x.log.gz".into(),
        unit: Unit::Centimetre,
        frames: 2,
        beams: 361,
        walls: 7,
        lines: 6,
        pieces_per_frame: 5.0,
        verified_share: 0.9,
        tallies,
        figure: None,
        truth,
    }
}

#[test]
fn the_settled_section_states_its_rules_and_has_no_verified_column() {
    let md = markdown(&[one_log(TruthConfig::settled())], 1);
    for needle in [
        "## 5. Real scans against map-derived truth",
        "Every frame of each log, against the settled truth",
        "leave-one-wall-out",
        "FalsePos = false / (false + true) lines",
        "| log | frames | map walls | counted pieces / frame |\n",
        "| x.log.gz (cm) | 2 | 7 | 5.0 |\n",
        "| method | TruePos | ≥ 1 m | 0.5–1 m | < 0.5 m | FalsePos | unexplained | neutral | \
         coverage |",
        "### Per log: the defaults, split-and-merge and the oracle",
    ] {
        assert!(md.contains(needle), "lacks {needle:?}:\n{md}");
    }
    // TruePos 8/10, ≥ 1 m 4/4, no pieces of 0.5–1 m or < 0.5 m, FalsePos
    // 2/(2 + 8), unexplained and neutral 1/12 each.
    assert!(
        md.contains(&format!(
            "| {NO_FLAGS} | 0.800 | 1.000 | — | — | 0.200 | 0.083 | 0.083 |"
        )),
        "{md}"
    );
    assert!(md.contains(&format!("| {ORACLE} |")));
    for legacy in ["| verified |", "| on no wall |", "| FalsePos on walls |"] {
        assert!(!md.contains(legacy), "settled section has {legacy:?}");
    }
}

#[test]
fn the_legacy_section_keeps_its_verified_share_and_columns() {
    let md = markdown(&[one_log(TruthConfig::legacy())], 5);
    for needle in [
        "Every 5-th frame of each log; true lines from the log's SLAM map",
        "| log | frames | map walls | counted pieces / frame | verified |",
        "| x.log.gz (cm) | 2 | 7 | 5.0 | 0.900 |",
        "| method | TruePos | TruePos ≥ 1 m | FalsePos | on no wall | FalsePos on walls |",
    ] {
        assert!(md.contains(needle), "lacks {needle:?}:\n{md}");
    }
    assert!(!md.contains("settled truth"));
}
