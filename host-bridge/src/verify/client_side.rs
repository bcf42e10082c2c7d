//! The client's side of a run: the co-processor's host line, its framer
//! and feature assembler, and the replies that came back.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lms_core::telegram::features::{
    Assembled, FeatureAssembler, CMD_CORNERS, CMD_EDGES, CMD_LINES, CMD_SEGMENTS, CMD_SUMMARY,
};
use lms_core::telegram::{Baud, Direction, Event, Framer, Handshake};

use super::checker::Checker;
use super::source::PlaySource;
use crate::serial::Link;

/// A reply seen on the host line (not a scan, not a feature telegram).
pub(super) struct HostReply {
    pub(super) command: u8,
    pub(super) data: Vec<u8>,
}

/// The client's framer for the co-processor's host line (replies and
/// scans, ACK/NAK expected): at the start and after an MCU reset.
pub(super) fn host_framer() -> Framer {
    Framer::new(Direction::SensorToHost, Handshake::Expected)
}

/// The client on the host line: what it reads and how busy the line is.
pub(super) struct ClientSide {
    pub(super) link: Box<dyn Link>,
    /// `--host-baud`, to set up again after an MCU reset.
    pub(super) baud: Baud,
    /// The host line's rate now, and when what came over it would have
    /// left a real line at that rate: the sensor is held meanwhile, so that
    /// the co-processor's host-line budget passes every scan on (a sensor
    /// faster than the host line makes it drop scans, by design:
    /// docs/PROTOCOL.md).
    pub(super) rate: Baud,
    pub(super) line_free: Instant,
    pub(super) framer: Framer,
    pub(super) assembler: FeatureAssembler,
    /// The last `B0` on the host line, waiting for its features.
    pub(super) pending_b0: Option<Vec<u8>>,
    pub(super) replies: VecDeque<HostReply>,
    pub(super) naks: u32,
    /// When the host line last carried anything.
    pub(super) last_rx: Instant,
}

impl ClientSide {
    /// The client on `link`, at 9600 Bd as every LMS line starts.
    pub(super) fn new(link: Box<dyn Link>) -> Self {
        ClientSide {
            link,
            baud: Baud::B9600,
            rate: Baud::B9600,
            line_free: Instant::now(),
            framer: host_framer(),
            assembler: FeatureAssembler::new(),
            pending_b0: None,
            replies: VecDeque::new(),
            naks: 0,
            last_rx: Instant::now(),
        }
    }

    /// What the host line has (waiting up to `wait` for the first bytes):
    /// scans and their features to `checker` (against what `source`
    /// played), replies kept.
    pub(super) fn receive(
        &mut self,
        wait: Duration,
        checker: &mut Checker,
        source: &PlaySource,
    ) -> Result<()> {
        let mut buf = [0u8; 4096];
        let mut wait = wait;
        loop {
            let n = self
                .link
                .receive(&mut buf, wait)
                .with_context(|| format!("host line {}", self.link.name()))?;
            if n == 0 {
                return Ok(());
            }
            self.last_rx = Instant::now();
            let start = self.line_free.max(self.last_rx);
            self.line_free = start + crate::serial::line_time(n, self.rate);
            self.feed(&buf[..n], checker, source)?;
            wait = Duration::ZERO;
        }
    }

    /// Bytes from the co-processor's host line; an error from the checker
    /// ends the run.
    fn feed(&mut self, bytes: &[u8], checker: &mut Checker, source: &PlaySource) -> Result<()> {
        let mut input = bytes;
        loop {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            match fed.event {
                // (`Long`: not from a full-size framer.)
                Some(Event::Ack | Event::Long { .. }) => {}
                Some(Event::Nak) => self.naks += 1,
                Some(Event::Telegram(t)) => match t.command() {
                    0xB0 => {
                        if self.pending_b0.is_some() {
                            checker.without_features();
                        }
                        self.pending_b0 = Some(t.as_bytes().to_vec());
                    }
                    CMD_SUMMARY | CMD_LINES | CMD_CORNERS | CMD_EDGES | CMD_SEGMENTS => {
                        match self.assembler.push(&t) {
                            Ok(Assembled::Complete(summary, features)) => {
                                let b0 = self.pending_b0.take();
                                checker.check(b0.as_deref(), &summary, features, source)?;
                            }
                            Ok(_) => {}
                            Err(e) => checker.problem(e),
                        }
                    }
                    command => self.replies.push_back(HostReply {
                        command,
                        data: t.data().to_vec(),
                    }),
                },
                None if input.is_empty() => return Ok(()),
                None => {}
            }
        }
    }
}
