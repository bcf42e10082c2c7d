//! `host-bridge extract`: the features of every selected frame of a CARMEN
//! log, a capture, a ROS 2 bag or the built-in synthetic scene, as JSON
//! Lines (one [`FrameRecord`] a frame), an MCAP file or a rosbag2 folder of
//! ROS 2 messages; `--realtime` plays them at their own times (and
//! `--foxglove` shows them live).
//!
//! [`record`] runs the extractor on frames and builds the records.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;

use crate::input::{self, InputFrame};
use crate::live_view::{self, FoxgloveArgs, Replay};
use crate::options::{FrameRange, ParamArgs, TopicArg, UnitArg};
use crate::ros2::messages::Stamp;
use crate::ros2::rosbag2_out::{stamp_for, Format, RosOut};
use crate::synthetic::{self, SceneArgs};

pub mod record;

pub use record::{
    extract_named, extract_observed, extract_to, extract_to_ros, CornerRecord, FrameRecord,
    LineRecord, StatsRecord, Summary,
};

/// Options of `host-bridge extract`.
#[derive(Args, Debug)]
pub struct ExtractArgs {
    /// CARMEN log (gzip or plain) or capture file from `scan`, a pipe or a FIFO; `-` reads standard input; without it, a synthetic scene is used
    log: Option<PathBuf>,
    #[command(flatten)]
    scene: SceneArgs,
    /// Range unit of the log's error codes: auto = mm if at least 1/4 of the values show 3 decimals, cm if none (warns when in between)
    #[arg(long, value_enum, default_value_t = UnitArg::Auto, requires = "log")]
    unit: UnitArg,
    #[command(flatten)]
    topic: TopicArg,
    #[command(flatten)]
    params: ParamArgs,
    /// Frames to process: A..B (B exclusive), A..=B, A.., ..B or A
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Write the output here instead of standard output: JSON Lines, an MCAP file (a name ending in .mcap) or a rosbag2 folder (--format rosbag2)
    #[arg(long, short, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Output format: jsonl (the default), mcap (ROS 2 messages on /scan, /features/markers and /features; chosen by -o NAME.mcap) or rosbag2 (-o names a new folder: metadata.yaml and an MCAP file, for `ros2 bag play`)
    #[arg(long, value_enum, value_name = "FORMAT", requires = "output")]
    format: Option<Format>,
    /// Keep the scans of a gzip log whose checksum fails (they may carry altered ranges) with a warning, instead of failing
    #[arg(long, requires = "log")]
    keep_damaged: bool,
    /// Play the frames at the input's own times instead of as fast as possible: a bag's stamps, a capture's record times, a CARMEN log or a scene at the LMS scan period; JSON Lines only, each line flushed when its frame is due
    #[arg(long)]
    realtime: bool,
    /// `--foxglove` (with --realtime): the replay live in Foxglove.
    #[command(flatten)]
    live: FoxgloveArgs,
}

/// The scans of `file` selected by `range`, streamed; reading stops before
/// the selection's last frame is passed.
fn selected_scans<'a>(
    file: &'a mut input::ScanFile,
    range: &'a FrameRange,
) -> impl Iterator<Item = Result<input::InputScan>> + 'a {
    std::iter::from_fn(move || {
        if range.is_past(file.read()) {
            return None;
        }
        file.next()
    })
    .filter(move |s| s.as_ref().map_or(true, |s| range.contains(s.index)))
}

/// The frames of a log or capture selected by `range`, streamed: reading
/// stops after the range's end.
fn file_inputs<'a>(
    file: &'a mut input::ScanFile,
    range: &'a FrameRange,
) -> impl Iterator<Item = Result<InputFrame>> + 'a {
    selected_scans(file, range).map(|s| s.map(input::InputScan::into_frame))
}

/// The input file in a summary line: its path, what it is, the scans read.
fn file_about(f: &input::ScanFile) -> String {
    format!(
        "{} ({}, {} scans read)",
        f.path().display(),
        f.describe(),
        f.read()
    )
}

/// The synthetic scene in a summary line.
fn scene_about(sc: &SceneArgs) -> String {
    format!(
        "scene {} (seed {}, {} frames, noise {} m, dropout {})",
        sc.scene_name(),
        sc.seed,
        sc.count,
        sc.noise_sigma,
        sc.dropout
    )
}

