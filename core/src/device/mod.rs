//! The device layer: whole devices built from the wire and pipeline layers,
//! sans I/O (bytes and time in, bytes out).
//!
//! - [`emulator`] — an LMS 2xx: its replies, its scan stream paced at the
//!   line rate, power-on, baud switches. The simulator's sensor, the test
//!   sensor and the co-processor's face towards its own client.
//! - [`client`] — an LMS 2xx client's handshake: a request, its
//!   `ACK`/`NAK`, reply, time-outs and resends, the `B0` stream, the baud
//!   search. The co-processor's bring-up and the host's serial client.
//! - [`coprocessor`] — the sensor co-processor: brings the LMS up
//!   ([`coprocessor::sensor_link`]), runs every scan through the pipeline
//!   and answers its client as an LMS would, with feature telegrams.
pub mod client;
pub mod coprocessor;
pub mod emulator;
