//! `lms-lab evaluate --data`: a missing or mistyped folder,
//! or one without logs, fails instead of evaluating no real scans; one bad
//! log is left out and listed in the report, the others are evaluated, and
//! the run then fails saying so.

use std::path::PathBuf;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_lms-lab");

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("lms-lab-inputs-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn evaluate(data: &std::path::Path, out: &std::path::Path) -> Output {
    Command::new(BIN)
        .args([
            "evaluate",
            "--scans",
            "1",
            "--scale-scans",
            "1",
            "--sigmas",
            "0.01",
        ])
        .args(["--no-plots", "--data"])
        .arg(data)
        .arg("-o")
        .arg(out)
        .output()
        .expect("cannot start lms-lab")
}

/// A small cm log: a wall 2 m ahead.
fn wall_log() -> String {
    let ranges: Vec<String> = (0..181)
        .map(|j| {
            let c = ((j as f64) - 90.0).to_radians().cos();
            if c > 0.3 {
                format!("{:.2}", 2.0 / c)
            } else {
                "81.91".to_string()
            }
        })
        .collect();
    let line = format!("FLASER 181 {} 0 0 0 0 0 0 1.0 host 1.0\n", ranges.join(" "));
    line.repeat(3)
}

#[test]
fn missing_or_empty_data_fails() {
    let out = scratch("out-missing");
    let o = evaluate(&out.join("no-such-folder"), &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("--data") && err.contains("no-such-folder"),
        "{err}"
    );
    let empty = scratch("empty");
    let o = evaluate(&empty, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("no *.log or *.log.gz file"), "{err}");
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_dir_all(&empty).unwrap();
}

#[test]
fn one_bad_log_is_left_out_and_reported() {
    let data = scratch("data");
    let out = scratch("out");
    std::fs::write(data.join("a-good.log"), wall_log()).unwrap();
    std::fs::write(data.join("b-bad.log"), "FLASER 181 1 2 3\n").unwrap();
    let o = evaluate(&data, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("b-bad.log left out") && err.contains("line 1"),
        "{err}"
    );
    assert!(err.contains("1 of 2 logs could not be evaluated"), "{err}");
    let md = std::fs::read_to_string(out.join("README.md")).unwrap();
    assert!(
        md.contains("## Logs left out") && md.contains("b-bad.log"),
        "report"
    );
    assert!(md.contains("a-good.log"), "the good log is evaluated");
    std::fs::remove_dir_all(&data).unwrap();
    std::fs::remove_dir_all(&out).unwrap();
}
