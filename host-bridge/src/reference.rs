//! `host-bridge params`: every parameter with its value, unit and meaning
//! ([`lms_core::params::FIELDS`]), the presets ([`lms_core::params::PRESETS`])
//! the counters of a frame's `stats` ([`lms_core::Stats::MEANINGS`]) and the
//! co-processor's counters (`D5`, [`Counters::MEANINGS`]), as aligned text or
//! as markdown. `docs/reference/parameters.md`, `docs/reference/stats.md`
//! and `docs/reference/counters.md` are its markdown output, and a test
//! (`tests/docs_current.rs`) fails when they differ from it.

use std::fmt::Write as _;
use std::io::{self, Write};

use anyhow::{anyhow, Result};
use clap::Args;
use lms_core::params::{Preset, FIELDS, PRESETS};
use lms_core::telegram::features::{CounterKind, Counters};
use lms_core::{Params, Stats};

use crate::options::flagged_parameters;

/// The command that writes `docs/reference/parameters.md`.
pub const PARAMETERS_COMMAND: &str =
    "cargo run -p host-bridge -- params --markdown > docs/reference/parameters.md";

/// The command that writes `docs/reference/stats.md`.
pub const STATS_COMMAND: &str =
    "cargo run -p host-bridge -- params --stats --markdown > docs/reference/stats.md";

/// The command that writes `docs/reference/counters.md`.
pub const COUNTERS_COMMAND: &str =
    "cargo run -p host-bridge -- params --counters --markdown > docs/reference/counters.md";

/// Options of `host-bridge params`.
#[derive(Args, Clone, Debug)]
pub struct ParamsArgs {
    /// Show this preset's values
    #[arg(long, value_name = "NAME", default_value = "default",
          value_parser = crate::options::preset_parser())]
    pub preset: String,
    /// Markdown tables (the parameters and the presets) instead of aligned text
    #[arg(long)]
    pub markdown: bool,
    /// The counters of a frame's `stats` record instead of the parameters
    #[arg(long, conflicts_with = "counters")]
    pub stats: bool,
    /// The co-processor's counters (its `D5` telegram, the status lines)
    /// instead of the parameters
    #[arg(long)]
    pub counters: bool,
}

