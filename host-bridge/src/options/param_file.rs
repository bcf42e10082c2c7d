//! `--params FILE`: parameters in a TOML file, a flat table of
//! `NAME = VALUE` (each NAME a parameter, as for `--set`) and an optional
//! `preset = "NAME"`:
//!
//! ```toml
//! preset = "v2"
//! sigma = 0.01
//! split_depth = 0
//! merge_anchor_gate = inf
//! turn_offsets = false
//! ```

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use lms_core::params::Preset;
use lms_core::Params;
use toml::de::{DeTable, DeValue};

/// One `NAME = VALUE` of the file.
#[derive(Clone, Debug, PartialEq)]
struct Entry {
    /// The parameter.
    name: &'static str,
    /// Its value as text for [`Params::set`].
    value: String,
    /// Its line in the file (1-based).
    line: usize,
}

/// A parameter file, read and checked: every name a parameter, every value
/// of its type (the values' ranges are for [`Params::validate`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamFile {
    /// Where it was read from (for messages).
    path: PathBuf,
    /// Its `preset = "NAME"`, if any.
    pub preset: Option<&'static Preset>,
    /// Its parameters.
    entries: Vec<Entry>,
}

impl ParamFile {
    /// Read and check the file at `path`; errors name the file and line.
    pub fn read(path: &Path) -> Result<ParamFile> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("--params {}: cannot read it", path.display()))?;
        let mut file =
            ParamFile::parse(&text).map_err(|e| anyhow!("--params {}: {e}", path.display()))?;
        file.path = path.to_path_buf();
        Ok(file)
    }

    /// Check the TOML `text` (no path).
    pub fn parse(text: &str) -> Result<ParamFile, String> {
        let table = DeTable::parse(text).map_err(|e| e.to_string().trim_end().to_string())?;
        let mut file = ParamFile::default();
        for (key, value) in table.get_ref() {
            let line = text[..key.span().start].matches('\n').count() + 1;
            let name: &str = key.get_ref();
            let at = |message: String| format!("line {line}: {name}: {message}");
            if name == "preset" {
                let DeValue::String(s) = value.get_ref() else {
                    return Err(at("give a preset's name in quotes, e.g. \"v2\"".into()));
                };
                file.preset = Some(super::preset(s).map_err(at)?);
                continue;
            }
            let name = super::parameter(name).map_err(at)?;
            let value =
                match value.get_ref() {
                    DeValue::Float(f) => f.as_str().to_string(),
                    DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                        .map_err(|e| at(e.to_string()))?
                        .to_string(),
                    DeValue::Boolean(b) => b.to_string(),
                    DeValue::String(s) => s.to_string(),
                    _ => return Err(at(
                        "give a number, a whole number or true/false (the file is one flat table)"
                            .into(),
                    )),
                };
            let mut check = Params::DEFAULT;
            check
                .set(name, &value)
                .map_err(|e| format!("line {line}: {e}"))?;
            file.entries.push(Entry { name, value, line });
        }
        Ok(file)
    }

    /// Set the file's parameters in `p`.
    pub fn apply(&self, p: &mut Params) -> Result<()> {
        for e in &self.entries {
            p.set(e.name, &e.value)
                .map_err(|err| anyhow!("--params {}:{}: {err}", self.path.display(), e.line))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_sets_its_parameters_and_preset() {
        let f = ParamFile::parse(
            "# comment\npreset = \"v2\"\nsplit_depth = 0\nmerge_anchor_gate = inf\n\
             turn_offsets = false\nsigma = 0.01\nmin_points = 0x7\n",
        )
        .unwrap();
        assert_eq!(f.preset.map(|p| p.name), Some("v2"));
        let mut p = Params::DEFAULT;
        f.apply(&mut p).unwrap();
        assert_eq!(
            (
                p.split_depth,
                p.merge_anchor_gate,
                p.turn_offsets,
                p.sigma,
                p.min_points
            ),
            (0, f32::INFINITY, false, 0.01, 7)
        );
    }

    #[test]
    fn errors_name_the_line_and_the_parameter() {
        for (text, says) in [
            (
                "sigma = 0.01\nsplit_dept = 3\n",
                "line 2: split_dept: no parameter",
            ),
            ("split-depth = 3\n", "did you mean split_depth?"),
            ("merge = 1\n", "line 1: merge must be true or false"),
            (
                "split_depth = 300\n",
                "split_depth must be a whole number 0..=255",
            ),
            ("preset = \"v1\"\n", "line 1: preset: no preset `v1`"),
            ("preset = 2\n", "give a preset's name in quotes"),
            ("[pipeline]\nsigma = 0.01\n", "pipeline:"),
            ("sigma = \n", "TOML parse error"),
        ] {
            let e = ParamFile::parse(text).unwrap_err();
            assert!(e.contains(says), "{text:?}: {e}");
        }
    }
}
