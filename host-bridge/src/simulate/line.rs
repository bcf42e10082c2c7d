//! [`PtyLine`]: the pty side of the simulation, between the client on the
//! slave and the emulator: connection state, speed mismatch (dropped bytes
//! one way, noise the other), line faults, counters.

use std::time::Instant;

use anyhow::Result;
use lms_core::device::emulator::{Emulator, ScanSource};
use lms_core::telegram::Baud;

use super::SimulateArgs;
use crate::pty::{Pty, ReadOutcome, Scrambler, WriteOutcome};

/// Bit errors and lost bytes on the line (`--bit-error-rate`,
/// `--drop-rate`): xorshift64*, one draw per bit and per byte.
#[derive(Debug)]
pub(super) struct LineFaults {
    bit_error_rate: f64,
    drop_rate: f64,
    state: u64,
    pub(super) bits_flipped: u64,
    pub(super) bytes_dropped: u64,
}

impl LineFaults {
    fn new(bit_error_rate: f64, drop_rate: f64, seed: u64) -> Self {
        LineFaults {
            bit_error_rate,
            drop_rate,
            // Any non-zero state; splitmix-style spread of small seeds.
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            bits_flipped: 0,
            bytes_dropped: 0,
        }
    }

    pub(super) fn active(&self) -> bool {
        self.bit_error_rate > 0.0 || self.drop_rate > 0.0
    }

    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `bytes` as they arrive at the other end of the line.
    fn apply(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(bytes.len());
        for &b in bytes {
            if self.drop_rate > 0.0 && self.uniform() < self.drop_rate {
                self.bytes_dropped += 1;
                continue;
            }
            let mut b = b;
            if self.bit_error_rate > 0.0 {
                for bit in 0..8 {
                    if self.uniform() < self.bit_error_rate {
                        b ^= 1 << bit;
                        self.bits_flipped += 1;
                    }
                }
            }
            out.push(b);
        }
        out
    }
}

/// Counters for the summary.
#[derive(Debug, Default)]
pub(super) struct Counters {
    pub(super) scans: u64,
    pub(super) written: u64,
    pub(super) no_client: u64,
    pub(super) garbled_out: u64,
    pub(super) dropped_in: u64,
    pub(super) overrun: u64,
    pub(super) connections: u64,
}

/// The pty side of the simulation.
pub(super) struct PtyLine {
    pub(super) pty: Pty,
    pub(super) connected: bool,
    /// The (client, sensor) speeds of the mismatch last reported.
    mismatch: Option<(Option<u32>, Baud)>,
    scrambler: Scrambler,
    /// Faults on the client → sensor and sensor → client directions, each
    /// with its own generator, so that what reaches the client depends only
    /// on the bytes sent, not on how the two directions interleave.
    pub(super) faults: [LineFaults; 2],
    pub(super) counters: Counters,
    verbose: bool,
    clock: Instant,
}

impl PtyLine {
    /// The line on `pty`, with the faults of the options; `clock` is the
    /// run's origin (for the log).
    pub(super) fn new(pty: Pty, args: &SimulateArgs, clock: Instant) -> Self {
        PtyLine {
            pty,
            connected: false,
            mismatch: None,
            scrambler: Scrambler::default(),
            faults: [
                LineFaults::new(args.bit_error_rate, args.drop_rate, args.fault_seed),
                LineFaults::new(
                    args.bit_error_rate,
                    args.drop_rate,
                    args.fault_seed ^ 0xA5A5_A5A5_A5A5_A5A5,
                ),
            ],
            counters: Counters::default(),
            verbose: args.verbose,
            clock,
        }
    }

    pub(super) fn log(&self, msg: impl std::fmt::Display) {
        if self.verbose {
            let t = self.clock.elapsed().as_secs_f64();
            eprintln!("[{t:9.3} s] {msg}");
        }
    }

    /// Update the connection state from the pty.
    pub(super) fn check_connection(&mut self) -> Result<()> {
        let now = self.pty.client_connected()?;
        if now != self.connected {
            self.set_connected(now)?;
        }
        Ok(())
    }

    fn set_connected(&mut self, connected: bool) -> Result<()> {
        self.connected = connected;
        self.mismatch = None;
        if connected {
            self.counters.connections += 1;
            self.log("client connected");
        } else {
            // Nothing left by this client (or written to it as it closed)
            // may reach the next one. (Flushing when the next one connects
            // would race with its first request.)
            self.pty.flush()?;
            self.log("client disconnected");
        }
        Ok(())
    }

    /// `true` if the client's speed is the sensor's; reports changes.
    fn speeds_match(&mut self, sensor: Baud) -> Result<bool> {
        let client = self.pty.client_speed()?;
        if client == Some(sensor.bits_per_second()) {
            if self.mismatch.take().is_some() {
                self.log(format!(
                    "client and sensor both at {} Bd",
                    sensor.bits_per_second()
                ));
            }
            return Ok(true);
        }
        if self.mismatch != Some((client, sensor)) {
            self.mismatch = Some((client, sensor));
            let client =
                client.map_or_else(|| "a non-LMS speed".to_string(), |c| format!("{c} Bd"));
            self.log(format!(
                "client at {client}, sensor at {} Bd: the line carries only noise",
                sensor.bits_per_second()
            ));
        }
        Ok(false)
    }

    /// Read what the client sent and hand it to the sensor, if it can
    /// understand it.
    pub(super) fn receive_from_client<S: ScanSource>(
        &mut self,
        lms: &mut Emulator<S>,
        now_us: u64,
    ) -> Result<()> {
        if !self.connected {
            return Ok(());
        }
        let mut buf = [0u8; 4096];
        loop {
            match self.pty.read(&mut buf)? {
                ReadOutcome::Data(n) => {
                    if self.speeds_match(lms.baud())? {
                        if self.faults[0].active() {
                            let arrived = self.faults[0].apply(&buf[..n]);
                            lms.receive(now_us, &arrived);
                        } else {
                            lms.receive(now_us, &buf[..n]);
                        }
                    } else {
                        self.counters.dropped_in += n as u64;
                    }
                }
                ReadOutcome::Empty => return Ok(()),
                ReadOutcome::Closed => return self.set_connected(false),
            }
        }
    }

    /// Write the sensor's bytes to the client (noise at the wrong speed).
    pub(super) fn send_to_client(&mut self, bytes: &[u8], sensor: Baud) -> Result<()> {
        if !self.connected {
            self.counters.no_client += bytes.len() as u64;
            return Ok(());
        }
        let garbled: Vec<u8>;
        let mut rest = if self.speeds_match(sensor)? {
            if self.faults[1].active() {
                garbled = self.faults[1].apply(bytes);
                &garbled
            } else {
                bytes
            }
        } else {
            garbled = bytes.iter().map(|&b| self.scrambler.byte(b)).collect();
            self.counters.garbled_out += bytes.len() as u64;
            &garbled
        };
        while !rest.is_empty() {
            match self.pty.write(rest)? {
                WriteOutcome::Written(n) => {
                    self.counters.written += n as u64;
                    rest = &rest[n.min(rest.len())..];
                }
                WriteOutcome::Full => {
                    // The client is not reading: a UART would overrun.
                    self.counters.overrun += rest.len() as u64;
                    return Ok(());
                }
                WriteOutcome::Closed => return self.set_connected(false),
            }
        }
        Ok(())
    }
}
