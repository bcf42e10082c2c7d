//! Facts declared once: the co-processor's counters are declared in one
//! table (`lms_core::telegram::features::Counters::NAMES`), and every
//! product source that reports them (the `D5` codec, the firmware's console,
//! the PC co-processor's status line, `verify`'s counters line) iterates it.
//! A source that names counters itself — a `"name"` literal, a `name={}`
//! format or `name=…` line, or a run of `c.name,` lines — fails this test.

use std::path::Path;

mod common;
use common::{files_under, workspace};

use lms_core::telegram::features::Counters;

/// The one declaration of the counters.
const DECLARATION: &str = "core/src/telegram/features.rs";

/// The product sources: the core, the host tool and the firmware.
const PRODUCT: [&str; 3] = ["core/src/", "host-bridge/src/", "firmware/src/"];

/// Where `text` names counters by hand, as messages; `text` is a source
/// file without its test module.
fn hand_listings(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for (name, _) in Counters::NAMES {
        if text.contains(&format!("\"{name}\"")) {
            found.push(format!("the literal \"{name}\""));
        }
        // A format (`name={}`) or a documented line (`name=…`); an
        // example value (`name=3`) is not a listing.
        for form in [format!("{name}={{"), format!("{name}=…")] {
            if text.contains(&form) {
                found.push(format!("`{form}`"));
            }
        }
    }
    // A run of three lines that are each one counter read, `x.name,`.
    let reads_a_counter = |line: &str| {
        let line = line.trim();
        let Some(expr) = line.strip_suffix(',') else {
            return false;
        };
        Counters::NAMES
            .iter()
            .any(|(name, _)| expr.ends_with(&format!(".{name}")))
    };
    let lines: Vec<&str> = text.lines().collect();
    for (i, run) in lines.windows(3).enumerate() {
        if run.iter().all(|l| reads_a_counter(l)) {
            found.push(format!("counters read one per line from line {}", i + 1));
        }
    }
    found
}

/// `text` up to its test module (`#[cfg(test)]` then `mod`).
fn without_tests(text: &str) -> &str {
    let mut at = 0;
    while let Some(i) = text[at..].find("#[cfg(test)]") {
        let i = at + i;
        let rest = text[i + "#[cfg(test)]".len()..].trim_start();
        if rest.starts_with("mod ") {
            return &text[..i];
        }
        at = i + 1;
    }
    text
}

#[test]
fn the_rule_finds_hand_listings() {
    let by_hand = "println!(\"scans_in={} scans_out={}\", c.scans_in,\n    c.scans_out,\n    \
                   c.scans_dropped,\n    c.relays_failed,\n);";
    let found = hand_listings(by_hand);
    assert!(
        found.iter().any(|f| f.contains("`scans_in={`")),
        "{found:?}"
    );
    assert!(!hand_listings("//! relays_failed=… scans_out=…").is_empty());
    assert!(hand_listings("/// (`host_scans_dropped=3`)").is_empty());
    assert!(
        found.iter().any(|f| f.contains("one per line")),
        "{found:?}"
    );
    assert!(!hand_listings("(\"relays_failed\", c.relays_failed),").is_empty());
    let iterated = "for (name, _, v) in counters.entries() {\n    w.field(name, v.into());\n}";
    assert!(hand_listings(iterated).is_empty());
}

#[test]
fn the_counters_are_declared_once_and_every_report_iterates_them() {
    let root = workspace();
    let mut problems = Vec::new();
    let mut sources = 0;
    for dir in PRODUCT {
        for path in files_under(&root.join(dir)) {
            let rel = path.strip_prefix(&root).unwrap_or(&path);
            let is_test = rel.file_name().is_some_and(|n| n == "tests.rs")
                || rel.components().any(|c| c.as_os_str() == "tests");
            if path.extension().is_none_or(|e| e != "rs") || is_test {
                continue;
            }
            if rel == Path::new(DECLARATION) {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            sources += 1;
            for f in hand_listings(without_tests(&text)) {
                problems.push(format!("{}: {f}", rel.display()));
            }
        }
    }
    assert!(sources > 50, "only {sources} product sources found");
    assert!(
        problems.is_empty(),
        "counters named by hand (iterate Counters::entries instead):\n{}",
        problems.join("\n")
    );
}
