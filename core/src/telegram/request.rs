//! Requests from the host to the sensor (PROTOCOL.md §2).
//!
//! | payload | [`Request`] |
//! |---|---|
//! | `20 00` + 8-byte password | [`Request::InstallationMode`] |
//! | `20 24` | [`Request::Continuous`] |
//! | `20 25` | [`Request::OnRequest`] |
//! | `20 40` / `41` / `42` / `48` | [`Request::SetBaud`] 38400 / 19200 / 9600 / 500000 |
//! | `30 01` | [`Request::OneScan`] |
//! | `31` | [`Request::Status`] |
//! | `3A` | [`Request::SensorType`] |
//! | `3B a_lo a_hi r_lo r_hi` | [`Request::SetVariant`] |
//! | `74` | [`Request::ReadConfig`] |
//! | `77` + 34 bytes | [`Request::WriteConfig`] |
//! | `10` | [`Request::Reset`] |
//! | anything else | [`Request::Unknown`] (a sensor answers `92`) |
//!
//! A known command with the wrong number of data bytes (or an unknown mode
//! byte after `20`) is malformed and parses as [`Request::Unknown`] too.

use core::fmt;

use super::config::{Config, CONFIG_LEN};
use super::packet::{buffer_len, emit_telegram, EmitError, Head, Telegram};
use super::{copy_into, le_u16, Direction, REPLY_COMMAND_BIT};
use crate::frame::{FovRes, Variant};

/// Command codes of requests.
pub mod code {
    /// Change operating mode (`20`).
    pub const MODE: u8 = 0x20;
    /// Measured values (`30`; `30 01` = one complete scan).
    pub const MEASURED: u8 = 0x30;
    /// Status (`31`).
    pub const STATUS: u8 = 0x31;
    /// Sensor type (`3A`).
    pub const SENSOR_TYPE: u8 = 0x3A;
    /// Variant (`3B`).
    pub const VARIANT: u8 = 0x3B;
    /// Read configuration (`74`).
    pub const READ_CONFIG: u8 = 0x74;
    /// Write configuration (`77`).
    pub const WRITE_CONFIG: u8 = 0x77;
    /// Reset (`10`).
    pub const RESET: u8 = 0x10;

    /// Mode byte after `20`: installation mode (+ 8-byte password).
    pub const MODE_INSTALLATION: u8 = 0x00;
    /// Mode byte after `20`: continuous output of all values.
    pub const MODE_CONTINUOUS: u8 = 0x24;
    /// Mode byte after `20`: values on request only (power-on default).
    pub const MODE_ON_REQUEST: u8 = 0x25;
    /// Data byte after `30`: one complete scan.
    pub const ONE_SCAN: u8 = 0x01;
}

/// The serial speeds an LMS 2xx switches to with `20 4x`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Baud {
    /// 9600 Bd (`20 42`; the power-on rate).
    B9600,
    /// 19200 Bd (`20 41`).
    B19200,
    /// 38400 Bd (`20 40`).
    B38400,
    /// 500000 Bd (`20 48`).
    B500000,
}

impl Baud {
    /// All four rates, slowest first.
    pub const ALL: [Baud; 4] = [Baud::B9600, Baud::B19200, Baud::B38400, Baud::B500000];

    /// Bits per second.
    pub const fn bits_per_second(self) -> u32 {
        match self {
            Baud::B9600 => 9600,
            Baud::B19200 => 19200,
            Baud::B38400 => 38400,
            Baud::B500000 => 500_000,
        }
    }

    /// The rate with this many bits per second, if the sensor has it.
    pub const fn from_bits_per_second(bps: u32) -> Option<Self> {
        match bps {
            9600 => Some(Baud::B9600),
            19200 => Some(Baud::B19200),
            38400 => Some(Baud::B38400),
            500_000 => Some(Baud::B500000),
            _ => None,
        }
    }

