//! The client machine against hand-made sensor bytes and the emulator.

use super::*;
use crate::device::emulator::{Emulator, FnSource, Settings};
use crate::telegram::{ModeResult, Reply, SensorStatus, ACK, DEFAULT_STATUS, NAK};
use std::vec::Vec;

const LIMITS: Limits = Limits {
    ack_us: 1_000,
    reply_us: Some(5_000),
    retries: 2,
};

/// A reply telegram from the sensor at `address`.
fn reply(address: u8, r: &Reply<'_>) -> Vec<u8> {
    let mut buf = [0u8; MAX_TELEGRAM_LEN];
    let n = r
        .emit(address, SensorStatus(DEFAULT_STATUS), &mut buf)
        .unwrap();
    buf[..n].to_vec()
}

fn a0() -> Vec<u8> {
    reply(0, &Reply::ModeChanged(ModeResult::Ok))
}

/// Feed all of `bytes`, collecting the outcomes.
fn feed_all(c: &mut Client, bytes: &[u8], now_us: u64) -> Vec<Outcome> {
    let mut input = bytes;
    let mut out = Vec::new();
    loop {
        let (o, rest) = c.feed(input, now_us);
        input = rest;
        match o {
            Some(o) => out.push(o),
            None => return out,
        }
    }
}

fn sent(request: &Request<'_>) -> Client {
    let mut c = Client::new(0);
    let bytes = c.prepare(request, LIMITS).unwrap().to_vec();
    assert_eq!(bytes, [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08]);
    c.mark_sent(100);
    c
}

#[test]
fn ack_then_reply() {
    let mut c = sent(&Request::OnRequest);
    assert_eq!(c.deadline_us(), Some(1_100));
    assert!(feed_all(&mut c, &[ACK], 500).is_empty());
    assert_eq!(c.deadline_us(), Some(5_500));
    let reply = a0();
    let (outcome, rest) = c.feed(&reply, 600);
    assert_eq!((outcome, rest.len()), (Some(Outcome::Reply), 0));
    // Read in place in the framer, until the next feed.
    assert_eq!(c.telegram_bytes(), &reply[..]);
    assert_eq!(c.feed(&[], 600).0, None);
    assert_eq!(c.telegram_bytes(), &[] as &[u8]);
    assert_eq!(c.deadline_us(), None);
    assert_eq!(c.stats().sent, 1);
    assert_eq!(c.stats().missing_acks, 0);
}

#[test]
fn reply_without_ack_other_telegrams_and_addresses() {
    let mut c = sent(&Request::OnRequest);
    let mut line = reply(1, &Reply::ModeChanged(ModeResult::Ok));
    line.extend(reply(0, &Reply::ResetAck));
    line.extend(reply(0, &Reply::PowerOn([0; 21])));
    line.extend(a0());
    assert_eq!(
        feed_all(&mut c, &line, 200),
        [Outcome::PowerOn, Outcome::Reply]
    );
    let s = c.stats();
    assert_eq!((s.wrong_address, s.ignored, s.missing_acks), (1, 2, 1));
}

#[test]
fn nak_resends_until_the_limit() {
    let mut c = sent(&Request::OnRequest);
    for attempt in 1..=3 {
        let want = if attempt <= 2 {
            Outcome::Resend
        } else {
            Outcome::NakLimit { attempts: 3 }
        };
        assert_eq!(feed_all(&mut c, &[NAK], 200), [want]);
        c.mark_sent(300);
    }
    assert_eq!(c.stats().resends, 3);
    assert_eq!(c.stats().sent, 4);
}

#[test]
fn unknown_command_and_keep_waiting() {
    let mut c = sent(&Request::OnRequest);
    let line = reply(0, &Reply::UnknownCommand);
    assert_eq!(feed_all(&mut c, &line, 200), [Outcome::UnknownCommand]);
    c.keep_waiting();
    assert_eq!(c.deadline_us(), Some(1_100));
    assert_eq!(feed_all(&mut c, &a0(), 300), [Outcome::Reply]);
}

#[test]
fn timeouts_name_what_was_awaited() {
    let mut c = sent(&Request::OnRequest);
    assert_eq!(c.poll(1_099), None);
    assert_eq!(c.poll(1_100), Some(Outcome::Timeout(Awaited::Ack)));
    c.mark_sent(2_000);
    assert!(feed_all(&mut c, &[ACK], 2_100).is_empty());
    assert_eq!(c.poll(7_099), None);
    assert_eq!(c.poll(7_100), Some(Outcome::Timeout(Awaited::Reply(0xA0))));
    c.await_stream(8_000, Some(100));
    assert_eq!(c.poll(8_100), Some(Outcome::Timeout(Awaited::StreamScan)));
}

