//! Every CRC vector of PROTOCOL.md §4, parsed and emitted byte for byte,
//! and the other request/reply codes of §2 round-tripped.

use lms_core::telegram::{
    crc16, Baud, Config, Direction, Head, ModeResult, Reply, ReplyError, Request, RequestError,
    SensorStatus, StatusBlock, StatusFields, Telegram, VariantReply, DEFAULT_PASSWORD,
    DEFAULT_STATUS, SENSOR_TYPE_LMS200,
};
use lms_core::{FovRes, Variant};

/// Host → sensor vectors of §4 and the request each one is.
fn request_vectors() -> Vec<(Vec<u8>, Request<'static>)> {
    vec![
        (
            vec![0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12],
            Request::Status,
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x30, 0x01, 0x31, 0x18],
            Request::OneScan,
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08],
            Request::Continuous,
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08],
            Request::OnRequest,
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08],
            Request::SetBaud(Baud::B9600),
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x41, 0x51, 0x08],
            Request::SetBaud(Baud::B19200),
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08],
            Request::SetBaud(Baud::B38400),
        ),
        (
            vec![0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08],
            Request::SetBaud(Baud::B500000),
        ),
        (
            vec![
                0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53,
                0xBE, 0xC5,
            ],
            Request::InstallationMode {
                password: DEFAULT_PASSWORD,
            },
        ),
        (
            vec![
                0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F,
            ],
            Request::SetVariant(FovRes {
                fov_deg: 180,
                res_centideg: 50,
            }),
        ),
        (
            vec![
                0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72,
            ],
            Request::SetVariant(FovRes {
                fov_deg: 100,
                res_centideg: 25,
            }),
        ),
        (
            vec![0x02, 0x00, 0x01, 0x00, 0x74, 0x50, 0x12],
            Request::ReadConfig,
        ),
        (
            vec![0x02, 0x00, 0x01, 0x00, 0x3A, 0x1E, 0x12],
            Request::SensorType,
        ),
        (
            vec![0x02, 0x00, 0x01, 0x00, 0x10, 0x34, 0x12],
            Request::Reset,
        ),
    ]
}

/// Sensor → host vectors of §4: (bytes, sensor address, reply).
fn reply_vectors() -> Vec<(Vec<u8>, u8, Reply<'static>)> {
    vec![
        (
            vec![0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A],
            0,
            Reply::ModeChanged(ModeResult::Ok),
        ),
        (
            vec![0x02, 0x81, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x36, 0x1A],
            1,
            Reply::ModeChanged(ModeResult::Ok),
        ),
        (
            vec![
                0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
            ],
            0,
            Reply::Variant(VariantReply {
                accepted: true,
                angle_deg: 180,
                resolution_centideg: 50,
            }),
        ),
        (
            vec![0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33],
            0,
            Reply::UnknownCommand,
        ),
    ]
}

#[test]
fn telegram_vectors_crc() {
    let all = request_vectors()
        .into_iter()
        .map(|(b, _)| b)
        .chain(reply_vectors().into_iter().map(|(b, _, _)| b));
    let mut n = 0;
    for bytes in all {
        let (body, crc) = bytes.split_at(bytes.len() - 2);
        assert_eq!(&crc16(body).to_le_bytes(), crc, "{bytes:02X?}");
        n += 1;
    }
    assert_eq!(n, 18);
}

#[test]
fn telegram_vectors_requests_parse() {
    for (bytes, expected) in request_vectors() {
        let t = Telegram::new_checked(&bytes[..], Direction::HostToSensor).unwrap();
        assert_eq!(t.address(), 0x00);
        assert_eq!(usize::from(t.length()) + 6, bytes.len());
        assert_eq!(t.status(), None);
        assert_eq!(Request::parse(&t), Ok(expected), "{bytes:02X?}");
    }
}

#[test]
fn telegram_vectors_requests_emit() {
    for (bytes, request) in request_vectors() {
        let mut buf = [0xAAu8; 32];
        let n = request.emit(0x00, &mut buf).unwrap();
        assert_eq!(&buf[..n], &bytes[..], "{request:?}");
        assert_eq!(request.buffer_len(), bytes.len());
        assert!(buf[n..].iter().all(|&b| b == 0xAA));
        // One byte short: refused with the size needed.
        let mut small = vec![0u8; bytes.len() - 1];
        assert_eq!(
            request.emit(0x00, &mut small),
            Err(lms_core::telegram::EmitError::BufferTooSmall {
                needed: bytes.len()
            })
        );
    }
}

#[test]
fn telegram_vectors_replies_parse() {
    for (bytes, address, expected) in reply_vectors() {
        let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
        assert_eq!(t.address(), 0x80 | address);
        assert_eq!(t.sensor_address(), address);
        assert_eq!(t.status(), Some(0x10));
        assert_eq!(Reply::parse(&t), Ok(expected), "{bytes:02X?}");
    }
}

