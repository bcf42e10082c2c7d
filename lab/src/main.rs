//! `lms-lab`: research tooling of the LMS 2xx feature co-processor.
//!
//! Subcommands:
//!
//! * `evaluate` — accuracy report: ground truth, scale space, baselines,
//!   real scans (see `lms_lab`); tables and figures only, the findings are
//!   hand-written in `docs/evaluation/FINDINGS.md`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "lms-lab",
    version,
    about = "Research tooling for the LMS 2xx feature co-processor (no stability promise)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Measure accuracy against ground truth (synthetic scenes), the scale
    /// space, two baselines and real scans; write the tables and SVG
    /// figures of a Markdown report into a folder
    Evaluate(lms_lab::EvaluateArgs),
    /// Real scans against truth from each log's SLAM map (the real-scan
    /// part of `evaluate` alone): writes DIR/real-truth.md and figures
    Truth(lms_lab::TruthArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Evaluate(args) => lms_lab::run(&args),
        Command::Truth(args) => lms_lab::run_truth(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lms-lab: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