#[test]
fn a_false_stx_is_given_up_at_the_deadline() {
    let mut c = sent(&Request::OnRequest);
    // A false STX with a long LEN holds the reply back.
    let mut line = vec![0x02, 0x80, 0x20, 0x00];
    line.extend(a0());
    assert!(feed_all(&mut c, &line, 200).is_empty());
    assert_eq!(c.poll(1_100), None);
    assert_eq!(feed_all(&mut c, &[], 1_100), [Outcome::Reply]);
    assert_eq!(c.framer_stats().abandoned, 1);
}

#[test]
fn the_stream_takes_scans_and_counts_bad_ones() {
    let mut c = Client::new(0);
    c.set_handshake(crate::telegram::Handshake::Ignored);
    c.await_stream(0, None);
    let mut emu = Emulator::new(
        FnSource::new(|_, _, out: &mut [u16]| {
            out.fill(100);
            out.len()
        }),
        Settings::default(),
        0,
    );
    emu.receive(0, &[0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08]);
    // 180 values at 9600 Bd: 383 ms per scan.
    let mut buf = [0u8; 4096];
    let n = emu.transmit(2_000_000, &mut buf);
    let (mut outcomes, mut input) = (Vec::new(), &buf[..n]);
    while let (Some(o), rest) = c.feed(input, 2_000_000) {
        input = rest;
        outcomes.push(o);
        if o == Outcome::Scan {
            assert_eq!(c.telegram().command(), 0xB0);
            assert_eq!(c.telegram_bytes().len(), 10 + 2 * 181);
        }
    }
    assert!(outcomes.len() >= 4, "{outcomes:?}");
    assert_eq!(outcomes[0], Outcome::PowerOn);
    assert!(outcomes[1..].iter().all(|&o| o == Outcome::Scan));
    // The power-on telegram and the A0 were not scans; the ACK is noise.
    assert_eq!(c.framer_stats().bytes_skipped, 1);
    assert_eq!(c.stats().ignored, 2);
    assert_eq!(c.deadline_us(), None);
}

#[test]
fn the_baud_probe_tries_every_rate_in_order() {
    let rates = [Baud::B9600, Baud::B38400];
    let mut probe = BaudProbe::new(&rates);
    assert_eq!(probe.next_rate(), Some(Baud::B9600));
    assert_eq!(probe.next_rate(), Some(Baud::B38400));
    assert_eq!(probe.next_rate(), None);
    assert_eq!(probe.rates(), &rates);
}

#[test]
fn awaited_in_words() {
    assert_eq!(std::format!("{}", Awaited::Reply(0xBB)), "reply BB");
    assert_eq!(std::format!("{}", Awaited::Ack), "ACK (06)");
}

#[test]
fn the_wait_runs_from_the_stream_telegrams_ahead_of_the_reply() {
    let mut b0 = [0u8; 64];
    let n = crate::telegram::emit_telegram(
        &mut b0,
        crate::telegram::Head::from_sensor(0xB0),
        &[2, 0, 1, 0, 1, 0],
        Some(0x10),
    )
    .unwrap();
    let b0 = &b0[..n];
    // Without `wait_behind_stream`: scans change nothing.
    let mut c = sent(&Request::OnRequest);
    assert!(feed_all(&mut c, b0, 900).is_empty());
    assert_eq!(c.deadline_us(), Some(1_100));
    // With it: the wait starts again from each scan, up to the cap.
    let mut c = sent(&Request::OnRequest);
    c.wait_behind_stream(3_000);
    assert!(feed_all(&mut c, b0, 900).is_empty());
    assert_eq!(c.deadline_us(), Some(1_900));
    assert_eq!(c.poll(1_899), None);
    assert!(feed_all(&mut c, b0, 1_800).is_empty());
    assert_eq!(c.deadline_us(), Some(2_800));
    assert!(feed_all(&mut c, b0, 5_000).is_empty());
    assert_eq!(c.deadline_us(), Some(100 + 3_000 + 1_000), "capped");
    // Other telegrams do not count; a new request starts without it.
    assert!(feed_all(&mut c, &reply(0, &Reply::ResetAck), 4_000).is_empty());
    assert_eq!(c.deadline_us(), Some(4_100));
    c.prepare(&Request::OnRequest, LIMITS).unwrap();
    c.mark_sent(10_000);
    assert!(feed_all(&mut c, b0, 10_500).is_empty());
    assert_eq!(c.deadline_us(), Some(11_000));
    assert_eq!(feed_all(&mut c, &a0(), 10_600), [Outcome::Reply]);
}