/// The frames of the synthetic scene selected by `range`, streamed.
fn scene_inputs<'a>(
    scene: &'a SceneArgs,
    range: &'a FrameRange,
) -> Result<impl Iterator<Item = Result<InputFrame>> + 'a> {
    Ok(synthetic::frames_iter(scene)?
        .take_while(move |f| f.as_ref().map_or(true, |f| !range.is_past(f.index)))
        .filter(move |f| f.as_ref().map_or(true, |f| range.contains(f.index))))
}

/// Refuse an output file that is the input, under any name (a hard link,
/// a symlink, `/dev/stdin`): it would be truncated before it is read.
fn check_output(output: &Path, input: Option<&Path>) -> Result<()> {
    let Some(input) = input else { return Ok(()) };
    if input::same_file(output, input) {
        bail!(
            "-o {}: that is the input file (same device and inode); writing it would destroy it",
            output.display()
        );
    }
    Ok(())
}

/// The parameters of `extract`: defaults per data for a CARMEN log (σ,
/// max_range; flags override), from the log's head in memory.
fn extract_params(file: Option<&input::ScanFile>, args: &ParamArgs) -> Result<lms_core::Params> {
    match file {
        Some(file) => match crate::defaults::for_file(file, args)? {
            Some((params, warning)) => {
                if let Some(w) = warning {
                    let _ = writeln!(io::stderr(), "host-bridge extract: {w}");
                }
                Ok(params)
            }
            None => args.to_params(),
        },
        None => args.to_params(),
    }
}

/// Run `host-bridge extract`.
pub fn run(args: &ExtractArgs) -> Result<()> {
    let started = Instant::now();
    let range = args.frames.unwrap_or_default();
    if let Some(output) = &args.output {
        check_output(output, args.log.as_deref())?;
    }
    // A log or a capture (told by its magic), streamed; or the scene.
    let mut file = match &args.log {
        Some(path) => Some(input::open_topic(
            path,
            input::ReadOptions {
                unit: args.unit,
                keep_damaged: args.keep_damaged,
            },
            args.topic.name(),
        )?),
        None => None,
    };
    let params = extract_params(file.as_ref(), &args.params)?;
    let format = Format::choose(args.format, args.output.as_deref());
    let replay = replay_for(args, format)?;
    if let Some(ros) = match &args.output {
        Some(path) => RosOut::create(format, path, false)?,
        None => None,
    } {
        return run_extract_ros(args, ros, file.as_mut(), &params, started);
    }
    let (out, out_name) = json_output(args.output.as_deref())?;
    let (summary, source) = match file.as_mut() {
        Some(f) => {
            let s = match &replay {
                Some(r) => replay_file(r, f, &range, &params, (out, &out_name))?,
                None => record::extract_named(file_inputs(f, &range), &params, out, &out_name)?,
            };
            f.warn_if_cut();
            (s, file_about(f))
        }
        None => {
            let scene = scene_inputs(&args.scene, &range)?;
            let s = match &replay {
                Some(r) => replay_scene(r, scene, &params, (out, &out_name))?,
                None => record::extract_named(scene, &params, out, &out_name)?,
            };
            let sc = &args.scene;
            let about = scene_about(sc);
            (s, about)
        }
    };
    if let Some(line) = replay.as_ref().and_then(Replay::summary) {
        let _ = writeln!(io::stderr(), "{line}");
    }
    if summary.frames == 0
        && !summary.output_closed
        && !replay.as_ref().is_some_and(Replay::stopped)
    {
        let total = file.as_ref().map_or(args.scene.count, |f| f.read());
        bail!(
            "{}--frames {range} selects no frame (there are {total} frames)",
            args.log
                .as_deref()
                .map_or_else(String::new, |p| format!("{}: ", p.display()))
        );
    }
    print_summary(&source, &summary, params.iterations, started);
    Ok(())
}

/// The JSON Lines output: `-o FILE`, else standard output; and its name.
fn json_output(output: Option<&Path>) -> Result<(Box<dyn Write>, String)> {
    Ok(match output {
        Some(path) => (
            Box::new(
                File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
            ),
            path.display().to_string(),
        ),
        None => (Box::new(io::stdout().lock()), "standard output".to_string()),
    })
}