    /// The mode byte after `20` that selects this rate.
    pub const fn mode_byte(self) -> u8 {
        match self {
            Baud::B9600 => 0x42,
            Baud::B19200 => 0x41,
            Baud::B38400 => 0x40,
            Baud::B500000 => 0x48,
        }
    }

    /// The rate a mode byte selects.
    pub const fn from_mode_byte(b: u8) -> Option<Self> {
        match b {
            0x42 => Some(Baud::B9600),
            0x41 => Some(Baud::B19200),
            0x40 => Some(Baud::B38400),
            0x48 => Some(Baud::B500000),
            _ => None,
        }
    }

    /// The `B1` baud word, 10⁶ / baud − 1 (integer division): 103, 51, 25, 1.
    pub const fn status_word(self) -> u16 {
        (1_000_000 / self.bits_per_second() - 1) as u16
    }

    /// The rate a `B1` baud word stands for.
    pub const fn from_status_word(w: u16) -> Option<Self> {
        match w {
            103 => Some(Baud::B9600),
            51 => Some(Baud::B19200),
            25 => Some(Baud::B38400),
            1 => Some(Baud::B500000),
            _ => None,
        }
    }
}

/// Why a telegram is not a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RequestError {
    /// The telegram was read as sensor → host.
    WrongDirection,
}

impl fmt::Display for RequestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RequestError::WrongDirection => f.write_str("not a host → sensor telegram"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for RequestError {}

/// A request from the host (see the [module table](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Request<'a> {
    /// `20 00` + password: enter installation mode.
    InstallationMode {
        /// The 8-byte password ([`DEFAULT_PASSWORD`](super::DEFAULT_PASSWORD)).
        password: [u8; 8],
    },
    /// `20 24`: continuous output of all values.
    Continuous,
    /// `20 25`: values on request only (stops the stream).
    OnRequest,
    /// `20 40`/`41`/`42`/`48`: switch the serial speed after the reply.
    SetBaud(Baud),
    /// `30 01`: send one complete scan.
    OneScan,
    /// `31`: send the status block.
    Status,
    /// `3A`: send the type string.
    SensorType,
    /// `3B`: set the variant.
    SetVariant(FovRes),
    /// `74`: read the configuration.
    ReadConfig,
    /// `77` + 34 bytes: write the configuration (installation mode only).
    WriteConfig(Config),
    /// `10`: reset.
    Reset,
    /// An unknown or malformed command (a sensor answers `92`).
    Unknown {
        /// The command code.
        command: u8,
        /// The data bytes after it.
        data: &'a [u8],
    },
}

