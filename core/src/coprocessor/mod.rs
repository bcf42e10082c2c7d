//! The sensor co-processor: an LMS 2xx on one serial line, the robot's
//! computer on the other (issue: firmware under QEMU).
//!
//! - [`sensor_link`] brings the sensor up and takes its `B0` stream.
//! - [`CoProcessor`] runs the pipeline on every scan and sends the host the
//!   scan itself (when the host asked for the stream) followed by the
//!   scan's feature telegrams ([`crate::telegram::features`]).

pub mod sensor_link;