#[test]
fn telegram_vectors_replies_emit() {
    for (bytes, address, reply) in reply_vectors() {
        let mut buf = [0u8; 32];
        let n = reply
            .emit(address, SensorStatus(DEFAULT_STATUS), &mut buf)
            .unwrap();
        assert_eq!(&buf[..n], &bytes[..], "{reply:?}");
        assert_eq!(reply.buffer_len(), bytes.len());
    }
}

#[test]
fn telegram_vectors_direction_is_checked() {
    let (bytes, _) = &request_vectors()[0];
    let t = Telegram::new_checked(&bytes[..], Direction::HostToSensor).unwrap();
    assert_eq!(Reply::parse(&t), Err(ReplyError::WrongDirection));
    let (bytes, _, _) = &reply_vectors()[0];
    let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
    assert_eq!(Request::parse(&t), Err(RequestError::WrongDirection));
}

/// Emit, check the telegram, parse it back.
fn reply_round_trip(reply: Reply<'_>, expected_len: usize) -> Vec<u8> {
    let mut buf = vec![0u8; expected_len + 4];
    let n = reply.emit(0x00, SensorStatus(0x10), &mut buf).unwrap();
    assert_eq!(n, expected_len, "{reply:?}");
    buf.truncate(n);
    let t = Telegram::new_checked(&buf[..], Direction::SensorToHost).unwrap();
    assert_eq!(usize::from(t.length()), expected_len - 6);
    assert_eq!(Reply::parse(&t), Ok(reply));
    buf
}

#[test]
fn telegram_replies_round_trip() {
    // B1: LEN 154, 160 bytes.
    let block = StatusBlock::from_fields(&StatusFields {
        operating_mode: 0x24,
        scan_angle_deg: 180,
        resolution_centideg: 50,
        baud: Baud::B38400,
        address: 0,
        units_code: 1,
    });
    let b = reply_round_trip(Reply::Status(block), 160);
    assert_eq!(&b[..5], &[0x02, 0x80, 0x9A, 0x00, 0xB1]);
    // Payload index p is telegram byte 4 + p.
    assert_eq!(b[4 + 8], 0x24);
    assert_eq!(&b[4 + 107..=4 + 110], &[180, 0, 50, 0]);
    assert_eq!(&b[4 + 116..=4 + 117], &[25, 0]);
    assert_eq!(b[4 + 122], 1);
    assert_eq!(b[4 + 153], 0x10);

    // BA: the LMS 200 type string.
    let b = reply_round_trip(Reply::SensorType(SENSOR_TYPE_LMS200.as_bytes()), 28);
    assert_eq!(&b[5..25], b"LMS200;30106x;V02.10");

    // F4: LEN 36.
    let mut config = Config::default();
    config.set_measuring_mode(0x0D);
    config.set_units_code(1);
    let b = reply_round_trip(Reply::Config(config), 42);
    assert_eq!(&b[..5], &[0x02, 0x80, 0x24, 0x00, 0xF4]);
    assert_eq!(&b[5..12], &[0, 0, 0, 0, 0, 0x0D, 0x01]);

    // F7: LEN 37, `01` then the block.
    let b = reply_round_trip(
        Reply::ConfigWritten {
            accepted: true,
            config,
        },
        43,
    );
    assert_eq!(&b[..7], &[0x02, 0x80, 0x25, 0x00, 0xF7, 0x01, 0x00]);

    // 90 power-on: 21 data bytes, LEN 23. 91 reset: LEN 2.
    let mut power_on = [0u8; 21];
    power_on[..6].copy_from_slice(b"LMS200");
    reply_round_trip(Reply::PowerOn(power_on), 29);
    let b = reply_round_trip(Reply::ResetAck, 8);
    assert_eq!(&b[..6], &[0x02, 0x80, 0x02, 0x00, 0x91, 0x10]);

    // A0 with a bad password, BB refused, an unknown code kept raw.
    reply_round_trip(Reply::ModeChanged(ModeResult::BadPassword), 9);
    reply_round_trip(Reply::variant(false, Variant::Fov100Res25), 13);
    reply_round_trip(
        Reply::Other {
            command: 0xC5,
            data: &[1, 2, 3],
        },
        11,
    );
}

#[test]
fn telegram_replies_malformed() {
    let cases: [(u8, &[u8]); 6] = [
        (0xA0, &[]),
        (0xA0, &[0, 0]),
        (0xBB, &[0x02, 0xB4, 0, 0x32, 0]),
        (0xB1, &[0; 151]),
        (0xF7, &[0; 34]),
        (0x92, &[0]),
    ];
    for (command, data) in cases {
        assert_eq!(
            Reply::from_parts(command, data),
            Err(ReplyError::Malformed {
                command,
                data_len: data.len()
            })
        );
    }
}

