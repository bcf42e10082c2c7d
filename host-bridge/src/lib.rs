//! # host-bridge — the host side of the LMS 2xx feature co-processor
//!
//! Modules in the order the data flows:
//!
//! 1. [`options`] — command-line pipeline parameters, frame selections and
//!    the range-unit value ([`options::UnitArg`]); [`reference`](mod@reference) lists the
//!    parameters, presets and stats counters (`host-bridge params`).
//! 2. Sources of frames: [`carmen`] (recorded CARMEN logs) and
//!    [`synthetic`] (seeded scenes from `lms-scene`, the no-hardware demo);
//!    [`input`] streams the scans of a log or a capture alike.
//! 3. [`extract`] — the `extract` subcommand: run `lms_core::Extractor` per
//!    frame ([`input::InputFrame`]) and write the JSON Lines record
//!    ([`extract::FrameRecord`]) or ROS 2 messages.
//! 4. [`plot`] — figures of one frame (scan with features, `D` per window).
//! 5. The sensor side: [`serial`] (the one serial-line trait
//!    [`serial::Link`], the real port [`serial::SerialLink`], a pty master as
//!    an `embedded-io` port), [`client`] (an LMS 2xx client over a link),
//!    [`emulated_link`] (its in-memory test double: the core's emulator on
//!    a virtual line with fault injection), [`scan`] (the `scan` session)
//!    and [`capture`] (the file format of recorded scans).
//!    [`simulate`] — a simulated LMS 2xx on a pseudo-terminal ([`pty`]);
//!    [`resample`] re-expresses scans for another variant (simulate and
//!    verify), [`stop`] ends either cleanly on a signal, [`warning`] says
//!    what a command worked around.
//! 6. [`verify`] — a co-processor (in a thread, under QEMU, or on serial
//!    ports) checked bit for bit against the std build; [`qemu`] runs the
//!    firmware under QEMU for it and for `coprocessor --qemu`.
//! 7. [`live_view`] — `--foxglove`: the scans and features live in
//!    Foxglove, over its WebSocket protocol.
//!
//! The binary `host-bridge` (src/main.rs) wires these into subcommands.
//! The accuracy evaluation is research tooling in its own package,
//! `lms-lab` (lab/), which uses this library.
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod capture;
pub mod carmen;
pub mod client;
pub mod coprocessor;
pub mod defaults;
pub mod emulated_link;
pub mod extract;
pub mod input;
pub mod live_view;
pub mod options;
pub mod plot;
pub mod pty;
pub mod qemu;
pub mod reference;
pub mod resample;
pub mod ros2;
pub mod scan;
pub mod serial;
pub mod simulate;
pub mod stop;
pub mod synthetic;
pub mod verify;
pub mod warning;
