//! `feature-bits LOG [ITERATIONS]`: every feature of every frame of a
//! CARMEN log as raw IEEE-754 bits on stdout (see the library docs), at the
//! default parameters with `ITERATIONS` smoothing passes (default: the
//! defaults' passes).
//!
//! `.ci/run` runs it built with and without `--features std` and requires
//! identical output (ALGORITHM.md §9: `std` changes no numeric result).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "../shared/data/carmen/csail-corrected.log.gz".into()),
    );
    let iterations = match args.next().map(|s| s.parse::<u16>()) {
        None => lms_core::Params::DEFAULT.iterations,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("feature-bits: ITERATIONS must be a number of passes (1..=1000): {e}");
            return ExitCode::from(2);
        }
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match feature_bits::write_log_bits(&path, iterations, &mut out).and_then(|_| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("feature-bits: {}: {e}", path.display());
            ExitCode::FAILURE
        }
    }
}
