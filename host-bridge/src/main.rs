//! `host-bridge`: the host tool of the LMS 2xx feature co-processor.
//!
//! Subcommands:
//!
//! * `extract` — features of a CARMEN log, a capture or a synthetic scene, as JSON Lines.
//! * `plot` — figures of one frame (see `host_bridge::plot`).
//! * `scan` — record scans from a sensor into a capture file (see `host_bridge::scan`).
//! * `simulate` — a simulated LMS 2xx on a pseudo-terminal (see `host_bridge::simulate`).
//! * `verify` — check a co-processor's features bit for bit (see `host_bridge::verify`).
//! * `coprocessor` — the co-processor natively between a sensor port and a pty (see `host_bridge::coprocessor`).
//! * `params` — every parameter with its value, unit and meaning, the presets, the stats counters (see `host_bridge::reference`).
//!
//! The accuracy evaluation is not here: `lms-lab evaluate` (lab/).

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};

use host_bridge::extract::{self, InputFrame};
use host_bridge::input;
use host_bridge::live_view::{self, FoxgloveArgs, Replay};
use host_bridge::options::{FrameRange, ParamArgs, TopicArg, UnitArg};
use host_bridge::ros2::messages::Stamp;
use host_bridge::ros2::rosbag2_out::{stamp_for, Format, RosOut};
use host_bridge::synthetic::{self, SceneArgs};

#[derive(Parser, Debug)]
#[command(
    name = "host-bridge",
    version,
    about = "Host tool for the LMS 2xx feature co-processor"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Extract features (segments, lines, corners) from a CARMEN log or a
    /// synthetic scene and write them as JSON Lines, one object per frame
    Extract(ExtractArgs),
    /// Plot one frame: the scan with its features, and D per window after
    /// selected passes (SVG or PNG)
    Plot(host_bridge::plot::PlotArgs),
    /// Record scans from an LMS 2xx on a serial port (or `simulate`'s pty)
    /// into a capture file: finds the baud rate, sets variant, units and
    /// rate, streams N scans
    Scan(host_bridge::scan::ScanArgs),
    /// Simulate an LMS 2xx on a pseudo-terminal: prints the device path,
    /// answers a real client, streams synthetic or replayed scans
    Simulate(host_bridge::simulate::SimulateArgs),
    /// Check a co-processor (in a thread, under QEMU, or on two serial
    /// ports): play the sensor, be its client, recompute every scan's
    /// features and compare them bit for bit
    Verify(host_bridge::verify::VerifyArgs),
    /// Run the co-processor on this computer: an LMS 2xx on a serial port,
    /// the client on a pseudo-terminal symlinked at --link
    Coprocessor(host_bridge::coprocessor::CoprocessorArgs),
    /// List every pipeline parameter with its value, unit and meaning (or
    /// a preset's values, or the counters of a frame's stats)
    Params(host_bridge::reference::ParamsArgs),
}

#[derive(Args, Debug)]
struct ExtractArgs {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Extract(args) => run_extract(args),
        Command::Plot(args) => host_bridge::plot::run(&args),
        Command::Scan(args) => host_bridge::scan::run(&args),
        Command::Simulate(args) => host_bridge::simulate::run(&args),
        Command::Verify(args) => host_bridge::verify::run(&args),
        Command::Coprocessor(args) => host_bridge::coprocessor::run(&args),
        Command::Params(args) => host_bridge::reference::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed stderr (a hung-up terminal) must not turn into a panic.
            let _ = writeln!(io::stderr(), "host-bridge: error: {e:#}");
            ExitCode::FAILURE
        }
    }
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
    selected_scans(file, range).map(|s| {
        s.map(|s| InputFrame {
            index: s.index,
            frame: s.frame,
            pose: s.pose,
        })
    })
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
        Some(file) => match host_bridge::defaults::for_file(file, args)? {
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

fn run_extract(args: ExtractArgs) -> Result<()> {
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
    let replay = replay_for(&args, format)?;
    if let Some(ros) = match &args.output {
        Some(path) => RosOut::create(format, path, false)?,
        None => None,
    } {
        return run_extract_ros(&args, ros, file.as_mut(), &params, started);
    }
    let (out, out_name) = json_output(args.output.as_deref())?;
    let (summary, source) = match file.as_mut() {
        Some(f) => {
            let s = match &replay {
                Some(r) => replay_file(r, f, &range, &params, (out, &out_name))?,
                None => extract::extract_named(file_inputs(f, &range), &params, out, &out_name)?,
            };
            f.warn_if_cut();
            let about = format!(
                "{} ({}, {} scans read)",
                f.path().display(),
                f.describe(),
                f.read()
            );
            (s, about)
        }
        None => {
            let scene = scene_inputs(&args.scene, &range)?;
            let s = match &replay {
                Some(r) => replay_scene(r, scene, &params, (out, &out_name))?,
                None => extract::extract_named(scene, &params, out, &out_name)?,
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
) -> Result<extract::Summary> {
    let frames = selected_scans(file, range)
        .map(|s| s.map(live_view::timed))
        .map_while(|t| replay.due(t));
    let mut show = |f: &InputFrame, features: &lms_core::Features| replay.show(f, features);
    extract::extract_observed(frames, params, out.0, out.1, true, &mut show)
}

/// The frames of the scene played by `replay` into `out`, at the LMS scan
/// period.
fn replay_scene(
    replay: &Replay,
    scene: impl Iterator<Item = Result<InputFrame>>,
    params: &lms_core::Params,
    out: (Box<dyn Write>, &str),
) -> Result<extract::Summary> {
    let frames = scene
        .map(|f| {
            f.map(|f| {
                let stamp = stamp_for(f.index, &f.frame, None, None, None);
                (f, stamp, live_view::Clock::ScanPeriod)
            })
        })
        .map_while(|t| replay.due(t));
    let mut show = |f: &InputFrame, features: &lms_core::Features| replay.show(f, features);
    extract::extract_observed(frames, params, out.0, out.1, true, &mut show)
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
            let s = extract::extract_to_ros(file_ros_inputs(f, &range), params, ros)?;
            f.warn_if_cut();
            let about = format!(
                "{} ({}, {} scans read)",
                f.path().display(),
                f.describe(),
                f.read()
            );
            (s, about, f.read())
        }
        None => {
            let frames = scene_inputs(&args.scene, &range)?.map(|f| {
                f.map(|f| {
                    let stamp = stamp_for(f.index, &f.frame, None, None, None);
                    (f, stamp)
                })
            });
            let s = extract::extract_to_ros(frames, params, ros)?;
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
            let stamp = stamp_for(
                s.index,
                &s.frame,
                s.stamp_ns,
                s.time_us,
                s.frame_id.as_deref(),
            );
            let frame = InputFrame {
                index: s.index,
                frame: s.frame,
                pose: s.pose,
            };
            (frame, stamp)
        })
    })
}

/// The closing line of `extract` on stderr (a closed stderr is ignored).
fn print_summary(source: &str, summary: &extract::Summary, passes: u16, started: Instant) {
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
