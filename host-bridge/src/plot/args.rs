//! The options of `host-bridge plot`.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use clap::{Args, ValueEnum};

use crate::options::{ParamArgs, UnitArg};
use crate::synthetic::SceneArgs;

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Scalable vector graphics (text drawn by the viewer).
    Svg,
    /// Bitmap (text rendered here with the TTF font).
    Png,
}

impl Format {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Svg => "svg",
            Format::Png => "png",
        }
    }
}

/// Which figures to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Figure {
    /// Both figures.
    All,
    /// The scan with its features.
    Scan,
    /// D per window after the selected passes.
    Mahalanobis,
}

/// A comma-separated list of passes, e.g. `1,30`: ascending, unique, ≥ 1.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassList(pub Vec<u16>);

impl FromStr for PassList {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut passes = Vec::new();
        for part in s.split(',') {
            let p: u16 = part.trim().parse().map_err(|_| {
                format!(
                    "bad passes list {s:?}: expected passes >= 1 separated by commas, e.g. 1,30"
                )
            })?;
            if p == 0 {
                return Err(format!("bad passes list {s:?}: passes count from 1"));
            }
            passes.push(p);
        }
        passes.sort_unstable();
        passes.dedup();
        Ok(PassList(passes))
    }
}

impl fmt::Display for PassList {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self.0.iter().map(u16::to_string).collect();
        f.write_str(&parts.join(","))
    }
}

/// Options of `host-bridge plot`.
#[derive(Args, Clone, Debug)]
pub struct PlotArgs {
    /// CARMEN log (gzip or plain) or capture file from `scan`; without it, a synthetic scene is used
    pub log: Option<PathBuf>,
    /// Synthetic scene options (used without LOG).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Range unit of the log's error codes: auto = mm if at least 1/4 of the values show 3 decimals, cm if none (warns when in between)
    #[arg(long, value_enum, default_value_t = UnitArg::Auto, requires = "log")]
    pub unit: UnitArg,
    /// The topic of a ROS 2 bag.
    #[command(flatten)]
    pub topic: crate::options::TopicArg,
    /// Pipeline parameters, as for `extract`.
    #[command(flatten)]
    pub params: ParamArgs,
    /// Frame to plot (index of the FLASER line or of the capture's scan, from 0; synthetic: 0..count)
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub frame: usize,
    /// Passes whose D is plotted, comma-separated [default: 1 and the last]
    #[arg(long, value_name = "P,P,..")]
    pub passes: Option<PassList>,
    /// Output directory (created if missing; files frame-K-scan.EXT and
    /// frame-K-mahalanobis.EXT), or a file name ending in .svg or .png
    #[arg(long, short, value_name = "DIR|FILE", default_value = ".")]
    pub output: PathBuf,
    /// Output format [default: svg, or the extension of a FILE output]
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Figures to draw
    #[arg(long, value_enum, default_value_t = Figure::All)]
    pub figure: Figure,
    /// Enlarge the corner ellipses by this factor [default: chosen so that
    /// they are visible; the factor is shown in the legend]
    #[arg(long, value_name = "F")]
    pub ellipse_scale: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_lists() {
        assert_eq!("1,30".parse(), Ok(PassList(vec![1, 30])));
        assert_eq!(" 30, 1 ,5".parse(), Ok(PassList(vec![1, 5, 30])));
        assert_eq!("7,7".parse(), Ok(PassList(vec![7])));
        for bad in ["", "0", "1,,2", "a", "1;30", "-1", "70000"] {
            assert!(bad.parse::<PassList>().is_err(), "{bad:?} accepted");
        }
    }
}
