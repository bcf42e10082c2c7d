//! The TrueType font the text is laid out with (`ab_glyph`, read at run
//! time; nothing linked against fontconfig or freetype).

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{anyhow, Result};
use plotters::style::FontStyle;

/// The family name the text is drawn in: the font [`ensure_font`] loads is
/// registered under it.
pub(super) const FONT: &str = "sans-serif";

/// Where a TTF font for text layout is looked for, after `$HOST_BRIDGE_FONT`.
pub const FONT_CANDIDATES: [&str; 8] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// The TTF font to lay out text with: `$HOST_BRIDGE_FONT`, else the first of
/// [`FONT_CANDIDATES`] that exists, else the first `*.ttf` under
/// `/usr/share/fonts`.
pub fn find_font() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("HOST_BRIDGE_FONT") {
        return Some(PathBuf::from(p));
    }
    if let Some(p) = FONT_CANDIDATES.iter().map(Path::new).find(|p| p.is_file()) {
        return Some(p.to_path_buf());
    }
    first_ttf(Path::new("/usr/share/fonts"), 4)
}

fn first_ttf(dir: &Path, depth: u32) -> Option<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in &entries {
        if p.is_file()
            && p.extension()
                .and_then(OsStr::to_str)
                .is_some_and(|e| e.eq_ignore_ascii_case("ttf"))
        {
            return Some(p.clone());
        }
    }
    if depth == 0 {
        return None;
    }
    entries
        .iter()
        .filter(|p| p.is_dir())
        .find_map(|p| first_ttf(p, depth - 1))
}

/// Register the font of [`find_font`] with plotters, once per process.
pub fn ensure_font() -> Result<()> {
    static FONT_STATE: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let state = FONT_STATE.get_or_init(|| {
        let path = find_font().ok_or_else(|| {
            format!(
                "no TrueType font found for the plot text (looked at $HOST_BRIDGE_FONT, {} and \
                 /usr/share/fonts); install one (Debian: fonts-dejavu-core) or set \
                 HOST_BRIDGE_FONT=/path/to/font.ttf",
                FONT_CANDIDATES[0]
            )
        })?;
        let bytes = std::fs::read(&path)
            .map_err(|e| format!("cannot read the font {}: {e}", path.display()))?;
        // plotters keeps the font for the whole process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font(FONT, FontStyle::Normal, bytes)
            .map_err(|_| format!("{} is not a usable TrueType font", path.display()))?;
        if let Some(bold) = bold_sibling(&path) {
            if let Ok(b) = std::fs::read(bold) {
                let b: &'static [u8] = Box::leak(b.into_boxed_slice());
                let _ = plotters::style::register_font(FONT, FontStyle::Bold, b);
            }
        }
        Ok(path)
    });
    state.as_ref().map(|_| ()).map_err(|e| anyhow!("{e}"))
}

fn bold_sibling(path: &Path) -> Option<PathBuf> {
    let stem = path.file_stem()?.to_str()?;
    let ext = path.extension()?.to_str()?;
    let bold = stem
        .strip_suffix("-Regular")
        .map_or_else(|| format!("{stem}-Bold"), |s| format!("{s}-Bold"));
    let p = path.with_file_name(format!("{bold}.{ext}"));
    p.is_file().then_some(p)
}