#[test]
fn telegram_requests_round_trip_and_unknown() {
    let mut config = Config::default();
    config.set_blanking(10);
    config.set_units_code(1);
    let mut buf = [0u8; 64];
    for request in [
        Request::WriteConfig(config),
        Request::set_variant(Variant::Fov100Res50),
        Request::Unknown {
            command: 0x20,
            data: &[0x2A],
        },
    ] {
        let n = request.emit(0x05, &mut buf).unwrap();
        assert_eq!(n, request.buffer_len());
        let t = Telegram::new_checked(&buf[..n], Direction::HostToSensor).unwrap();
        assert_eq!(t.address(), 0x05);
        assert_eq!(Request::parse(&t), Ok(request));
    }
    // `77` + 34 bytes: LEN 35, 41 bytes.
    assert_eq!(Request::WriteConfig(config).buffer_len(), 41);
    assert_eq!(Request::WriteConfig(config).reply_command(), 0xF7);

    // Malformed or unknown commands all parse as Unknown (a sensor answers 92).
    let cases: [(u8, &[u8]); 9] = [
        (0x20, &[0x2A]),
        (0x20, &[]),
        (0x20, &[0x00, b'S', b'I', b'C', b'K']),
        (0x20, &[0x24, 0x00]),
        (0x30, &[0x02]),
        (0x31, &[0x00]),
        (0x3B, &[0xB4, 0x00, 0x32]),
        (0x77, &[0; 33]),
        (0x55, &[]),
    ];
    for (command, data) in cases {
        assert_eq!(
            Request::from_parts(command, data),
            Request::Unknown { command, data }
        );
    }
    assert_eq!(
        Request::from_parts(0x3B, &[0xB4, 0x00, 0x32, 0x00]).variant(),
        Some(Variant::Fov180Res50)
    );
    assert_eq!(
        Request::from_parts(0x3B, &[0xB4, 0x00, 0x19, 0x00]).variant(),
        None
    );
}

#[test]
fn telegram_baud_words() {
    let expected = [
        (Baud::B9600, 0x42, 103),
        (Baud::B19200, 0x41, 51),
        (Baud::B38400, 0x40, 25),
        (Baud::B500000, 0x48, 1),
    ];
    for (baud, mode, word) in expected {
        assert_eq!(baud.mode_byte(), mode);
        assert_eq!(baud.status_word(), word);
        assert_eq!(Baud::from_mode_byte(mode), Some(baud));
        assert_eq!(Baud::from_status_word(word), Some(baud));
        assert_eq!(
            Baud::from_bits_per_second(baud.bits_per_second()),
            Some(baud)
        );
        assert_eq!(u32::from(word), 1_000_000 / baud.bits_per_second() - 1);
    }
}

/// The value modes (docs/PROTOCOL.md §2d): requests and stream telegrams.
#[test]
fn value_mode_telegrams_are_byte_exact() {
    use lms_core::device::emulator::ValueMode;
    use lms_core::telegram::emit_telegram;
    let hex = |s: &str| -> Vec<u8> {
        s.split(' ')
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect()
    };
    let mut buf = [0u8; 64];
    for (data, text, mode) in [
        (
            &[0x26, 5][..],
            "02 00 03 00 20 26 05 79 3E",
            ValueMode::Mean { samples: 5 },
        ),
        (
            &[0x27, 1, 0, 22, 0][..],
            "02 00 06 00 20 27 01 00 16 00 54 AB",
            ValueMode::Subrange { first: 1, last: 22 },
        ),
        (
            &[0x28, 3, 10, 0, 20, 0][..],
            "02 00 07 00 20 28 03 0A 00 14 00 4D A6",
            ValueMode::MeanSubrange {
                samples: 3,
                first: 10,
                last: 20,
            },
        ),
    ] {
        let n = emit_telegram(&mut buf, Head::to_sensor(0x20), data, None).unwrap();
        assert_eq!(buf[..n], hex(text)[..]);
        assert_eq!(ValueMode::parse(0x20, data), Some(mode));
    }
    for (mode, text) in [
        (
            ValueMode::Mean { samples: 5 },
            "02 80 09 00 B6 05 02 00 64 00 C8 00 10 B4 08",
        ),
        (
            ValueMode::Subrange { first: 1, last: 2 },
            "02 80 0C 00 B7 01 00 02 00 02 00 64 00 C8 00 10 60 A4",
        ),
        (
            ValueMode::MeanSubrange {
                samples: 5,
                first: 1,
                last: 2,
            },
            "02 80 0D 00 BF 05 01 00 02 00 02 00 64 00 C8 00 10 E2 B5",
        ),
    ] {
        let n = mode
            .emit(
                0,
                SensorStatus(0x10),
                lms_core::Unit::Centimetre,
                &[100, 200],
                &mut buf,
            )
            .unwrap();
        assert_eq!(buf[..n], hex(text)[..], "{mode:?}");
    }
}