/// Run `host-bridge params`.
pub fn run(args: &ParamsArgs) -> Result<()> {
    let preset = crate::options::preset(&args.preset).map_err(|e| anyhow!("--preset: {e}"))?;
    let text = match (args.stats, args.counters, args.markdown) {
        (true, _, true) => stats_markdown(),
        (true, _, false) => stats_text(),
        (false, true, true) => counters_markdown(),
        (false, true, false) => counters_text(),
        (false, false, true) => parameters_markdown(preset),
        (false, false, false) => parameters_text(preset),
    };
    // A closed standard output (`| head`) ends the listing, not an error.
    match io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// `[`x`]` rustdoc links as plain code, `crate::` as `lms_core::`.
fn plain(doc: &str) -> String {
    doc.replace("[`", "`")
        .replace("`]", "`")
        .replace("`crate::", "`lms_core::")
}

/// Rows of text in columns as wide as their widest cell, the last column
/// unpadded.
fn aligned(rows: &[Vec<String>]) -> String {
    let columns = rows.first().map_or(0, Vec::len);
    let widths: Vec<usize> = (0..columns)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for row in rows {
        let mut line = String::new();
        for (c, cell) in row.iter().enumerate() {
            if c + 1 == columns {
                line.push_str(cell);
            } else {
                let pad = widths[c] - cell.chars().count();
                let _ = write!(line, "{cell}{}  ", " ".repeat(pad));
            }
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// Every parameter of `preset` as aligned text: name, value, unit, meaning.
pub fn parameters_text(preset: &Preset) -> String {
    let mut rows = vec![vec![
        "NAME".to_string(),
        "VALUE".to_string(),
        "UNIT".to_string(),
        "RANGE".to_string(),
        "MEANING".to_string(),
    ]];
    rows.extend(FIELDS.iter().map(|f| {
        vec![
            f.name.to_string(),
            (f.get)(&preset.params).to_string(),
            f.unit.to_string(),
            f.range.to_string(),
            f.meaning.to_string(),
        ]
    }));
    let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
    let flagged: Vec<&str> = flagged_parameters().iter().map(|f| f.name).collect();
    format!(
        "Preset {}: {}.\n\n{}\n\
         Set one with --set NAME=VALUE or in a --params FILE; {} have flags of their own.\n\
         With a log, sigma and max_range come from its data unless set. Presets: {}\n\
         (--preset NAME). A firmware built with this preset reports params_fingerprint={}\n\
         on its console (with LMS_ITERATIONS another).\n",
        preset.name,
        preset.summary,
        aligned(&rows),
        and_list(&flagged),
        names.join(", "),
        preset.params.fingerprint()
    )
}

/// `items` as English: `a`, `a and b`, `a, b and c`.
fn and_list(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => (*one).to_string(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

/// The fields of `p` that differ from [`Params::DEFAULT`], as
/// `` `name = value` `` items.
fn changes(p: &Params) -> Vec<String> {
    FIELDS
        .iter()
        .filter(|f| (f.get)(p) != (f.get)(&Params::DEFAULT))
        .map(|f| format!("`{} = {}`", f.name, (f.get)(p)))
        .collect()
}

/// The parameter reference in markdown: every parameter with its value in
/// `preset`, unit and meaning, then the presets with what each changes.
pub fn parameters_markdown(preset: &Preset) -> String {
    let mut out = String::new();
    let flagged = flagged_parameters();
    let ticked: Vec<String> = flagged.iter().map(|f| format!("`{}`", f.name)).collect();
    let flags: Vec<String> = flagged
        .iter()
        .map(|f| format!("`--{}`", f.name.replace('_', "-")))
        .collect();
    let _ = write!(
        out,
        "# Parameters\n\n\
         <!-- Generated from the code: `{PARAMETERS_COMMAND}`. \
         host-bridge/tests/docs_current.rs fails when this file differs. -->\n\n\
         Every parameter of the pipeline is a field of `lms_core::Params`. On the command line\n\
         of `extract`, `plot`, `verify` and `coprocessor` one is set by its name with\n\
         `--set NAME=VALUE` (repeatable) or in a TOML file given to `--params FILE`\n\
         (`NAME = VALUE` lines, and an optional `preset = \"NAME\"`).\n\
         {} also have flags of their own\n\
         ({}).\n\
         Later wins: the preset (`--preset NAME`, else `default`), then\n\
         the file, then `--set`, then those flags. With a log, `sigma` and `max_range` come\n\
         from their data (quantisation step, range mode) unless set. `Params::validate`\n\
         checks the result and names a parameter out of its range (the column range).\n\
         Values are numbers (`inf` for infinity), whole numbers or `true`/`false`. E.g.\n\n\
         ```sh\n\
         host-bridge extract LOG --preset v2 --set split_depth=0 --set min_length=0.2\n\
         host-bridge extract LOG --params my-params.toml --sigma 0.01\n\
         ```\n\n\
         with `my-params.toml`:\n\n\
         ```toml\n\
         preset = \"v2\"\n\
         split_depth = 0\n\
         max_alpha_sd_deg = inf\n\
         ```\n\n\
         `host-bridge params` prints this table; `host-bridge params --preset NAME` with a\n\
         preset's values.\n\n\
         | name | {} | unit | range | meaning |\n| --- | --- | --- | --- | --- |\n",
        and_list(&ticked.iter().map(String::as_str).collect::<Vec<_>>()),
        flags.join(", "),
        preset.name
    );
    for f in FIELDS {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} | {} |",
            f.name,
            (f.get)(&preset.params),
            f.unit,
            f.range,
            f.meaning
        );
    }
    out.push_str(&presets_markdown());
    out
}

/// The presets in markdown: name, what it is, what it changes.
pub fn presets_markdown() -> String {
    let mut out = String::from(
        "\n## Presets\n\n\
         `--preset NAME` starts from one of these (`lms_core::params::PRESETS`).\n\n\
         | preset | what it is | differs from `default` in |\n| --- | --- | --- |\n",
    );
    for p in &PRESETS {
        let changed = changes(&p.params);
        let changed = if changed.is_empty() {
            "-".to_string()
        } else {
            changed.join(", ")
        };
        let _ = writeln!(out, "| `{}` | {} | {} |", p.name, p.summary, changed);
    }
    out
}

/// The counters of `stats` as aligned text: name, meaning.
pub fn stats_text() -> String {
    let mut rows = vec![vec!["COUNTER".to_string(), "MEANING".to_string()]];
    rows.extend(
        Stats::MEANINGS
            .iter()
            .map(|(name, meaning)| vec![name.to_string(), plain(meaning).replace('\n', " ")]),
    );
    aligned(&rows)
}

/// The counters of `stats` in markdown.
pub fn stats_markdown() -> String {
    let mut out = format!(
        "# Stats counters\n\n\
         <!-- Generated from the code: `{STATS_COMMAND}`. \
         host-bridge/tests/docs_current.rs fails when this file differs. -->\n\n\
         Each frame's record of `host-bridge extract` has a `stats` object with these {}\n\
         counters (`lms_core::Stats::FIELDS`, in this order): what the frame's run dropped,\n\
         rejected or could not store. The first {} are the words of the co-processor's `D0`\n\
         telegram.\n\n\
         | counter | meaning |\n| --- | --- |\n",
        Stats::FIELDS.len(),
        Stats::D0_FIELDS
    );
    for (name, meaning) in Stats::MEANINGS {
        let _ = writeln!(out, "| `{name}` | {} |", plain(meaning));
    }
    out
}

/// What a co-processor counter's kind says, for the tables.
fn kind_name(kind: CounterKind) -> &'static str {
    match kind {
        CounterKind::Count => "count",
        CounterKind::ScanLoss => "scan loss",
        CounterKind::Boot => "boot",
    }
}

/// The co-processor's counters as aligned text: name, kind, meaning.
pub fn counters_text() -> String {
    let mut rows = vec![vec!["COUNTER".into(), "KIND".into(), "MEANING".into()]];
    rows.extend(Counters::NAMES.iter().zip(Counters::MEANINGS).map(
        |(&(name, kind), (_, meaning))| {
            let meaning = plain(meaning).replace('\n', " ");
            vec![name.to_string(), kind_name(kind).to_string(), meaning]
        },
    ));
    aligned(&rows)
}

/// The co-processor's counters in markdown.
pub fn counters_markdown() -> String {
    let mut out = format!(
        "# Co-processor counters\n\n\
         <!-- Generated from the code: `{COUNTERS_COMMAND}`. \
         host-bridge/tests/docs_current.rs fails when this file differs. -->\n\n\
         The co-processor's {} counters (`lms_core::telegram::features::Counters::NAMES`, in\n\
         this order): the `u32` words of its `D5` telegram (docs/PROTOCOL.md), and, but the\n\
         boot's, the `name=value` pairs of the firmware's console, of `host-bridge coprocessor`'s\n\
         status line and of `host-bridge verify`'s counters line. The scan losses together\n\
         account for every scan of the sensor's stream the client did not get.\n\n\
         | counter | kind | meaning |\n| --- | --- | --- |\n",
        Counters::LEN
    );
    for (&(name, kind), (_, meaning)) in Counters::NAMES.iter().zip(Counters::MEANINGS) {
        let meaning = plain(meaning).replace('\n', " ");
        let _ = writeln!(out, "| `{name}` | {} | {meaning} |", kind_name(kind));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_and_counter_is_listed() {
        let text = parameters_text(&PRESETS[0]);
        let markdown = parameters_markdown(&PRESETS[0]);
        for f in FIELDS {
            assert!(text.contains(f.name) && markdown.contains(&format!("| `{}` |", f.name)));
        }
        for p in &PRESETS {
            assert!(markdown.contains(&format!("| `{}` |", p.name)));
        }
        assert!(markdown.contains("| `sigma` | 0.005 | m |"), "{markdown}");
        let stats = stats_markdown();
        for (name, _) in Stats::FIELDS {
            assert!(stats.contains(&format!("| `{name}` |")));
        }
        assert!(!stats.contains("[`"), "{stats}");
    }

    #[test]
    fn a_preset_lists_what_it_changes() {
        assert!(changes(&Params::DEFAULT).is_empty());
        let paper = changes(&Params::PAPER);
        assert!(
            paper.contains(&"`split_depth = 0`".to_string()),
            "{paper:?}"
        );
        assert!(
            paper.contains(&"`max_range = inf`".to_string()),
            "{paper:?}"
        );
    }
}
