//! `host-bridge verify`: drive a co-processor from both of its serial lines
//! and check, bit for bit, that the features it sends are the ones the std
//! build computes from the very scans it passed through.
//!
//! Its options are those of `host-bridge verify --help` ([`VerifyArgs`]).
//!
//! # What it plays
//!
//! * **The sensor** on the co-processor's sensor line: a simulated LMS 2xx
//!   ([`lms_core::device::emulator::Emulator`]) that the co-processor brings up
//!   itself (variant, mm, 500 kBd, continuous output). Its scans come from a
//!   [`PlaySource`]: the synthetic scene (default; the frames of
//!   `host-bridge extract` with the same scene options) or the `FLASER`
//!   frames `--frames A..B` of a CARMEN log (`--replay`); 180° logs of other
//!   resolutions are resampled to 180°/0.5° like `simulate --replay` does, 100°
//!   logs are refused. Each scan of the selection is sent exactly once, in
//!   order, at the emulator's real pace (one `B0` per 26.7 ms at 500 kBd).
//! * **The client** on the co-processor's host line, with raw LMS telegrams:
//!   the counters request `55` (retried until the `D5` comes: the first
//!   bytes may be lost while the board starts), `20 48` (500 kBd,
//!   `--host-baud`), `20 24`; then it reads the `B0` + feature telegrams
//!   (`D4 D3 D1… D2… D0`), reassembles them per scan
//!   ([`FeatureAssembler`](lms_core::telegram::features::FeatureAssembler)), and at the end `20 25` and a last `55`.
//!
//! # Sequence (deterministic)
//!
//! The emulator runs on the real clock, except that its clock is held:
//!
//! * from the moment the co-processor has started the sensor's stream until
//!   the client's `20 24` is acknowledged, so that no scan of the selection
//!   is spent before the host side streams;
//! * while `--max-in-flight` scans (the warm-up scan included) are out and
//!   not back (default with `--qemu`: as many 732-byte `B0`s as fit the
//!   firmware's 1023-byte sensor receive queue, 1; QEMU moves only ~10 KB/s
//!   into a UART, a third of the 500 kBd line rate, so all of them may be
//!   waiting in that queue; with `--host` 1 too: a loaded computer holds
//!   the co-processor's thread off the CPU for up to a third of a second,
//!   nothing comes back meanwhile, and a sensor running free would outrun
//!   the host line, which takes 27.2 ms on average for a CSAIL scan with
//!   its features at 500 kBd, more than the 26.7 ms scan period; off with
//!   `--ports`);
//! * while the host line is still busy, at its rate, with what came back
//!   (so that the co-processor's host-line budget passes every scan on);
//! * after the last scan of the selection has gone out, or at `--timeout`;
//! * while verify's own loop is held off the CPU: the clock advances at
//!   most 5 ms from one pass of the loop to the next, so that a stalled
//!   loop does not find several scans due at once and send them back to
//!   back (no LMS does).
//!
//! The LMS's first mirror tick falls at the very start of its stream, so
//! one scan is drawn before the clock can be held (a warm-up scan); it
//! reaches the co-processor after the client's stream is on, and is checked
//! like every scan that comes back, but not counted as part of the
//! selection. So `scans_in` is one more than the selection.
//!
//! # The check
//!
//! For every scan that comes back on the host line:
//!
//! 1. its `B0` must be byte for byte (count word and value words) a scan
//!    the sensor side sent, in order (the pass-through);
//! 2. the std build recomputes the features: [`MeasuredView::to_frame`](lms_core::telegram::MeasuredView::to_frame)
//!    with 13 range bits, [`Extractor::run`](lms_core::Extractor::run) with the parameters echoed in
//!    the `D0` summary (`iterations`, `sigma`, `q`, `tau`; the others from
//!    the command line, default ALGORITHM.md). Under QEMU these are first
//!    compared with the ones the firmware runs, by their fingerprint on its
//!    console ([`Params::fingerprint`], `params_fingerprint`): a firmware
//!    built with another preset (`LMS_PRESET`) ends the run with a message
//!    that names it, instead of a mismatch on every scan;
//! 3. segments, edge points, every field of every line and corner (floats
//!    by their bits; all NaNs count as equal) and the statistics must be
//!    identical.
//!
//! Every failing scan prints one line on stdout with its first differing
//! field:
//!
//! ```text
//! MISMATCH scan 12 (frame 11): line 3 alpha: co-processor 0x3FC90FDB (1.5707964), recomputed 0x3FC90FDA (1.5707963); 4 fields differ
//! ```
//!
//! and the run ends with `N/N scans bit-identical`, the scans lost (sent by
//! the sensor side, never back with features, found by counting; the
//! co-processor's drop counters, `scans_dropped`, `host_scans_dropped`,
//! `scans_rejected` and `scans_other_setting`, must add up to them, and
//! every message names the counters that counted them as the counters line
//! does, e.g. `host_scans_dropped=3`), and the co-processor's counters
//! from the final `55`. The exit status is 1 on any
//! mismatch, on a restart of the sensor's bring-up by the co-processor
//! while the selection plays, or on any lost scan (not back although the host line went quiet for
//! 3 s), when fewer than `--scans` scans were checked before `--timeout`
//! (those still on their way are reported as such), or without the final
//! counters.
//!
//! # Modes (how the lines are connected)
//!
//! * `--host` (default): the core's [`CoProcessor`](lms_core::device::coprocessor::CoProcessor) runs natively in a
//!   thread on the masters of two pseudo-terminals ([`crate::pty`], behind
//!   [`PtyPort`](crate::serial::PtyPort), an `embedded-io` 0.7 port); verify opens the two slave
//!   devices with the `serialport` crate, exactly as in `--ports`. The
//!   sensor's bytes reach the co-processor with their arrival times
//!   ([`Arrivals`](crate::serial::Arrivals)), as in `host-bridge coprocessor`.
//! * `--qemu [ELF]`: the firmware under `qemu-system-arm -M netduinoplus2`
//!   (extra QEMU arguments from the `QEMU_EXTRA` environment variable)
//!   with its three serial ports on TCP sockets on 127.0.0.1 (free ports
//!   chosen at start), as `firmware/run-qemu.sh` does: USART1 = host line,
//!   USART2 = sensor line, USART3 = console (read all the time, since QEMU
//!   stalls on a full socket; `s` before the stream for the firmware's
//!   parameters, `s` at the end for its report, then `q`). QEMU runs in its own process group under `timeout` (when
//!   installed), so it is bounded even if verify is killed; a guard kills
//!   the group on every exit, errors and panics included. Its `defmt` log
//!   is kept in a temporary directory and its tail decoded with
//!   `defmt-print` (if installed) when the run fails.
//!   QEMU ignores baud-rate registers: the sensor line's rates are modelled
//!   (`line_rate`) from the rate the firmware programmed in USART2's `BRR`,
//!   read through QEMU's QMP socket; bytes between ends whose rates differ
//!   arrive as noise. `--reset-mcu-after N` resets the MCU through QMP
//!   (`system_reset`) once N scans are back, while the LMS streams on at
//!   500 kBd; verify then sets the host line up again as a client would,
//!   the scans lost meanwhile are written off, and the first scan must be
//!   back within one second of the reset.
//! * `--ports HOST SENSOR`: two serial ports wired to a co-processor
//!   (`serialport` crate, 8N1, 9600 Bd at the start as after power-on).
//!
//! # Layout (in the order of the data flow)
//!
//! * `args` — [`VerifyArgs`], the options.
//! * `source` — [`PlaySource`]: the scans the sensor side plays, and what
//!   it drew ([`play_source`] builds it from the options).
//! * `dut` — the co-processor under test and the two lines to it, per mode:
//!   `host` (the [`CoProcessor`](lms_core::device::coprocessor::CoProcessor)
//!   in a thread, [`run_coprocessor`]), [`crate::qemu`] (the firmware under QEMU, on
//!   TCP), or two serial ports. Every line is a [`crate::serial::Link`].
//! * `line_rate` — the sensor line's rate model under QEMU.
//! * `session` — both lines, the emulator, the client side and its
//!   requests (`exchange`), the phases of the run (`phases`).
//! * `checker` and `compare` — every scan that comes back, recomputed and
//!   compared field by field ([`differences`]).
//! * `report` — the outcome and the summary on stdout.

