//! The co-processor on a computer: the core's [`CoProcessor`] on a sensor
//! port whose bytes carry their arrival times ([`Arrivals`]), on this
//! computer's monotonic clock (µs since start). `host-bridge coprocessor`
//! and `verify --host` both run it.

use std::fmt::Display;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use embedded_io::{Read, ReadReady, Write};
use lms_core::device::coprocessor::{CoProcessor, PollError, PollOutcome, SensorSetup, WriteRoom};
use lms_core::ValidParams;

use crate::serial::Arrivals;

/// A [`CoProcessor`] started on `sensor`, its clock, and one way to poll it.
pub struct PcCoProcessor<P> {
    cop: Box<CoProcessor>,
    sensor: Arrivals<P>,
    started: Instant,
}

impl<P: Read + ReadReady + Write> PcCoProcessor<P>
where
    P::Error: Display,
{
    /// The co-processor with `params`, bringing the sensor on `sensor` up
    /// with `setup`, its face powered on now.
    pub fn start(params: ValidParams, setup: SensorSetup, sensor: P) -> Self {
        let mut pc = PcCoProcessor {
            cop: Box::new(CoProcessor::new(params, setup)),
            sensor: Arrivals::new(sensor),
            started: Instant::now(),
        };
        pc.cop.start(pc.now_us());
        pc
    }

    /// The co-processor's clock: µs since [`PcCoProcessor::start`].
    pub fn now_us(&self) -> u64 {
        micros_since(self.started)
    }

    /// Time since [`PcCoProcessor::start`].
    pub fn elapsed(&self) -> Duration {
        self.started.elapsed()
    }

    /// Poll the co-processor with the sensor bytes found waiting, each at
    /// its arrival time ([`Arrivals::poll`]), and the client line `host`.
    /// A failed port is an error naming it: `sensor port: …` or
    /// `client line: …`.
    pub fn poll<H>(&mut self, host: &mut H) -> Result<PollOutcome>
    where
        H: Read + ReadReady + WriteRoom,
        H::Error: Display,
    {
        let started = self.started;
        self.sensor
            .poll(&mut self.cop, host, || micros_since(started))
            .map_err(|e| match e {
                PollError::Sensor(e) => anyhow!("sensor port: {e}"),
                PollError::Host(e) => anyhow!("client line: {e}"),
            })
    }

    /// The co-processor.
    pub fn cop(&self) -> &CoProcessor {
        &self.cop
    }

    /// The sensor port.
    pub fn sensor_mut(&mut self) -> &mut P {
        self.sensor.port_mut()
    }

    /// The co-processor and the sensor port, together (a port that follows
    /// the co-processor's state).
    pub fn parts(&mut self) -> (&CoProcessor, &mut P) {
        (&self.cop, self.sensor.port_mut())
    }
}

/// µs since `start` (saturating).
fn micros_since(start: Instant) -> u64 {
    u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX)
}
