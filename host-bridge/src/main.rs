//! `host-bridge`: the host tool of the LMS 2xx feature co-processor.
//!
//! Subcommands:
//!
//! * `extract` — features of a CARMEN log, a capture or a synthetic scene, as JSON Lines.
//! * `plot` — figures of one frame (see `host_bridge::plot`).
//! * `scan` — record scans from a sensor into a capture file (see `host_bridge::scan`).
//! * `simulate` — a simulated LMS 2xx on a pseudo-terminal (see `host_bridge::simulate`).
//! * `verify` — check a co-processor's features bit for bit (see `host_bridge::verify`).
//!
//! The accuracy evaluation is not here: `lms-lab evaluate` (lab/).

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};

use host_bridge::carmen;
use host_bridge::extract::{self, InputFrame};
use host_bridge::options::{FrameRange, ParamArgs, UnitArg};
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
}

#[derive(Args, Debug)]
struct ExtractArgs {
    /// CARMEN log (gzip or plain) or capture file from `scan`; without it, a synthetic scene is used
    log: Option<PathBuf>,
    #[command(flatten)]
    scene: SceneArgs,
    /// Range unit of the log's error codes: auto = mm if any value has 3 decimals
    #[arg(long, value_enum, default_value_t = UnitArg::Auto, requires = "log")]
    unit: UnitArg,
    #[command(flatten)]
    params: ParamArgs,
    /// Frames to process: A..B (B exclusive), A..=B, A.., ..B or A
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Write the JSON Lines here instead of standard output
    #[arg(long, short, value_name = "FILE")]
    output: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Extract(args) => run_extract(args),
        Command::Plot(args) => host_bridge::plot::run(&args),
        Command::Scan(args) => host_bridge::scan::run(&args),
        Command::Simulate(args) => host_bridge::simulate::run(&args),
        Command::Verify(args) => host_bridge::verify::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-bridge: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The frames of the CARMEN log at `path` selected by `range`, and a
/// description for the summary.
fn log_inputs(
    path: &Path,
    args: &ExtractArgs,
    range: &FrameRange,
) -> Result<(String, Vec<InputFrame>)> {
    let log = carmen::read_log(path, args.unit.carmen_mode())?;
    let total = log.scans.len();
    let inputs: Vec<InputFrame> = log
        .scans
        .into_iter()
        .filter(|s| range.contains(s.index))
        .map(|s| InputFrame {
            index: s.index,
            frame: s.frame,
            pose: Some(s.meta.pose),
        })
        .collect();
    if inputs.is_empty() {
        bail!(
            "{}: --frames {range} selects no frame (the log has {total} FLASER frames)",
            path.display()
        );
    }
    let about = format!("{} ({} frames, {} ranges)", path.display(), total, log.unit);
    Ok((about, inputs))
}

/// The frames of the synthetic scene selected by `range`, and a
/// description for the summary.
fn scene_inputs(scene: &SceneArgs, range: &FrameRange) -> Result<(String, Vec<InputFrame>)> {
    let all = synthetic::frames(scene)?;
    let total = all.len();
    let inputs: Vec<InputFrame> = all
        .into_iter()
        .filter(|f| range.contains(f.index))
        .collect();
    if inputs.is_empty() {
        bail!("--frames {range} selects no frame of the {total} synthetic frames");
    }
    let about = format!(
        "scene {} (seed {}, {} frames, noise {} m, dropout {})",
        scene.scene_name(),
        scene.seed,
        total,
        scene.noise_sigma,
        scene.dropout
    );
    Ok((about, inputs))
}

fn run_extract(args: ExtractArgs) -> Result<()> {
    let started = Instant::now();
    let range = args.frames.unwrap_or_default();
    // Defaults per data for a CARMEN log (σ, max_range; flags override).
    let params = match &args.log {
        Some(path) if !host_bridge::capture::is_capture(path).unwrap_or(false) => {
            let (params, warning) =
                host_bridge::defaults::for_log(path, args.unit.carmen_mode(), &args.params)?;
            warning
                .into_iter()
                .for_each(|w| eprintln!("host-bridge extract: {w}"));
            params
        }
        _ => args.params.to_params()?,
    };
    let (source, inputs) = match &args.log {
        // A capture recorded by `host-bridge scan` (told by its magic).
        Some(path) if host_bridge::capture::is_capture(path).unwrap_or(false) => {
            host_bridge::capture::input_frames(path, &range)?
        }
        Some(path) => log_inputs(path, &args, &range)?,
        None => scene_inputs(&args.scene, &range)?,
    };

    let out: Box<dyn Write> = match &args.output {
        Some(path) => Box::new(
            File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
        ),
        None => Box::new(io::stdout().lock()),
    };
    let summary = extract::extract_to(inputs.into_iter().map(Ok), &params, out)?;
    let per_frame = summary.pipeline.as_secs_f64() * 1e3 / summary.frames.max(1) as f64;
    eprintln!(
        "host-bridge extract: {source}: {} frames{}, {} lines, {} corners ({} well-conditioned); \
         pipeline {:.1} ms ({per_frame:.3} ms/frame at {} passes), total {:.1} ms",
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
        params.iterations,
        started.elapsed().as_secs_f64() * 1e3,
    );
    Ok(())
}
