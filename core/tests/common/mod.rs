//! Shared by the integration tests that run the co-processor in memory
//! (each test uses part of it).
#![allow(dead_code)]

use std::collections::VecDeque;
use std::convert::Infallible;

/// One direction of a serial line in memory: the co-processor reads `rx`
/// and writes `tx`.
#[derive(Default)]
pub struct Port {
    /// Bytes waiting to be read.
    pub rx: VecDeque<u8>,
    /// Bytes written.
    pub tx: Vec<u8>,
}

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}
impl embedded_io::Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, v) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = v;
        }
        Ok(n)
    }
}
impl embedded_io::ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}
impl embedded_io::Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The test room seen from its middle: a wall 3 m ahead, side walls 2 m
/// away, a box 1.5 m ahead between −0.2 and 0.1 rad; the distance (m) along
/// bearing `phi` (rad), `+inf` where nothing is hit.
pub fn room_distance_m(phi: f64) -> f64 {
    let (c, s) = (phi.cos(), phi.sin());
    let mut d = f64::INFINITY;
    if c > 1e-6 {
        d = d.min(3.0 / c);
    }
    if s.abs() > 1e-6 {
        d = d.min(2.0 / s.abs());
    }
    if (-0.2..0.1).contains(&phi) {
        d = d.min(1.5 / c);
    }
    d
}
