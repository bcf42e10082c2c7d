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
    /// Run the co-processor on this computer: an LMS 2xx on a serial port,
    /// the client on a pseudo-terminal symlinked at --link
    Coprocessor(host_bridge::coprocessor::CoprocessorArgs),
    /// List every pipeline parameter with its value, unit and meaning (or
    /// a preset's values, or the counters of a frame's stats)
    Params(host_bridge::reference::ParamsArgs),
}

#[derive(Args, Debug)]
struct ExtractArgs {
    /// CARMEN log (gzip or plain) or capture file from `scan`; without it, a synthetic scene is used
    log: Option<PathBuf>,
    #[command(flatten)]
    scene: SceneArgs,
    /// Range unit of the log's error codes: auto = mm if at least 1/4 of the values show 3 decimals, cm if none (warns when in between)
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

/// The frames of a log or capture selected by `range`, streamed: reading
/// stops after the range's end.
fn file_inputs<'a>(
    file: &'a mut input::ScanFile,
    range: &'a FrameRange,
) -> impl Iterator<Item = Result<InputFrame>> + 'a {
    // Stop before reading past the selection's last frame.
    std::iter::from_fn(move || {
        if range.is_past(file.read()) {
            return None;
        }
        file.next()
    })
    .filter(move |s| s.as_ref().map_or(true, |s| range.contains(s.index)))
    .map(|s| {
        s.map(|s| InputFrame {
            index: s.index,
            frame: s.frame,
            pose: s.pose,
        })
    })
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

/// Refuse an output file that is the input (it would be truncated before
/// it is read).
fn check_output(output: &Path, input: Option<&Path>) -> Result<()> {
    let Some(input) = input else { return Ok(()) };
    if let (Ok(a), Ok(b)) = (std::fs::canonicalize(output), std::fs::canonicalize(input)) {
        if a == b {
            bail!(
                "-o {}: that is the input file; writing it would destroy it",
                output.display()
            );
        }
    }
    Ok(())
}

fn run_extract(args: ExtractArgs) -> Result<()> {
    let started = Instant::now();
    let range = args.frames.unwrap_or_default();
    if let Some(output) = &args.output {
        check_output(output, args.log.as_deref())?;
    }
    // A log or a capture (told by its magic), streamed; or the scene.
    let mut file = match &args.log {
        Some(path) => Some(input::open(path, args.unit)?),
        None => None,
    };
    // Defaults per data for a CARMEN log (σ, max_range; flags override).
    let params = match &args.log {
        Some(path) => match host_bridge::defaults::for_log(path, args.unit, &args.params)? {
            Some((params, warning)) => {
                if let Some(w) = warning {
                    let _ = writeln!(io::stderr(), "host-bridge extract: {w}");
                }
                params
            }
            None => args.params.to_params()?,
        },
        None => args.params.to_params()?,
    };

    let (out, out_name): (Box<dyn Write>, String) = match &args.output {
        Some(path) => (
            Box::new(
                File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
            ),
            path.display().to_string(),
        ),
        None => (Box::new(io::stdout().lock()), "standard output".to_string()),
    };
    let (summary, source) = match file.as_mut() {
        Some(f) => {
            let s = extract::extract_named(file_inputs(f, &range), &params, out, &out_name)?;
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
            let s = extract::extract_named(
                scene_inputs(&args.scene, &range)?,
                &params,
                out,
                &out_name,
            )?;
            let sc = &args.scene;
            let about = format!(
                "scene {} (seed {}, {} frames, noise {} m, dropout {})",
                sc.scene_name(),
                sc.seed,
                sc.count,
                sc.noise_sigma,
                sc.dropout
            );
            (s, about)
        }
    };
    if summary.frames == 0 && !summary.output_closed {
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