/// `--realtime` (and `--foxglove`): the replay, or `None`; refused with
/// an MCAP or rosbag2 output, and `--foxglove` without `--realtime`.
fn replay_for(args: &ExtractArgs, format: Format) -> Result<Option<Replay>> {
    if !args.realtime {
        if args.live.foxglove.is_some() {
            bail!("--foxglove replays the input into Foxglove at its own times: add --realtime");
        }
        return Ok(None);
    }
    if format != Format::Jsonl {
        bail!(
            "--realtime writes JSON Lines; an MCAP file or a rosbag2 folder is written as fast \
             as possible (leave out --realtime, or give -o FILE.jsonl)"
        );
    }
    Replay::start(&args.live, "host-bridge extract").map(Some)
}

/// The selected frames of `file` played by `replay` into `out` (a writer
/// and its name).
fn replay_file(
    replay: &Replay,
    file: &mut input::ScanFile,
    range: &FrameRange,
    params: &lms_core::Params,
    out: (Box<dyn Write>, &str),
) -> Result<Summary> {
    let frames = selected_scans(file, range)
        .map(|s| s.map(live_view::timed))
        .map_while(|t| replay.due(t));
    let mut show = |f: &InputFrame, features: &lms_core::Features| replay.show(f, features);
    record::extract_observed(frames, params, out.0, out.1, true, &mut show)
}

/// The frames of the scene played by `replay` into `out`, at the LMS scan
/// period.
fn replay_scene(
    replay: &Replay,
    scene: impl Iterator<Item = Result<InputFrame>>,
    params: &lms_core::Params,
    out: (Box<dyn Write>, &str),
) -> Result<Summary> {
    let frames = scene
        .map(|f| {
            f.map(|f| {
                let stamp = stamp_for(f.index, &f.frame, None, None, None);
                (f, stamp, live_view::Clock::ScanPeriod)
            })
        })
        .map_while(|t| replay.due(t));
    let mut show = |f: &InputFrame, features: &lms_core::Features| replay.show(f, features);
    record::extract_observed(frames, params, out.0, out.1, true, &mut show)
}

/// `extract -o x.mcap` or `--format rosbag2`: the frames with their stamps
/// as ROS 2 messages into `ros`.
fn run_extract_ros(
    args: &ExtractArgs,
    ros: RosOut,
    file: Option<&mut input::ScanFile>,
    params: &lms_core::Params,
    started: Instant,
) -> Result<()> {
    let range = args.frames.unwrap_or_default();
    let (summary, source, total) = match file {
        Some(f) => {
            let s = record::extract_to_ros(file_ros_inputs(f, &range), params, ros)?;
            f.warn_if_cut();
            (s, file_about(f), f.read())
        }
        None => {
            let frames = scene_inputs(&args.scene, &range)?.map(|f| {
                f.map(|f| {
                    let stamp = stamp_for(f.index, &f.frame, None, None, None);
                    (f, stamp)
                })
            });
            let s = record::extract_to_ros(frames, params, ros)?;
            let sc = &args.scene;
            let about = scene_about(sc);
            (s, about, sc.count)
        }
    };
    if summary.frames == 0 {
        bail!("--frames {range} selects no frame (there are {total} frames)");
    }
    print_summary(&source, &summary, params.iterations, started);
    Ok(())
}

/// [`file_inputs`] with each frame's stamp (its own, a capture's time, or
/// its index at the scan period) for the ROS 2 outputs.
fn file_ros_inputs<'a>(
    file: &'a mut input::ScanFile,
    range: &'a FrameRange,
) -> impl Iterator<Item = Result<(InputFrame, Stamp)>> + 'a {
    selected_scans(file, range).map(|s| {
        s.map(|s| {
            let stamp = s.stamp();
            (s.into_frame(), stamp)
        })
    })
}

/// The closing line of `extract` on stderr (a closed stderr is ignored).
fn print_summary(source: &str, summary: &Summary, passes: u16, started: Instant) {
    let per_frame = summary.pipeline.as_secs_f64() * 1e3 / summary.frames.max(1) as f64;
    let _ = writeln!(
        io::stderr(),
        "host-bridge extract: {source}: {} frames{}, {} lines, {} corners ({} well-conditioned); \
         pipeline {:.1} ms ({per_frame:.3} ms/frame at {passes} passes), total {:.1} ms",
        summary.frames,
        if summary.output_closed {
            " (output closed early)"
        } else {
            ""
        },
        summary.lines,
        summary.corners,
        summary.well_conditioned,
        summary.pipeline.as_secs_f64() * 1e3,
        started.elapsed().as_secs_f64() * 1e3,
    );
}
