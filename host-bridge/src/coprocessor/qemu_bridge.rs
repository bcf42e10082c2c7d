//! `host-bridge coprocessor --qemu`: the real firmware under QEMU between
//! the sensor port and the client's pty. The bytes are passed both ways as
//! they come; the sensor port follows the firmware's baud switch (its `20 4x`
//! request and the sensor's `A0 00` reply, seen on the way), as a UART
//! would; the client line's rate is the firmware's business (QEMU's UARTs
//! carry bytes at its own pace).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use embedded_io::{Read as _, ReadReady as _, Write as _};
use lms_core::telegram::{Baud, Direction, Event, Framer, Handshake, Request};

use crate::serial::{Link, PtyPort, SerialLink};
use crate::verify::QemuLines;

/// Longest wait for sensor bytes per round.
const TICK: Duration = Duration::from_millis(1);

/// Watches both directions of the sensor line for a completed baud switch.
struct BaudWatch {
    requests: Framer,
    replies: Framer,
    pending: Option<Baud>,
}

impl BaudWatch {
    fn new() -> Self {
        BaudWatch {
            requests: Framer::new(Direction::HostToSensor, Handshake::Ignored),
            replies: Framer::new(Direction::SensorToHost, Handshake::Expected),
            pending: None,
        }
    }

    /// Bytes the firmware sent the sensor.
    fn requests(&mut self, mut bytes: &[u8]) {
        loop {
            let fed = self.requests.feed(bytes);
            bytes = fed.remaining;
            match fed.event {
                Some(Event::Telegram(t)) => {
                    if let Ok(Request::SetBaud(b)) = Request::parse(&t) {
                        self.pending = Some(b);
                    }
                }
                Some(_) => {}
                None => return,
            }
        }
    }

    /// Bytes the sensor sent the firmware: the rate to switch to now, if
    /// they held the `A0 00` of a baud request.
    fn replies(&mut self, mut bytes: &[u8]) -> Option<Baud> {
        let mut switch = None;
        loop {
            let fed = self.replies.feed(bytes);
            bytes = fed.remaining;
            match fed.event {
                Some(Event::Telegram(t)) if t.command() == 0xA0 && t.data().first() == Some(&0) => {
                    switch = switch.or(self.pending.take());
                }
                Some(_) => {}
                None => return switch,
            }
        }
    }
}

/// Pass bytes between the sensor, QEMU and the client until `stop` or
/// `quit_after`; returns why it stopped.
pub(super) fn bridge(
    sensor: &mut SerialLink,
    client: &mut PtyPort,
    qemu: &mut QemuLines,
    stop: &AtomicBool,
    quit_after: Option<Duration>,
) -> Result<&'static str> {
    let started = Instant::now();
    let mut watch = BaudWatch::new();
    let mut buf = [0u8; 4096];
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok("signal");
        }
        if quit_after.is_some_and(|q| started.elapsed() >= q) {
            return Ok("--quit-after");
        }
        while client.read_ready()? {
            let n = client.read(&mut buf)?;
            if n == 0 {
                break;
            }
            qemu.host.send(&buf[..n]).context("firmware host UART")?;
        }
        let n = qemu.host.receive(&mut buf, Duration::ZERO)?;
        client.write_all(&buf[..n])?;
        let n = qemu.sensor.receive(&mut buf, Duration::ZERO)?;
        if n > 0 {
            sensor.send(&buf[..n]).context("sensor port")?;
            watch.requests(&buf[..n]);
        }
        let n = sensor.receive(&mut buf, TICK).context("sensor port")?;
        if n > 0 {
            qemu.sensor
                .send(&buf[..n])
                .context("firmware sensor UART")?;
            if let Some(b) = watch.replies(&buf[..n]) {
                sensor
                    .set_baud(b)
                    .context("sensor port: cannot switch the rate")?;
            }
        }
        if let Some(console) = qemu.console.as_mut() {
            while console.receive(&mut buf, Duration::ZERO)? > 0 {}
        }
    }
}
