//! `--host`: the core's co-processor natively in a thread, on the masters
//! of two pseudo-terminals; verify opens the two slaves as serial ports.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use lms_core::device::coprocessor::SensorSetup;
use lms_core::telegram::features::Counters;
use lms_core::telegram::Baud;
use lms_core::{Params, ValidParams};

use super::dut::{Dut, Lines};
use crate::coprocessor::PcCoProcessor;
use crate::pty::Pty;
use crate::serial::TICK;
use crate::serial::{PtyPort, SerialLink};

/// Run a [`CoProcessor`](lms_core::device::coprocessor::CoProcessor) on
/// two ports until `stop` ([`PcCoProcessor`]: the sensor's bytes at their
/// arrival times), waiting up to [`TICK`] for sensor bytes between polls.
/// Returns its counters.
pub fn run_coprocessor(
    params: ValidParams,
    sensor: PtyPort,
    mut host: PtyPort,
    stop: &AtomicBool,
) -> Result<Counters, String> {
    let mut pc = PcCoProcessor::start(params, SensorSetup::default(), sensor);
    let failed = |e: anyhow::Error| format!("co-processor thread: {e}");
    while !stop.load(Ordering::Relaxed) {
        pc.poll(&mut host).map_err(failed)?;
        pc.sensor_mut()
            .wait_readable(TICK)
            .map_err(|e| format!("co-processor thread: {e}"))?;
    }
    Ok(pc.cop().counters())
}

/// Two pseudo-terminals, the co-processor in a thread on their masters and
/// verify's ends on their slaves.
pub(super) fn connect(params: Params) -> Result<Lines> {
    let sensor_pty = PtyPort::new(Pty::open(9600)?);
    let host_pty = PtyPort::new(Pty::open(9600)?);
    // Our ends first, so that nothing the co-processor sends is lost.
    let sensor = SerialLink::open(sensor_pty.slave_path(), Baud::B9600)?;
    let host = SerialLink::open(host_pty.slave_path(), Baud::B9600)?;
    let how = format!(
        "lms_core::device::coprocessor::CoProcessor in a thread, host line {}, sensor line {}",
        host_pty.slave_path().display(),
        sensor_pty.slave_path().display()
    );
    let params = params
        .validate()
        .map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
    let thread_stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&thread_stop);
    let handle = std::thread::Builder::new()
        .name("coprocessor".into())
        .spawn(move || run_coprocessor(params, sensor_pty, host_pty, &flag))
        .context("cannot start the co-processor thread")?;
    let dut = Dut::Thread {
        handle: Some(handle),
        stop: thread_stop,
    };
    Ok(Lines {
        sensor: Box::new(sensor),
        host: Box::new(host),
        console: None,
        runner: dut,
        how,
    })
}
