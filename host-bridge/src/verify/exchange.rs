//! The client's requests on the host line: sent until their reply comes.

use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use lms_core::telegram::features::{
    Counters, CMD_COUNTERS, CMD_FEATURES, REQ_COUNTERS, REQ_FEATURES,
};
use lms_core::telegram::{emit_telegram, Head, Request};

use super::session::Session;
use super::RETRY;
use crate::serial::TICK;

impl Session {
    /// Send `request` on the host line until the reply `reply` comes (every
    /// [`RETRY`], until `deadline`); returns the reply's data.
    fn exchange(
        &mut self,
        request: &[u8],
        reply: u8,
        what: &str,
        deadline: Instant,
    ) -> Result<Vec<u8>> {
        let mut attempts = 0u32;
        loop {
            if Instant::now() >= deadline {
                bail!(
                    "no answer to {what} on the host line {} ({attempts} attempts)",
                    self.client.link.name()
                );
            }
            self.client.replies.clear();
            self.client.naks = 0;
            self.client
                .link
                .send(request)
                .with_context(|| format!("host line {}", self.client.link.name()))?;
            attempts += 1;
            self.log(format!("client: {what} (attempt {attempts})"));
            let sent = Instant::now();
            while sent.elapsed() < RETRY && Instant::now() < deadline && self.client.naks == 0 {
                self.pump(TICK)?;
                if let Some(i) = self.client.replies.iter().position(|r| r.command == reply) {
                    let data = self
                        .client
                        .replies
                        .remove(i)
                        .map(|r| r.data)
                        .unwrap_or_default();
                    return Ok(data);
                }
                if self.client.replies.iter().any(|r| r.command == 0x92) {
                    bail!(
                        "{what}: the host line answered 92 (unknown command){}",
                        if matches!(request.get(4), Some(&(REQ_COUNTERS | REQ_FEATURES))) {
                            ": not the co-processor (the firmware's stand-in, or an LMS?)"
                        } else {
                            ""
                        }
                    );
                }
            }
        }
    }

    /// A mode request (`20 xx`): expects `A0 00`.
    pub(super) fn mode(
        &mut self,
        request: Request<'_>,
        what: &str,
        deadline: Instant,
    ) -> Result<()> {
        let mut buf = [0u8; 64];
        let n = request.emit(0, &mut buf)?;
        let data = self.exchange(&buf[..n], 0xA0, what, deadline)?;
        ensure!(
            data.first() == Some(&0),
            "{what}: the co-processor answered A0 {:02X?}",
            data
        );
        Ok(())
    }

    /// The co-processor's counters (`55` → `D5`).
    pub(super) fn counters(&mut self, deadline: Instant) -> Result<Counters> {
        let mut buf = [0u8; 16];
        let n = emit_telegram(&mut buf, Head::to_sensor(REQ_COUNTERS), &[], None)?;
        let data = self.exchange(&buf[..n], CMD_COUNTERS, "55 (counters)", deadline)?;
        Counters::decode(&data).context("malformed D5 counters")
    }

    /// Switch the co-processor's feature telegrams on (`56 01` → `D6 01`):
    /// off by default, so that the host line carries only what an LMS would.
    pub(super) fn features_on(&mut self, deadline: Instant) -> Result<()> {
        let mut buf = [0u8; 16];
        let n = emit_telegram(&mut buf, Head::to_sensor(REQ_FEATURES), &[1], None)?;
        let data = self.exchange(&buf[..n], CMD_FEATURES, "56 01 (features on)", deadline)?;
        ensure!(
            data == [1],
            "56 01: the co-processor answered D6 {:02X?}",
            data
        );
        Ok(())
    }

    /// The firmware's console report (`s`), then `q`.
    pub(super) fn firmware_report(&mut self) -> Option<String> {
        let text = self.console_report();
        if let Some(c) = self.console.as_mut() {
            let _ = c.send(b"q");
        }
        text
    }

    /// The firmware's console report (`s`): its one line, if it has a
    /// console and answers within 2 s.
    pub(super) fn console_report(&mut self) -> Option<String> {
        self.console.as_ref()?;
        self.console_text.clear();
        let until = Instant::now() + Duration::from_secs(2);
        if let Some(c) = self.console.as_mut() {
            c.send(b"s").ok()?;
        }
        while !self.console_text.contains(&b'\n') && Instant::now() < until {
            if self.pump(TICK).is_err() {
                break;
            }
        }
        let text = String::from_utf8_lossy(&self.console_text)
            .trim()
            .to_string();
        (!text.is_empty()).then_some(text)
    }
}
