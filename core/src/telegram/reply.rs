//! Replies from the sensor to the host (PROTOCOL.md §2–§3).
//!
//! | payload (without status) | [`Reply`] |
//! |---|---|
//! | `A0 rr` | [`Reply::ModeChanged`] (rr 00 ok, 01 bad password, 02 fault) |
//! | `B0 W values…` | [`Reply::Measured`] |
//! | `B1` + 152 bytes | [`Reply::Status`] |
//! | `BA` + type string | [`Reply::SensorType`] |
//! | `BB ok a_lo a_hi r_lo r_hi` | [`Reply::Variant`] |
//! | `F4` + 34 bytes | [`Reply::Config`] |
//! | `F7 ok` + 34 bytes | [`Reply::ConfigWritten`] |
//! | `90` + 21 bytes | [`Reply::PowerOn`] |
//! | `91` | [`Reply::ResetAck`] |
//! | `92` | [`Reply::UnknownCommand`] |
//! | anything else | [`Reply::Other`] |
//!
//! The status byte that ends every reply is not part of [`Reply`]: read it
//! with [`Telegram::status`] and give it to [`Reply::emit`]. `ACK` and `NAK`
//! are single bytes, not telegrams ([`ACK`](super::ACK),
//! [`NAK`](super::NAK), reported by the [`Framer`](super::Framer)).

use core::fmt;

use super::config::{Config, CONFIG_LEN};
use super::measured::{MeasuredError, MeasuredView, MEASURED_COMMAND};
use super::packet::{buffer_len, emit_telegram, EmitError, Head, Telegram};
use super::status::{SensorStatus, StatusBlock, STATUS_BLOCK_LEN};
use super::{copy_into, le_u16, Direction};
use crate::frame::{FovRes, Variant};

/// Command codes of replies.
pub mod code {
    /// Mode change acknowledged (`A0`).
    pub const MODE_CHANGED: u8 = 0xA0;
    /// Measured values (`B0`).
    pub const MEASURED: u8 = super::MEASURED_COMMAND;
    /// Status block (`B1`).
    pub const STATUS: u8 = 0xB1;
    /// Type string (`BA`).
    pub const SENSOR_TYPE: u8 = 0xBA;
    /// Variant (`BB`).
    pub const VARIANT: u8 = 0xBB;
    /// Configuration (`F4`).
    pub const CONFIG: u8 = 0xF4;
    /// Configuration written (`F7`).
    pub const CONFIG_WRITTEN: u8 = 0xF7;
    /// Power-on telegram (`90`).
    pub const POWER_ON: u8 = 0x90;
    /// Reset acknowledged (`91`).
    pub const RESET_ACK: u8 = 0x91;
    /// Unknown or malformed command (`92`).
    pub const UNKNOWN_COMMAND: u8 = 0x92;
}

/// Bytes of `90` data.
pub const POWER_ON_LEN: usize = 21;

/// Result byte of an `A0` reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModeResult {
    /// `00`: mode changed.
    Ok,
    /// `01`: wrong installation password.
    BadPassword,
    /// `02`: fault, mode not changed.
    Fault,
    /// Any other byte.
    Unknown(u8),
}

impl ModeResult {
    /// The result a byte stands for.
    pub const fn from_byte(b: u8) -> Self {
        match b {
            0 => ModeResult::Ok,
            1 => ModeResult::BadPassword,
            2 => ModeResult::Fault,
            other => ModeResult::Unknown(other),
        }
    }

    /// The byte sent.
    pub const fn byte(self) -> u8 {
        match self {
            ModeResult::Ok => 0,
            ModeResult::BadPassword => 1,
            ModeResult::Fault => 2,
            ModeResult::Unknown(b) => b,
        }
    }
}

/// The data of a `BB` reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VariantReply {
    /// `true` (01) if the variant was accepted; `false` (00) if refused and
    /// the previous one kept.
    pub accepted: bool,
    /// Scan angle in degrees now in use.
    pub angle_deg: u16,
    /// Angular resolution in 1/100 ° now in use.
    pub resolution_centideg: u16,
}

