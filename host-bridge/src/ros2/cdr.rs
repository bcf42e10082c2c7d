//! CDR, the ROS 2 message encoding, through `cdr-encoding` (the serde
//! implementation of RustDDS): a message is a 4-byte encapsulation header,
//! `00 01 00 00` for little-endian CDR (what [`encode`] writes) or
//! `00 00 00 00` for big-endian ([`decode`] reads both), then the CDR body,
//! every value aligned on its size from the start of the body.
//!
//! The message types are plain serde structs whose fields follow their
//! `.msg` definitions in order; fixed-size arrays are Rust arrays (no
//! count), sequences are `Vec`s, strings `String`s. A damaged message is an
//! error: the decoder checks every length against the bytes left, and
//! serde reserves at most a bounded capacity before the elements arrive,
//! so a huge count is no large allocation.

use anyhow::{bail, Context, Result};
use byteorder::{BigEndian, LittleEndian};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// The encapsulation header of little-endian CDR.
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// `message` as a ROS 2 CDR message: the little-endian header and body.
pub fn encode<T: Serialize>(message: &T) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    // Writing into a Vec cannot fail, and every sequence of these message
    // types has a known length: the encoder has no error left to give.
    match cdr_encoding::to_vec::<T, LittleEndian>(message) {
        Ok(body) => out.extend_from_slice(&body),
        Err(e) => debug_assert!(false, "CDR encoding failed: {e}"),
    }
    out
}

/// Read a ROS 2 CDR message of type `T` (little- or big-endian, told by
/// the encapsulation header). Bytes after the message (padding) are
/// allowed.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T> {
    let Some((head, body)) = bytes.split_first_chunk::<4>() else {
        bail!(
            "a CDR message of {} bytes: shorter than its 4-byte header",
            bytes.len()
        );
    };
    let decoded = match [head[0], head[1]] {
        [0, 0] => cdr_encoding::from_bytes::<T, BigEndian>(body),
        [0, 1] => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        id => bail!(
            "CDR representation {:02x} {:02x} is not supported (plain CDR: 00 00 or 00 01)",
            id[0],
            id[1]
        ),
    };
    let (message, _used) =
        decoded.with_context(|| format!("a damaged CDR message ({} bytes)", bytes.len()))?;
    Ok(message)
}