mod args;
mod checker;
mod client_side;
mod compare;
mod disrupt;
mod dut;
mod exchange;
mod host;
mod line_rate;
mod phases;
mod recovery;
mod report;
mod sensor_side;
mod session;
mod source;

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use lms_core::params::PRESETS;
use lms_core::telegram::features::EchoedParams;
use lms_core::telegram::Baud;
use lms_core::Params;

use crate::serial::SerialLink;

pub use args::VerifyArgs;

pub use compare::{differences, Difference, Value};
pub use host::run_coprocessor;
pub use source::{play_source, Drawn, PlaySource, Tag};

/// How long a request waits for its reply before it is sent again.
const RETRY: Duration = Duration::from_millis(500);
/// After the last scan has gone out: give up waiting for the rest once the
/// host line has been silent this long.
const QUIET: Duration = Duration::from_secs(3);
/// Time for the closing `20 25` and `55` (also after `--timeout`).
const CLOSING: Duration = Duration::from_secs(5);

/// The checked options that are not the play source: the host line's
/// rate and the pipeline parameters.
fn checked_options(args: &VerifyArgs) -> Result<(Baud, Params)> {
    ensure!(
        args.timeout.is_finite() && args.timeout > 0.0,
        "--timeout must be > 0 (seconds)"
    );
    let host_baud = Baud::from_bits_per_second(args.host_baud).with_context(|| {
        format!(
            "--host-baud {}: not a rate of the LMS 2xx (9600, 19200, 38400 or 500000)",
            args.host_baud
        )
    })?;
    args.params.ensure_coprocessor_runs_them()?;
    let params = args.params.to_params()?;
    if args.qemu.is_some() || args.ports.is_some() {
        ensure_firmware_runs(&params)?;
    }
    if let Some(t) = args.recompute_tau {
        ensure!(t.is_finite() && t > 0.0, "--recompute-tau must be > 0");
    }
    Ok((host_baud, params))
}

