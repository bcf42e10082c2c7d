//! Docs that cannot drift from the code: the parameter and stats references
//! in `docs/reference/` are what `host-bridge params` prints, and every
//! `--set NAME=VALUE` and `--preset NAME` that a markdown file of the
//! repository shows names a real parameter or preset, with a value that
//! reads as the parameter's type.

use std::path::PathBuf;

mod common;
use common::{files_under, workspace as root};

use host_bridge::reference::{self, COUNTERS_COMMAND, PARAMETERS_COMMAND, STATS_COMMAND};
use lms_core::params::{self, PRESETS};
use lms_core::Params;

/// `docs/reference/NAME` must be `expected`; the message gives the command
/// that writes it.
fn check_generated(name: &str, expected: &str, command: &str) {
    let path = root().join("docs/reference").join(name);
    let found = std::fs::read_to_string(&path).unwrap_or_default();
    if found != expected {
        let line = found
            .lines()
            .zip(expected.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| found.lines().count().min(expected.lines().count()));
        panic!(
            "{} differs from the code (first at line {}). Regenerate it from the \
             repository's root:\n    {command}",
            path.display(),
            line + 1
        );
    }
}

#[test]
fn the_parameter_reference_is_current() {
    check_generated(
        "parameters.md",
        &reference::parameters_markdown(&PRESETS[0]),
        PARAMETERS_COMMAND,
    );
}

#[test]
fn the_stats_reference_is_current() {
    check_generated("stats.md", &reference::stats_markdown(), STATS_COMMAND);
}

#[test]
fn the_counters_reference_is_current() {
    check_generated(
        "counters.md",
        &reference::counters_markdown(),
        COUNTERS_COMMAND,
    );
}

/// Every `*.md` of the repository's root, of `docs/` and of the packages'
/// folders (not hidden folders or build output).
fn markdown_files() -> Vec<PathBuf> {
    let root = root();
    let is_markdown = |p: &PathBuf| p.extension().is_some_and(|e| e == "md");
    let top = std::fs::read_dir(&root)
        .unwrap()
        .filter_map(|e| Some(e.ok()?.path()));
    let mut files: Vec<PathBuf> = top.filter(|p| p.is_file() && is_markdown(p)).collect();
    files.sort();
    for dir in [
        "docs",
        "core",
        "host-bridge",
        "firmware",
        "fuzz",
        "lab",
        "scene",
        "tests",
        "tools",
        "capi",
        "examples",
        "python",
    ] {
        files.extend(files_under(&root.join(dir)).into_iter().filter(is_markdown));
    }
    files
}

/// A word of the docs that stands for a value (`NAME`, `VALUE`, `N`,
/// `<name>`): not checked.
fn placeholder(word: &str) -> bool {
    word.is_empty()
        || word.starts_with('<')
        || word.chars().all(|c| c.is_ascii_uppercase() || c == '_')
        || word == "name"
}

/// The word after `flag` at `at` in `line` (after one space or `=`), up to
/// the first character that cannot be part of a name or a value; `None`
/// if the flag is a longer one (`--settings`) or stands alone.
fn word_after<'a>(line: &'a str, at: usize, flag: &str) -> Option<&'a str> {
    let rest = &line[at + flag.len()..];
    let rest = rest.strip_prefix(' ').or_else(|| rest.strip_prefix('='))?;
    let end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || "_.+-=<>".contains(c)))
        .unwrap_or(rest.len());
    Some(rest[..end].trim_end_matches(['.', ',']))
}

/// What is wrong with a `--set` word (`NAME=VALUE`), if anything.
fn check_setting(word: &str) -> Option<String> {
    let Some((name, value)) = word.split_once('=') else {
        return (!placeholder(word)).then(|| format!("`--set {word}`: give NAME=VALUE"));
    };
    if placeholder(name) {
        return None;
    }
    let Some(field) = params::field(name) else {
        return Some(format!("`--set {word}`: no parameter `{name}`"));
    };
    if placeholder(value) {
        return None;
    }
    let mut p = Params::DEFAULT;
    p.set(field.name, value)
        .err()
        .map(|e| format!("`--set {word}`: {e}"))
}

/// What is wrong with a `--preset` word, if anything.
fn check_preset(word: &str) -> Option<String> {
    if placeholder(word) || params::preset(word).is_some() {
        return None;
    }
    let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
    Some(format!(
        "`--preset {word}`: no such preset (there are {})",
        names.join(", ")
    ))
}

/// Every `--set` and `--preset` of `text`: `line: message` for each wrong.
fn wrong_uses(text: &str) -> Vec<String> {
    let mut wrong = Vec::new();
    for (k, line) in text.lines().enumerate() {
        for (flag, check) in [
            ("--set", check_setting as fn(&str) -> Option<String>),
            ("--preset", check_preset),
        ] {
            for (at, _) in line.match_indices(flag) {
                if let Some(message) = word_after(line, at, flag).and_then(check) {
                    wrong.push(format!("{}: {message}", k + 1));
                }
            }
        }
    }
    wrong
}

#[test]
fn the_docs_set_only_real_parameters_and_presets() {
    let root = root();
    let files = markdown_files();
    assert!(files.iter().any(|f| f.ends_with("README.md")));
    let mut wrong = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap_or_default();
        let shown = file
            .strip_prefix(&root)
            .unwrap_or(file)
            .display()
            .to_string();
        wrong.extend(
            wrong_uses(&text)
                .into_iter()
                .map(|w| format!("{shown}:{w}")),
        );
    }
    assert!(
        wrong.is_empty(),
        "these docs use a parameter or preset the code does not have \
         (`host-bridge params` lists them):\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_docs_check_finds_what_is_wrong() {
    let text = "Run `extract LOG --set split_depth=0 --set merge_anchor_gate=inf`.\n\
                Then --set NAME=VALUE, --set footprint=RAD and --preset NAME;\n\
                --set split-depth=3 or --set merge=yes or --preset v1 or --set=arc_chain=2.\n\
                --settings and --presets are other words; --set sigma=0.01, fine.\n";
    assert_eq!(
        wrong_uses(text),
        [
            "3: `--set split-depth=3`: no parameter `split-depth`",
            "3: `--set merge=yes`: merge must be true or false",
            "3: `--preset v1`: no such preset (there are default, v3.2, v3.1, v3.0, v2, paper)",
        ]
    );
}
