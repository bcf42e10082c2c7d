//! The telegram layer on arbitrary bytes: `Telegram` views (checked and
//! unchecked, both directions), `Request::parse` / `from_parts`,
//! `Reply::parse` / `from_parts`, `MeasuredView`, `MeasuredValues`, the
//! status and configuration blocks, and `emit_telegram`.
//!
//! Checks: no panic; what parses re-emits to bytes that parse to the same
//! value (requests, replies), and a telegram emitted around any payload
//! checks and gives that payload back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::telegram::{
    emit_telegram, Direction, Head, MeasuredValues, MeasuredView, RangeBits, Reply, Request,
    SensorStatus, Telegram, MAX_LEN, MAX_TELEGRAM_LEN,
};

fuzz_target!(|data: &[u8]| {
    // 1. The bytes as a telegram, both directions.
    for direction in [Direction::HostToSensor, Direction::SensorToHost] {
        let t = Telegram::new_unchecked(data, direction);
        let _ = (t.address(), t.length(), t.total_len(), t.command());
        let _ = (t.payload(), t.data(), t.status(), t.crc(), t.compute_crc());
        let _ = (t.as_bytes(), t.starts_with_stx(), t.sensor_address());
        let checked = Telegram::new_checked(data, direction);
        if let Ok(c) = checked {
            assert_eq!(c.compute_crc(), c.crc());
            assert!(c.total_len() <= data.len());
        }
        let _ = Request::parse(&t);
        if let Ok(Reply::Measured(v)) = Reply::parse(&t) {
            for bits in [RangeBits::Bits13, RangeBits::Bits14, RangeBits::Bits15] {
                let _ = v.to_frame(bits);
            }
        }
        let _ = MeasuredValues::parse(&t);
    }

    // 2. The bytes as command + data.
    let Some((&command, body)) = data.split_first() else {
        return;
    };
    let request = Request::from_parts(command, body);
    let _ = (
        request.command(),
        request.reply_command(),
        request.variant(),
    );
    if !matches!(request, Request::Unknown { .. }) {
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        let n = request
            .emit(0x00, &mut buf)
            .expect("a parsed request emits");
        assert_eq!(n, request.buffer_len());
        let t = Telegram::new_checked(&buf[..n], Direction::HostToSensor)
            .expect("emitted request checks");
        assert_eq!(Request::parse(&t), Ok(request), "request round trip");
    }
    if let Ok(reply) = Reply::from_parts(command, body) {
        if !matches!(reply, Reply::Other { .. }) {
            let mut buf = [0u8; MAX_TELEGRAM_LEN];
            if let Ok(n) = reply.emit(0x00, SensorStatus(0x10), &mut buf) {
                assert_eq!(n, reply.buffer_len());
                let t = Telegram::new_checked(&buf[..n], Direction::SensorToHost)
                    .expect("emitted reply checks");
                assert_eq!(Reply::parse(&t), Ok(reply), "reply round trip");
            }
        }
    }
    let _ = MeasuredView::new(body).map(|v| v.to_values(0x10));
    let _ = lms_core::telegram::StatusBlock::from_slice(body)
        .map(|b| (b.fields(), b.variant(), b.baud()));
    let _ = lms_core::telegram::Config::from_slice(body).map(|c| c.blanking());

    // 3. Any payload in a telegram of its own.
    for (status, direction) in [
        (None, Direction::HostToSensor),
        (Some(0x10), Direction::SensorToHost),
    ] {
        let mut buf = [0u8; MAX_TELEGRAM_LEN + 8];
        match emit_telegram(&mut buf, Head::from_sensor(command), body, status) {
            Ok(n) => {
                let t =
                    Telegram::new_checked(&buf[..n], direction).expect("emitted telegram checks");
                assert_eq!(t.command(), command);
                assert_eq!(t.data(), body);
                assert_eq!(t.status(), status);
            }
            Err(_) => assert!(body.len() + 1 + usize::from(status.is_some()) > MAX_LEN),
        }
    }
});
