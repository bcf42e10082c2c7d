//! # host-bridge — the host side of the LMS 2xx feature co-processor
//!
//! Modules in the order the data flows:
//!
//! 1. [`options`] — command-line pipeline parameters and frame selections.
//! 2. Sources of frames: [`carmen`] (recorded CARMEN logs) and
//!    [`synthetic`] (seeded scenes from `lms-scene`, the no-hardware demo).
//! 3. [`extract`] — run `lms_core::Extractor` per frame and build the JSON
//!    Lines record ([`extract::FrameRecord`]).
//! 4. [`plot`] — figures of one frame (scan with features, `D` per window).
//!
//! The binary `host-bridge` (src/main.rs) wires these into subcommands.
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod carmen;
pub mod extract;
pub mod options;
pub mod plot;
pub mod synthetic;
