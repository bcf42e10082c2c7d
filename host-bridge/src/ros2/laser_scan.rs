//! `sensor_msgs/msg/LaserScan`, the ROS 2 message of a planar range
//! scan: its types, its CDR encoding (what rosbag2 stores in an MCAP file
//! with message encoding `cdr`) and its `ros2msg` schema text.
//!
//! [`encode`] and [`decode`] go through [`super::cdr`]: a damaged message
//! is an error, never a large allocation or a panic.

use anyhow::Result;
use serde::{Deserialize, Serialize};

/// The schema name of the message, as MCAP and rosbag2 name it.
pub const SCHEMA_NAME: &str = "sensor_msgs/msg/LaserScan";

/// The schema encoding of [`SCHEMA_TEXT`] in an MCAP file.
pub const SCHEMA_ENCODING: &str = "ros2msg";

/// The message encoding of a CDR message in an MCAP file.
pub const MESSAGE_ENCODING: &str = "cdr";

/// The message definition with its dependencies, each after a line of 80
/// `=` and a `MSG: package/Type` line, as ROS 2 tools embed it.
pub const SCHEMA_TEXT: &str = "\
# A planar range scan: beams from angle_min to angle_max, counter-clockwise.
std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities

================================================================================
MSG: std_msgs/Header
# The time of the data and the frame it is expressed in.
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
# Seconds and nanoseconds since the epoch.
int32 sec
uint32 nanosec
";

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds since the epoch.
    pub fn as_nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }

    /// The time `ns` nanoseconds after the epoch (negative: before it).
    pub fn from_nanos(ns: i64) -> Time {
        let sec = ns.div_euclid(1_000_000_000);
        let nanosec = ns.rem_euclid(1_000_000_000) as u32;
        Time {
            sec: sec.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            nanosec,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the scan was taken.
    pub stamp: Time,
    /// The coordinate frame of the scan.
    pub frame_id: String,
}

/// `sensor_msgs/msg/LaserScan`: angles in radians, ranges in metres.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp and frame.
    pub header: Header,
    /// Angle of the first beam (rad).
    pub angle_min: f32,
    /// Angle of the last beam (rad).
    pub angle_max: f32,
    /// Angle between beams (rad).
    pub angle_increment: f32,
    /// Time between beams (s).
    pub time_increment: f32,
    /// Time between scans (s).
    pub scan_time: f32,
    /// Shortest valid range (m).
    pub range_min: f32,
    /// Longest valid range (m).
    pub range_max: f32,
    /// Ranges (m); values outside `range_min ..= range_max` are not echoes.
    pub ranges: Vec<f32>,
    /// Intensities (device units), empty when the device gives none.
    pub intensities: Vec<f32>,
}

/// `scan` as a ROS 2 CDR message (little-endian, with the encapsulation
/// header; [`super::cdr`]).
pub fn encode(scan: &LaserScan) -> Vec<u8> {
    super::cdr::encode(scan)
}

/// Read a ROS 2 CDR `LaserScan` message (little- or big-endian, told by
/// the encapsulation header; [`super::cdr`]). Bytes after the message
/// (padding) are allowed.
pub fn decode(bytes: &[u8]) -> Result<LaserScan> {
    super::cdr::decode(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LaserScan {
        LaserScan {
            header: Header {
                stamp: Time {
                    sec: 1_700_000_000,
                    nanosec: 250_000_000,
                },
                frame_id: "laser".into(),
            },
            angle_min: -1.5707964,
            angle_max: 1.5707964,
            angle_increment: 0.017453292,
            time_increment: 0.0,
            scan_time: 0.2,
            range_min: 0.0,
            range_max: 81.9,
            ranges: vec![1.0, 2.5, f32::INFINITY],
            intensities: vec![],
        }
    }

    #[test]
    fn encode_then_decode_gives_the_scan_back() {
        let s = sample();
        let bytes = encode(&s);
        assert_eq!(bytes[..4], [0, 1, 0, 0]);
        // "laser" + NUL: 6 bytes, padded to 8.
        assert_eq!(bytes.len(), 4 + 8 + 4 + 8 + 28 + 4 + 12 + 4);
        assert_eq!(decode(&bytes).unwrap(), s);
    }

    #[test]
    fn big_endian_is_read_too() {
        let s = sample();
        let le = encode(&s);
        let mut be = vec![0, 0, 0, 0];
        // Every field is a 4-byte word except the frame id's bytes
        // (offsets 12..20 of the body): swap the words, keep those.
        let body = &le[4..];
        for (i, w) in body.chunks(4).enumerate() {
            if i == 3 || i == 4 {
                be.extend_from_slice(w);
            } else {
                be.extend(w.iter().rev());
            }
        }
        assert_eq!(decode(&be).unwrap(), s);
    }

    #[test]
    fn every_cut_of_a_message_is_an_error() {
        let bytes = encode(&sample());
        for n in 0..bytes.len() {
            assert!(decode(&bytes[..n]).is_err(), "cut at {n}");
        }
    }

    #[test]
    fn a_huge_count_is_an_error_not_an_allocation() {
        let mut bytes = encode(&sample());
        let at = 4 + 20 + 28;
        bytes[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let err = decode(&bytes).unwrap_err();
        assert!(
            format!("{err:#}").contains("damaged CDR message"),
            "{err:#}"
        );
    }

    #[test]
    fn time_converts_to_and_from_nanoseconds() {
        let t = Time { sec: 3, nanosec: 5 };
        assert_eq!(t.as_nanos(), 3_000_000_005);
        assert_eq!(Time::from_nanos(3_000_000_005), t);
        assert_eq!(
            Time::from_nanos(-1),
            Time {
                sec: -1,
                nanosec: 999_999_999
            }
        );
    }
}
