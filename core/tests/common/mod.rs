//! Shared by the integration tests that run the co-processor in memory.

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
