//! The MCAP files of a bag: a `.mcap` file itself, or the files a
//! rosbag2 folder's `metadata.yaml` names (`relative_file_paths`, in
//! order). The few keys needed are read from the YAML text line by line.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// The file rosbag2 writes beside its storage files.
pub const METADATA: &str = "metadata.yaml";

/// Where a bag's scans are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BagFiles {
    /// The MCAP files present, in the order of the metadata.
    pub files: Vec<PathBuf>,
    /// Files the metadata names that are not there.
    pub missing: Vec<PathBuf>,
}

/// `true` if `path` is a rosbag2 folder (a directory with a
/// `metadata.yaml`) or that `metadata.yaml` itself.
pub fn is_folder(path: &Path) -> bool {
    (path.is_dir() && path.join(METADATA).is_file())
        || (path.file_name().is_some_and(|n| n == METADATA) && path.is_file())
}

/// The MCAP files of the bag at `path`: the file itself, or a rosbag2
/// folder's (given as the folder or its `metadata.yaml`). A folder whose
/// storage is not MCAP, or whose files are compressed one by one, is an
/// error; one without any of its files too.
pub fn locate(path: &Path) -> Result<BagFiles> {
    if !is_folder(path) {
        return Ok(BagFiles {
            files: vec![path.to_owned()],
            missing: Vec::new(),
        });
    }
    let (dir, meta) = if path.is_dir() {
        (path.to_owned(), path.join(METADATA))
    } else {
        (
            path.parent().unwrap_or(Path::new(".")).to_owned(),
            path.to_owned(),
        )
    };
    let text = std::fs::read_to_string(&meta)
        .with_context(|| format!("cannot read {}", meta.display()))?;
    check_storage(&meta, &text)?;
    let names = list(&text, "relative_file_paths");
    if names.is_empty() {
        bail!(
            "{}: no relative_file_paths: the bag names no files",
            meta.display()
        );
    }
    let mut found = BagFiles {
        files: Vec::new(),
        missing: Vec::new(),
    };
    for name in names {
        let direct = dir.join(&name);
        // Some rosbag2 versions write the paths with the folder's name first.
        let by_name = Path::new(&name).file_name().map(|n| dir.join(n));
        match by_name.filter(|_| !direct.is_file()) {
            Some(p) if p.is_file() => found.files.push(p),
            _ if direct.is_file() => found.files.push(direct),
            _ => found.missing.push(direct),
        }
    }
    if found.files.is_empty() {
        bail!(
            "{}: none of the {} files it names is there ({})",
            meta.display(),
            found.missing.len(),
            names_of(&found.missing)
        );
    }
    Ok(found)
}

/// The file names of `paths`, comma-separated.
pub fn names_of(paths: &[PathBuf]) -> String {
    paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Refuse a storage other than MCAP and per-file compression.
fn check_storage(meta: &Path, text: &str) -> Result<()> {
    if let Some(storage) = value(text, "storage_identifier") {
        if storage != "mcap" {
            bail!(
                "{}: storage {storage:?} is not supported (ROS 2 bags with MCAP storage only)",
                meta.display()
            );
        }
    }
    let mode = value(text, "compression_mode").unwrap_or_default();
    let format = value(text, "compression_format").unwrap_or_default();
    if mode.eq_ignore_ascii_case("file") && !format.is_empty() {
        bail!(
            "{}: files compressed one by one ({format}) are not supported \
             (decompress them, or record with MCAP's chunk compression)",
            meta.display()
        );
    }
    Ok(())
}

/// The scalar after `key:` on the first line that starts with it.
fn value(text: &str, key: &str) -> Option<String> {
    text.lines().find_map(|line| {
        let rest = line.trim_start().strip_prefix(key)?.strip_prefix(':')?;
        Some(unquote(rest.trim()))
    })
}

/// The items of the list under `key:`, block (`- item` lines) or flow
/// (`[a, b]`) style.
fn list(text: &str, key: &str) -> Vec<String> {
    let mut lines = text.lines();
    let Some(rest) = lines.by_ref().find_map(|line| {
        line.trim_start()
            .strip_prefix(key)?
            .strip_prefix(':')
            .map(str::trim)
    }) else {
        return Vec::new();
    };
    if let Some(flow) = rest.strip_prefix('[') {
        return flow
            .trim_end_matches(']')
            .split(',')
            .map(|s| unquote(s.trim()))
            .filter(|s| !s.is_empty())
            .collect();
    }
    lines
        .map(str::trim)
        .take_while(|l| l.starts_with("- ") || *l == "-")
        .map(|l| unquote(l[1..].trim()))
        .filter(|s| !s.is_empty())
        .collect()
}

/// A YAML scalar without its quotes.
fn unquote(s: &str) -> String {
    let s = s.split(" #").next().unwrap_or(s).trim();
    for q in ['"', '\''] {
        if let Some(inner) = s.strip_prefix(q).and_then(|t| t.strip_suffix(q)) {
            return inner.to_string();
        }
    }
    s.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    const META: &str = "rosbag2_bagfile_information:
  version: 5
  storage_identifier: mcap
  relative_file_paths:
    - bag_0.mcap
    - \"bag_1.mcap\"
  duration:
    nanoseconds: 10
  compression_format: \"\"
  compression_mode: \"\"
";

    #[test]
    fn the_keys_are_read() {
        assert_eq!(value(META, "storage_identifier").as_deref(), Some("mcap"));
        assert_eq!(
            list(META, "relative_file_paths"),
            ["bag_0.mcap", "bag_1.mcap"]
        );
        assert_eq!(
            list(
                "relative_file_paths: [a.mcap, 'b.mcap']",
                "relative_file_paths"
            ),
            ["a.mcap", "b.mcap"]
        );
        assert!(check_storage(Path::new("m"), META).is_ok());
        let sqlite = META.replace("storage_identifier: mcap", "storage_identifier: sqlite3");
        let err = check_storage(Path::new("m"), &sqlite)
            .unwrap_err()
            .to_string();
        assert!(err.contains("\"sqlite3\" is not supported"), "{err}");
        let zipped = META
            .replace("compression_format: \"\"", "compression_format: zstd")
            .replace("compression_mode: \"\"", "compression_mode: FILE");
        assert!(check_storage(Path::new("m"), &zipped).is_err());
    }
}
