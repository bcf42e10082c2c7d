//! A clean stop on SIGINT and SIGTERM (`simulate`, `verify`, `scan`), and
//! SIGHUP (a closed terminal) for `scan`.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{Context, Result};

/// A flag set by SIGINT and SIGTERM (signal-hook: no handler code of ours
/// runs in the signal).
pub fn stop_flag() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("cannot install the signal handler")?;
    }
    Ok(stop)
}

/// Like [`stop_flag`], for SIGINT, SIGTERM and SIGHUP, but a second
/// signal while the first is being handled exits at once with status 130
/// (`scan`: the first signal stops the sensor cleanly and keeps the scans).
pub fn interrupt_flag() -> Result<Arc<AtomicBool>> {
    let interrupted = Arc::new(AtomicBool::new(false));
    for signal in [
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGHUP,
    ] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, Arc::clone(&interrupted))
            .and_then(|_| signal_hook::flag::register(signal, Arc::clone(&interrupted)))
            .context("cannot install the signal handler")?;
    }
    Ok(interrupted)
}
