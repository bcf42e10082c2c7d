//! `host-bridge coprocessor --qemu`: the real firmware under QEMU between
//! the sensor port and the client's pty. The bytes are passed both ways as
//! they come; the sensor port follows the firmware's baud switch (its `20 4x`
//! request and the sensor's `A0 00` reply, seen on the way), as a UART
//! would. The client's pty follows the firmware's host UART the same way
//! (the client's `20 4x` and the firmware's `A0 00`; back to 9600 Bd with
//! the firmware's power-on telegram `90`), so that a client at another
//! rate is noise to the firmware, as on a real line ([`PtyPort`]); QEMU's
//! UARTs themselves carry bytes at their own pace whatever the rate.
//!
//! QEMU's USART takes a received byte per turn of its main loop, about
//! 10 KB/s (less under load), while the sensor streams 15–28 KB/s at
//! 500 kBd; passed on as they come, the sensor's bytes queued in the TCP
//! socket to QEMU (up to its 64 KiB window, seconds of stream) and every
//! reply of the sensor reached the firmware that late (a bring-up's
//! `20 25` answered 5.8 s after it was sent, relayed requests unanswered).
//! A real 500 kBd line never queues: so [`SensorFeed`] passes the sensor's
//! stream telegrams (`B0`, `B6`/`B7`/`BF`) only while its estimate of what
//! QEMU has not yet taken is under
//! [`QEMU_QUEUE_BYTES`](crate::qemu::intake::QEMU_QUEUE_BYTES), dropping the
//! others whole (counted, said at exit: the firmware sees a slower sensor),
//! and every reply, `ACK` and `NAK` at once.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use embedded_io::{Read as _, ReadReady as _, Write as _};
use lms_core::telegram::reply::code as reply_code;
use lms_core::telegram::{Baud, Direction, Event, Framer, Handshake, Request};

use crate::qemu::Connected;
use crate::qemu::QemuIntake;
use crate::serial::{Link, PtyPort, SerialLink, TICK};

/// The sensor's bytes on their way to QEMU (see the module docs).
pub(super) struct SensorFeed {
    framer: Framer,
    intake: QemuIntake,
    /// Stream telegrams dropped.
    pub(super) dropped: u64,
}

impl SensorFeed {
    pub(super) fn new() -> Self {
        SensorFeed {
            framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
            intake: QemuIntake::new(),
            dropped: 0,
        }
    }

    /// What of `bytes` goes to QEMU now, appended to `out`: every complete
    /// telegram, `ACK` and `NAK`, but a stream telegram only while the
    /// queue is short; bytes that frame nothing are not passed.
    pub(super) fn pass(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut input = bytes;
        loop {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            let start = out.len();
            match fed.event {
                Some(Event::Telegram(t)) => {
                    let stream = matches!(t.command(), 0xB0 | 0xB6 | 0xB7 | 0xBF);
                    if stream && self.intake.full() {
                        self.dropped += 1;
                    } else {
                        out.extend_from_slice(t.as_bytes());
                    }
                }
                Some(Event::Ack) => out.push(lms_core::telegram::ACK),
                Some(Event::Nak) => out.push(lms_core::telegram::NAK),
                // Not from a full-size framer.
                Some(Event::Long { .. }) => {}
                None => return,
            }
            self.intake.add(out.len() - start);
        }
    }
}

/// Watches both directions of the sensor line for a completed baud switch.
struct BaudWatch {
    requests: Framer,
    replies: Framer,
    pending: Option<Baud>,
    /// The power-on telegram `90` puts the line back to 9600 Bd (the
    /// client line: the firmware's face restarts at the LMS's power-on
    /// rate after a `10` or a reboot).
    power_on_resets: bool,
}

impl BaudWatch {
    fn new(power_on_resets: bool) -> Self {
        BaudWatch {
            requests: Framer::new(Direction::HostToSensor, Handshake::Ignored),
            replies: Framer::new(Direction::SensorToHost, Handshake::Expected),
            pending: None,
            power_on_resets,
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
                Some(Event::Telegram(t))
                    if self.power_on_resets && t.command() == reply_code::POWER_ON =>
                {
                    self.pending = None;
                    switch = Some(Baud::B9600);
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
    qemu: &mut Connected,
    stop: &AtomicBool,
    quit_after: Option<Duration>,
) -> Result<&'static str> {
    let mut feed = SensorFeed::new();
    let reason = pass_bytes(sensor, client, qemu, stop, quit_after, &mut feed);
    if feed.dropped > 0 {
        eprintln!(
            "host-bridge coprocessor: {} sensor scans dropped for QEMU's slower sensor line",
            feed.dropped
        );
    }
    reason
}

/// [`bridge`]'s loop.
fn pass_bytes(
    sensor: &mut SerialLink,
    client: &mut PtyPort,
    qemu: &mut Connected,
    stop: &AtomicBool,
    quit_after: Option<Duration>,
    feed: &mut SensorFeed,
) -> Result<&'static str> {
    let started = Instant::now();
    let mut watch = BaudWatch::new(false);
    let mut client_watch = BaudWatch::new(true);
    client.set_line_rate(Baud::B9600.bits_per_second());
    let mut buf = [0u8; 4096];
    let mut to_qemu = Vec::new();
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
            client_watch.requests(&buf[..n]);
        }
        let n = qemu.host.receive(&mut buf, Duration::ZERO)?;
        client.write_all(&buf[..n])?;
        if let Some(b) = client_watch.replies(&buf[..n]) {
            client.set_line_rate(b.bits_per_second());
        }
        let n = qemu.sensor.receive(&mut buf, Duration::ZERO)?;
        if n > 0 {
            sensor.send(&buf[..n]).context("sensor port")?;
            watch.requests(&buf[..n]);
        }
        let n = sensor.receive(&mut buf, TICK).context("sensor port")?;
        if n > 0 {
            to_qemu.clear();
            feed.pass(&buf[..n], &mut to_qemu);
            qemu.sensor.send(&to_qemu).context("firmware sensor UART")?;
            if let Some(b) = watch.replies(&to_qemu) {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor_telegram(command: u8, data_len: usize) -> Vec<u8> {
        let mut buf = [0u8; 1024];
        let data = vec![0u8; data_len];
        let n = lms_core::telegram::emit_telegram(
            &mut buf,
            lms_core::telegram::Head::from_sensor(command),
            &data,
            Some(0x10),
        )
        .unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn the_stream_is_passed_as_qemu_takes_it_replies_always() {
        let b0 = sensor_telegram(0xB0, 400);
        let a0 = sensor_telegram(0xA0, 1);
        let mut feed = SensorFeed::new();
        let mut burst: Vec<u8> = b0.repeat(6);
        burst.push(lms_core::telegram::ACK);
        burst.extend(&a0);
        burst.extend(&b0);
        let mut out = Vec::new();
        feed.pass(&burst, &mut out);
        // 410-byte B0s: three fill the 1000-byte queue, the rest are
        // dropped whole; the ACK and the A0 behind them pass.
        let mut want = b0.repeat(3);
        want.push(lms_core::telegram::ACK);
        want.extend(&a0);
        assert_eq!(out, want);
        assert_eq!(feed.dropped, 4);
        // Split anywhere, a telegram passes whole once complete.
        let mut feed = SensorFeed::new();
        let mut out = Vec::new();
        feed.pass(&a0[..4], &mut out);
        assert!(out.is_empty());
        feed.pass(&a0[4..], &mut out);
        assert_eq!(out, a0);
    }
}