impl<'a> Request<'a> {
    /// The request in a host → sensor telegram.
    pub fn parse(telegram: &Telegram<&'a [u8]>) -> Result<Request<'a>, RequestError> {
        if telegram.direction() != Direction::HostToSensor {
            return Err(RequestError::WrongDirection);
        }
        Ok(Request::from_parts(
            telegram.command(),
            telegram.into_data(),
        ))
    }

    /// The request with this command code and data (never fails: anything
    /// not in the table is [`Request::Unknown`]).
    pub fn from_parts(command: u8, data: &'a [u8]) -> Request<'a> {
        let unknown = Request::Unknown { command, data };
        match (command, data) {
            (code::MODE, [code::MODE_INSTALLATION, password @ ..]) => {
                match <[u8; 8]>::try_from(password) {
                    Ok(password) => Request::InstallationMode { password },
                    Err(_) => unknown,
                }
            }
            (code::MODE, [code::MODE_CONTINUOUS]) => Request::Continuous,
            (code::MODE, [code::MODE_ON_REQUEST]) => Request::OnRequest,
            (code::MODE, [mode]) => match Baud::from_mode_byte(*mode) {
                Some(b) => Request::SetBaud(b),
                None => unknown,
            },
            (code::MEASURED, [code::ONE_SCAN]) => Request::OneScan,
            (code::STATUS, []) => Request::Status,
            (code::SENSOR_TYPE, []) => Request::SensorType,
            (code::VARIANT, [_, _, _, _]) => Request::SetVariant(FovRes {
                fov_deg: le_u16(data, 0),
                res_centideg: le_u16(data, 2),
            }),
            (code::READ_CONFIG, []) => Request::ReadConfig,
            (code::WRITE_CONFIG, _) => match Config::from_slice(data) {
                Some(c) => Request::WriteConfig(c),
                None => unknown,
            },
            (code::RESET, []) => Request::Reset,
            _ => unknown,
        }
    }

    /// A `3B` request for a variant.
    pub const fn set_variant(v: Variant) -> Request<'static> {
        Request::SetVariant(FovRes {
            fov_deg: v.fov_deg(),
            res_centideg: v.resolution_centideg(),
        })
    }

    /// The command code.
    pub fn command(&self) -> u8 {
        match self {
            Request::InstallationMode { .. }
            | Request::Continuous
            | Request::OnRequest
            | Request::SetBaud(_) => code::MODE,
            Request::OneScan => code::MEASURED,
            Request::Status => code::STATUS,
            Request::SensorType => code::SENSOR_TYPE,
            Request::SetVariant(_) => code::VARIANT,
            Request::ReadConfig => code::READ_CONFIG,
            Request::WriteConfig(_) => code::WRITE_CONFIG,
            Request::Reset => code::RESET,
            Request::Unknown { command, .. } => *command,
        }
    }

    /// The command code of the sensor's reply (`command | 0x80`).
    pub fn reply_command(&self) -> u8 {
        self.command() | REPLY_COMMAND_BIT
    }

    /// For a `3B` request: the variant it asks for, if the sensor has it.
    pub fn variant(&self) -> Option<Variant> {
        match *self {
            Request::SetVariant(asked) => Variant::from_fov_res(asked),
            _ => None,
        }
    }

    /// The data bytes (after the command), using `scratch` for the ones this
    /// value builds.
    fn data<'s>(&'s self, scratch: &'s mut [u8; CONFIG_LEN]) -> &'s [u8] {
        let n = match self {
            Request::InstallationMode { password } => {
                scratch[0] = code::MODE_INSTALLATION;
                copy_into(scratch.get_mut(1..).unwrap_or_default(), password);
                1 + password.len()
            }
            Request::Continuous => {
                scratch[0] = code::MODE_CONTINUOUS;
                1
            }
            Request::OnRequest => {
                scratch[0] = code::MODE_ON_REQUEST;
                1
            }
            Request::SetBaud(b) => {
                scratch[0] = b.mode_byte();
                1
            }
            Request::OneScan => {
                scratch[0] = code::ONE_SCAN;
                1
            }
            Request::SetVariant(FovRes {
                fov_deg,
                res_centideg,
            }) => {
                let [a0, a1] = fov_deg.to_le_bytes();
                let [r0, r1] = res_centideg.to_le_bytes();
                copy_into(scratch, &[a0, a1, r0, r1]);
                4
            }
            Request::WriteConfig(c) => return c.as_bytes(),
            Request::Unknown { data, .. } => return data,
            Request::Status | Request::SensorType | Request::ReadConfig | Request::Reset => 0,
        };
        scratch.get(..n).unwrap_or_default()
    }

    /// Bytes of the complete telegram.
    pub fn buffer_len(&self) -> usize {
        let mut scratch = [0u8; CONFIG_LEN];
        buffer_len(self.data(&mut scratch).len(), Direction::HostToSensor)
    }

    /// Write the request as a telegram to the sensor at `address` (raw
    /// `ADDR` byte, default 0); returns the telegram's length.
    pub fn emit(&self, address: u8, buf: &mut [u8]) -> Result<usize, EmitError> {
        let mut scratch = [0u8; CONFIG_LEN];
        let data = self.data(&mut scratch);
        emit_telegram(
            buf,
            Head {
                address,
                command: self.command(),
            },
            data,
            None,
        )
    }
}
