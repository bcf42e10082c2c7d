//! Facts declared once: the co-processor's counters are declared in one
//! table (`lms_core::telegram::features::Counters::NAMES`), and every
//! product source that reports them (the `D5` codec, the firmware's console,
//! the PC co-processor's status line, `verify`'s counters line) iterates it.
//! A source that names counters itself — a `"name"` literal, a `name={}`
//! format or `name=…` line, or a run of `c.name,` lines — fails this test.

use std::path::Path;

mod common;
use common::{files_under, workspace};

use lms_core::params::FIELDS;
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

/// The one declaration of the parameters: `lms_core::params::FIELDS` and
/// the `Params` struct it covers (`core/src/params.rs`, `core/src/params/`).
const PARAMS_DECLARATION: [&str; 2] = ["core/src/params.rs", "core/src/params/"];

/// The C ABI's mirror of `Params`: a `#[repr(C)]` struct has to name
/// every field, and the ABI numbers its error codes by field. Its own tests
/// take every field through it and back (`every_field_is_mirrored`) and
/// check each code's message against the core's.
const C_ABI_MIRRORS: [&str; 2] = ["capi/src/params.rs", "capi/src/codes.rs"];

/// Protocol layouts: the `D0` summary echoes iterations, σ, q and τ in its
/// wire order (`EchoedParams`, whose `over` gives the parameters a scan ran
/// with, for `verify`'s comparison through `FIELDS`).
const PROTOCOL_LAYOUTS: [&str; 1] = ["core/src/telegram/features.rs"];

/// The product sources the parameter rule reads.
const PARAMS_PRODUCT: [&str; 5] = [
    "core/src/",
    "host-bridge/src/",
    "firmware/src/",
    "capi/src/",
    "python/src/",
];

/// Fewest parameter names in one place that make a listing.
const RUN: usize = 4;

/// The parameter names a line of source names in the ways a listing
/// does: a `"name"` literal, a struct literal's or declaration's `name:`,
/// a setter `.with_name(`, or a `name =` line (a file or a format).
fn names_on_line(line: &str) -> Vec<&'static str> {
    let t = line.trim_start();
    let code = t.split("//").next().unwrap_or("");
    FIELDS
        .iter()
        .map(|f| f.name)
        .filter(|name| {
            let word_at = |at: usize| {
                !code[..at]
                    .chars()
                    .next_back()
                    .is_some_and(|c| c.is_alphanumeric() || c == '_')
            };
            let as_field = [format!("{name}:"), format!("{name} =")]
                .iter()
                .any(|form| {
                    (code.starts_with(form.as_str()) || code.starts_with(&format!("pub {form}")))
                        && !code.starts_with(&format!("{name}::"))
                });
            let literal = code
                .match_indices(&format!("\"{name}\""))
                .any(|(at, _)| word_at(at));
            let setter = code.contains(&format!(".with_{name}("));
            as_field || literal || setter
        })
        .collect()
}

/// Where `text` lists parameter names by hand: [`RUN`] distinct names
/// within [`RUN`] consecutive lines (a `"name"` literal, `name:`,
/// `.with_name(`, `name =`). `text` is a source file without its tests.
fn param_listings(text: &str) -> Vec<String> {
    let lines: Vec<Vec<&str>> = text.lines().map(names_on_line).collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let mut names: Vec<&str> = lines[i..(i + RUN).min(lines.len())]
            .iter()
            .flatten()
            .copied()
            .collect();
        names.sort_unstable();
        names.dedup();
        if names.len() >= RUN {
            found.push(format!("line {}: {}", i + 1, names.join(", ")));
            i += RUN;
        } else {
            i += 1;
        }
    }
    found
}

#[test]
fn the_parameter_rule_finds_hand_listings() {
    let literal = "Params {\n    sigma: 0.01,\n    tau: 9.0,\n    q: 0.0,\n    iterations: 5,\n}";
    assert_eq!(param_listings(literal).len(), 1, "{literal}");
    let chain = "Params::DEFAULT.with_sigma(0.01).with_tau(9.0)\n.with_q(0.0).with_iterations(5)";
    assert_eq!(param_listings(chain).len(), 1);
    let names = "const ONES: [&str; 4] = [\"grazing_noise\", \"fit_sigma\",\n\"per_turn\", \"merge_f_test\"];";
    assert_eq!(param_listings(names).len(), 1);
    let file = "sigma = 0.01\ntau = 9\nq = 0\nsplit_depth = 0\n";
    assert_eq!(param_listings(file).len(), 1);
    // Three names, or names used where they are needed, are no listing.
    assert!(param_listings("Params::DEFAULT.with_sigma(s).with_tau(t).with_q(q)").is_empty());
    let reads = "let w = p.sigma * p.sigma + p.q;\nif d > p.tau {\n    split(p.split_depth, p.iterations);\n}";
    assert!(param_listings(reads).is_empty());
    let spread = "\"sigma\"\n\n\n\n\"tau\"\n\n\n\n\"q\"\n\n\n\n\"merge\"";
    assert!(param_listings(spread).is_empty());
    assert!(param_listings("for f in FIELDS {\n    p.set(f.name, v)?;\n}").is_empty());
    assert!(param_listings("\"sigmas\" \"taus\" \"x_q\" \"qq\"").is_empty());
}

#[test]
fn the_parameters_are_declared_once_and_every_consumer_iterates_them() {
    let root = workspace();
    let mut problems = Vec::new();
    let mut sources = 0;
    let skipped = |rel: &Path| {
        let s = rel.to_string_lossy().replace('\\', "/");
        let exempt = PARAMS_DECLARATION
            .iter()
            .chain(&C_ABI_MIRRORS)
            .chain(&PROTOCOL_LAYOUTS);
        exempt.into_iter().any(|d| {
            if d.ends_with('/') {
                s.starts_with(d)
            } else {
                s == *d
            }
        })
    };
    for dir in PARAMS_PRODUCT {
        for path in files_under(&root.join(dir)) {
            let rel = path.strip_prefix(&root).unwrap_or(&path);
            let is_test = rel
                .file_name()
                .is_some_and(|n| n == "tests.rs" || n == "test_support.rs")
                || rel.components().any(|c| c.as_os_str() == "tests");
            if path.extension().is_none_or(|e| e != "rs") || is_test || skipped(rel) {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            sources += 1;
            for f in param_listings(without_tests(&text)) {
                problems.push(format!("{}: {f}", rel.display()));
            }
        }
    }
    assert!(sources > 60, "only {sources} product sources found");
    for declared in PARAMS_DECLARATION
        .iter()
        .chain(&C_ABI_MIRRORS)
        .chain(&PROTOCOL_LAYOUTS)
    {
        assert!(root.join(declared).exists(), "{declared}");
    }
    assert!(
        problems.is_empty(),
        "parameters named by hand (iterate lms_core::params::FIELDS instead):\n{}",
        problems.join("\n")
    );
}
