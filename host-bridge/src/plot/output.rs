//! Where the figures go ([`outputs`]).

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, ensure, Result};

use super::args::{Figure, Format};

/// Where each figure goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outputs {
    /// Format of all files.
    pub format: Format,
    /// The scan figure's file, if drawn.
    pub scan: Option<PathBuf>,
    /// The `D` figure's file, if drawn.
    pub mahalanobis: Option<PathBuf>,
}

/// Decide the files: `output` is a directory unless it ends in `.svg` or
/// `.png`; a file gets the first figure, a second goes beside it as
/// `STEM-mahalanobis.EXT`.
pub fn outputs(
    output: &Path,
    format: Option<Format>,
    figure: Figure,
    frame: usize,
) -> Result<Outputs> {
    let ext = output
        .extension()
        .and_then(OsStr::to_str)
        .map(str::to_ascii_lowercase);
    let file_format = match ext.as_deref() {
        Some("svg") => Some(Format::Svg),
        Some("png") => Some(Format::Png),
        _ => None,
    };
    let want_scan = figure != Figure::Mahalanobis;
    let want_d = figure != Figure::Scan;
    if let Some(ff) = file_format {
        if let Some(f) = format {
            ensure!(
                f == ff,
                "--output {} is a .{} file but --format is {}",
                output.display(),
                ff.extension(),
                f.extension()
            );
        }
        let stem = output
            .file_stem()
            .and_then(OsStr::to_str)
            .ok_or_else(|| anyhow!("bad output file name {}", output.display()))?;
        let beside = output.with_file_name(format!("{stem}-mahalanobis.{}", ff.extension()));
        let (scan, d) = match (want_scan, want_d) {
            (true, true) => (Some(output.to_path_buf()), Some(beside)),
            (true, false) => (Some(output.to_path_buf()), None),
            _ => (None, Some(output.to_path_buf())),
        };
        return Ok(Outputs {
            format: ff,
            scan,
            mahalanobis: d,
        });
    }
    let f = format.unwrap_or(Format::Svg);
    let name = |what: &str| output.join(format!("frame-{frame}-{what}.{}", f.extension()));
    Ok(Outputs {
        format: f,
        scan: want_scan.then(|| name("scan")),
        mahalanobis: want_d.then(|| name("mahalanobis")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn output_names() {
        let o = outputs(Path::new("plots"), None, Figure::All, 3).unwrap();
        assert_eq!(o.format, Format::Svg);
        assert_eq!(o.scan, Some(PathBuf::from("plots/frame-3-scan.svg")));
        assert_eq!(
            o.mahalanobis,
            Some(PathBuf::from("plots/frame-3-mahalanobis.svg"))
        );
        let o = outputs(Path::new("a/b.PNG"), None, Figure::All, 3).unwrap();
        assert_eq!(o.format, Format::Png);
        assert_eq!(o.scan, Some(PathBuf::from("a/b.PNG")));
        assert_eq!(o.mahalanobis, Some(PathBuf::from("a/b-mahalanobis.png")));
        let o = outputs(Path::new("d.svg"), None, Figure::Mahalanobis, 0).unwrap();
        assert_eq!(
            (o.scan, o.mahalanobis),
            (None, Some(PathBuf::from("d.svg")))
        );
        assert!(outputs(Path::new("d.svg"), Some(Format::Png), Figure::All, 0).is_err());
    }
}