/// With `--qemu` or `--ports` the co-processor is the firmware, which runs
/// a preset ([`PRESETS`]: the defaults unless built with `LMS_PRESET`) and
/// echoes only iterations, σ, q and τ in its `D0` summary: parameters on
/// the command line that are no preset with those four changed would make
/// the check recompute with parameters no firmware runs, and report every
/// scan as a mismatch. Refuse them, naming the parameters that differ from
/// the defaults (or the `--preset` given). Which preset the firmware runs
/// is checked at the first summary under QEMU (its console's
/// `params_fingerprint`), and by the bits on a board.
fn ensure_firmware_runs(params: &Params) -> Result<()> {
    let echoed = EchoedParams::from(params);
    if PRESETS.iter().any(|p| echoed.over(p.params) == *params) {
        return Ok(());
    }
    let nearest = echoed.over(Params::DEFAULT);
    // The fields that differ, by name, with the value asked for.
    let differing: Vec<String> = lms_core::params::FIELDS
        .iter()
        .filter(|f| (f.get)(params) != (f.get)(&nearest))
        .map(|f| format!("{}={}", f.name, (f.get)(params)))
        .collect();
    anyhow::bail!(
        "with --qemu or --ports the co-processor is the firmware, which runs a preset (the \
         defaults unless built with LMS_PRESET) and reports only iterations, sigma, q and tau: \
         {} would be checked against results the firmware never computes; leave those flags \
         out, give the firmware's --preset, or use --host, which runs the co-processor with them",
        differing.join(", ")
    )
}

/// Connect to the co-processor the options ask for.
fn connect(
    args: &VerifyArgs,
    params: Params,
    timeout: Duration,
    stop: &Arc<AtomicBool>,
) -> Result<dut::Lines> {
    if let Some(elf) = &args.qemu {
        crate::qemu::connect(elf.as_deref(), timeout, stop).map(|c| c.map_runner(dut::Dut::Qemu))
    } else if let Some(ports) = &args.ports {
        let [host, sensor] = ports.as_slice() else {
            bail!("--ports takes two paths: HOST SENSOR");
        };
        let how = format!(
            "co-processor on serial ports {} (host line) and {} (sensor line)",
            host.display(),
            sensor.display()
        );
        Ok(dut::Lines {
            sensor: Box::new(SerialLink::open(sensor, Baud::B9600)?),
            host: Box::new(SerialLink::open(host, Baud::B9600)?),
            console: None,
            runner: dut::Dut::Ports,
            how,
        })
    } else {
        host::connect(params)
    }
}

/// Run `host-bridge verify`.
pub fn run(args: &VerifyArgs) -> Result<()> {
    let started = Instant::now();
    let (host_baud, params) = checked_options(args)?;
    let (source, about) = play_source(args)?;
    let timeout = Duration::from_secs_f64(args.timeout);
    let deadline = started + timeout;
    let stop = crate::stop::stop_flag()?;
    let lines = connect(args, params, timeout, &stop)?;
    eprintln!("host-bridge verify: {}", lines.how);
    eprintln!("host-bridge verify: sensor side plays {about}");
    let mut session = session::Session::new(lines, source, args, params, stop, started);
    let result = session.run(host_baud, deadline).map(|mut outcome| {
        outcome.firmware_report = session.firmware_report();
        outcome
    });
    session
        .dut
        .after_run(!result.as_ref().is_ok_and(report::Outcome::ok));
    let outcome = result?;
    report::report(&outcome);
    drop(session);
    outcome.verdict()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_firmware_refuses_parameters_it_does_not_echo_by_name() {
        let echoed = Params::DEFAULT.with_sigma(0.02).with_iterations(12);
        assert!(ensure_firmware_runs(&echoed).is_ok());
        let other = echoed
            .with_split_depth(3)
            .with_merge(!Params::DEFAULT.merge);
        let message = ensure_firmware_runs(&other).unwrap_err().to_string();
        let merge = format!("merge={}", other.merge);
        assert!(message.contains("split_depth=3"), "{message}");
        assert!(message.contains(&merge), "{message}");
        assert!(!message.contains("sigma="), "{message}");
        // A preset build, passes changed (`LMS_PRESET`, `LMS_ITERATIONS`).
        assert!(ensure_firmware_runs(&Params::V3_2.with_iterations(8)).is_ok());
        assert!(ensure_firmware_runs(&Params::V3_1).is_ok());
    }
}
