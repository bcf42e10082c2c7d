//! `host-bridge`: the host tool of the LMS 2xx feature co-processor.
//!
//! Subcommands:
//!
//! * `extract` — features of a CARMEN log, a capture, a ROS 2 bag or a synthetic scene, as JSON Lines or ROS 2 messages (see `host_bridge::extract`).
//! * `plot` — figures of one frame (see `host_bridge::plot`).
//! * `scan` — record scans from a sensor into a capture file (see `host_bridge::scan`).
//! * `simulate` — a simulated LMS 2xx on a pseudo-terminal (see `host_bridge::simulate`).
//! * `verify` — check a co-processor's features bit for bit (see `host_bridge::verify`).
//! * `coprocessor` — the co-processor natively between a sensor port and a pty (see `host_bridge::coprocessor`).
//! * `params` — every parameter with its value, unit and meaning, the presets, the stats counters (see `host_bridge::reference`).
//!
//! The accuracy evaluation is not here: `lms-lab evaluate` (lab/).

use std::io::{self, Write};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

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
    Extract(host_bridge::extract::ExtractArgs),
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Extract(args) => host_bridge::extract::run(&args),
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