impl VariantReply {
    /// The variant named by angle and resolution, if the sensor has it.
    pub const fn variant(&self) -> Option<Variant> {
        Variant::from_fov_res(FovRes {
            fov_deg: self.angle_deg,
            res_centideg: self.resolution_centideg,
        })
    }
}

/// Why a telegram is not a reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ReplyError {
    /// The telegram was read as host → sensor.
    WrongDirection,
    /// A known reply code with the wrong number of data bytes or an
    /// undefined flag byte.
    Malformed {
        /// The command code.
        command: u8,
        /// Data bytes present (without command and status).
        data_len: usize,
    },
    /// A `B0` whose data is not a scan.
    Measured(MeasuredError),
}

impl fmt::Display for ReplyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplyError::WrongDirection => f.write_str("not a sensor → host telegram"),
            ReplyError::Malformed { command, data_len } => {
                write!(
                    f,
                    "malformed reply {command:#04x} with {data_len} data bytes"
                )
            }
            ReplyError::Measured(e) => write!(f, "B0: {e}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ReplyError {}

impl From<MeasuredError> for ReplyError {
    fn from(e: MeasuredError) -> Self {
        ReplyError::Measured(e)
    }
}

/// A reply from the sensor (see the [module table](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Reply<'a> {
    /// `A0`: answer to a `20` mode change.
    ModeChanged(ModeResult),
    /// `B0`: measured values, read in place.
    Measured(MeasuredView<'a>),
    /// `B1`: the status block.
    Status(StatusBlock),
    /// `BA`: the type string, e.g. `LMS200;30106x;V02.10` (ASCII bytes).
    SensorType(&'a [u8]),
    /// `BB`: answer to a `3B` variant request.
    Variant(VariantReply),
    /// `F4`: the configuration.
    Config(Config),
    /// `F7`: answer to a `77` configuration write.
    ConfigWritten {
        /// `true` (01) if the configuration was taken; `false` (00) if not.
        accepted: bool,
        /// The configuration now in use.
        config: Config,
    },
    /// `90`: the power-on telegram (21 data bytes, kept raw).
    PowerOn([u8; POWER_ON_LEN]),
    /// `91`: reset acknowledged (the power-on `90` follows).
    ResetAck,
    /// `92`: the request was unknown or malformed.
    UnknownCommand,
    /// Any other reply code.
    Other {
        /// The command code.
        command: u8,
        /// The data bytes (without the status byte).
        data: &'a [u8],
    },
}

/// `00` → false, `01` → true, anything else is malformed.
fn flag(b: u8) -> Option<bool> {
    match b {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    }
}

impl<'a> Reply<'a> {
    /// The reply in a sensor → host telegram.
    pub fn parse(telegram: &Telegram<&'a [u8]>) -> Result<Reply<'a>, ReplyError> {
        if telegram.direction() != Direction::SensorToHost {
            return Err(ReplyError::WrongDirection);
        }
        Reply::from_parts(telegram.command(), telegram.into_data())
    }

    /// The reply with this command code and data (status byte excluded).
    pub fn from_parts(command: u8, data: &'a [u8]) -> Result<Reply<'a>, ReplyError> {
        let malformed = ReplyError::Malformed {
            command,
            data_len: data.len(),
        };
        let reply = match (command, data) {
            (code::MODE_CHANGED, [rr]) => Reply::ModeChanged(ModeResult::from_byte(*rr)),
            (code::MEASURED, _) => Reply::Measured(MeasuredView::new(data)?),
            (code::STATUS, _) => Reply::Status(StatusBlock::from_slice(data).ok_or(malformed)?),
            (code::SENSOR_TYPE, _) => Reply::SensorType(data),
            (code::VARIANT, [ok, _, _, _, _]) => Reply::Variant(VariantReply {
                accepted: flag(*ok).ok_or(malformed)?,
                angle_deg: le_u16(data, 1),
                resolution_centideg: le_u16(data, 3),
            }),
            (code::CONFIG, _) => Reply::Config(Config::from_slice(data).ok_or(malformed)?),
            (code::CONFIG_WRITTEN, [ok, config @ ..]) => Reply::ConfigWritten {
                accepted: flag(*ok).ok_or(malformed)?,
                config: Config::from_slice(config).ok_or(malformed)?,
            },
            (code::POWER_ON, _) => {
                Reply::PowerOn(<[u8; POWER_ON_LEN]>::try_from(data).map_err(|_| malformed)?)
            }
            (code::RESET_ACK, []) => Reply::ResetAck,
            (code::UNKNOWN_COMMAND, []) => Reply::UnknownCommand,
            (
                code::MODE_CHANGED
                | code::VARIANT
                | code::CONFIG_WRITTEN
                | code::RESET_ACK
                | code::UNKNOWN_COMMAND,
                _,
            ) => return Err(malformed),
            _ => Reply::Other { command, data },
        };
        Ok(reply)
    }

    /// The command code.
    pub fn command(&self) -> u8 {
        match self {
            Reply::ModeChanged(_) => code::MODE_CHANGED,
            Reply::Measured(_) => code::MEASURED,
            Reply::Status(_) => code::STATUS,
            Reply::SensorType(_) => code::SENSOR_TYPE,
            Reply::Variant(_) => code::VARIANT,
            Reply::Config(_) => code::CONFIG,
            Reply::ConfigWritten { .. } => code::CONFIG_WRITTEN,
            Reply::PowerOn(_) => code::POWER_ON,
            Reply::ResetAck => code::RESET_ACK,
            Reply::UnknownCommand => code::UNKNOWN_COMMAND,
            Reply::Other { command, .. } => *command,
        }
    }

    /// A `BB` reply for a variant.
    pub const fn variant(accepted: bool, v: Variant) -> Reply<'static> {
        Reply::Variant(VariantReply {
            accepted,
            angle_deg: v.fov_deg(),
            resolution_centideg: v.resolution_centideg(),
        })
    }

    /// The data bytes (after the command, before the status), using
    /// `scratch` for the ones this value builds.
    fn data<'s>(&'s self, scratch: &'s mut [u8; CONFIG_LEN + 1]) -> &'s [u8] {
        let n = match self {
            Reply::ModeChanged(r) => {
                scratch[0] = r.byte();
                1
            }
            Reply::Variant(v) => {
                let [a0, a1] = v.angle_deg.to_le_bytes();
                let [r0, r1] = v.resolution_centideg.to_le_bytes();
                copy_into(scratch, &[u8::from(v.accepted), a0, a1, r0, r1]);
                5
            }
            Reply::ConfigWritten { accepted, config } => {
                scratch[0] = u8::from(*accepted);
                copy_into(scratch.get_mut(1..).unwrap_or_default(), config.as_bytes());
                1 + CONFIG_LEN
            }
            Reply::Measured(m) => return m.as_bytes(),
            Reply::Status(s) => return s.as_bytes(),
            Reply::SensorType(t) => return t,
            Reply::Config(c) => return c.as_bytes(),
            Reply::PowerOn(p) => return p,
            Reply::Other { data, .. } => return data,
            Reply::ResetAck | Reply::UnknownCommand => 0,
        };
        scratch.get(..n).unwrap_or_default()
    }

    /// Bytes of the complete telegram.
    pub fn buffer_len(&self) -> usize {
        let mut scratch = [0u8; CONFIG_LEN + 1];
        buffer_len(self.data(&mut scratch).len(), Direction::SensorToHost)
    }

    /// Write the reply as a telegram from the sensor at `address` (0..=0x7F;
    /// `ADDR = 0x80 | address`) with this `status` byte (typically
    /// [`DEFAULT_STATUS`](super::DEFAULT_STATUS)); returns its length.
    pub fn emit(
        &self,
        address: u8,
        status: SensorStatus,
        buf: &mut [u8],
    ) -> Result<usize, EmitError> {
        let mut scratch = [0u8; CONFIG_LEN + 1];
        let data = self.data(&mut scratch);
        emit_telegram(
            buf,
            Head {
                address: Direction::SensorToHost.address_byte(address),
                command: self.command(),
            },
            data,
            Some(status.0),
        )
    }
}

// Keep the two block sizes in step with PROTOCOL.md §2 (LEN 154 and 36/37).
const _: () = assert!(STATUS_BLOCK_LEN + 2 == 154 && CONFIG_LEN + 2 == 36);
