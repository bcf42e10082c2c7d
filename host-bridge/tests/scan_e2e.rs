//! The client side end to end.
//!
//! * Library level, against the core's emulator on an in-memory line
//!   ([`EmulatedLink`]: virtual clock, so 9600 Bd costs no real time):
//!   every target rate × variant × units gives exactly the scans the sensor
//!   sent; faults on the line (a corrupted CRC, a truncated telegram,
//!   noise, a wrong address, corrupted requests answered with NAK, lost
//!   ACKs) are skipped or answered and counted, and the stream goes on;
//!   timeouts and a silent sensor give errors naming what was sent and how
//!   long the client waited.
//! * Over a real pseudo-terminal against `host-bridge simulate` (see
//!   `pty_*` below).
//! * The command line: a port that does not exist, bad arguments.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use host_bridge::capture::{self, CaptureWriter};
use host_bridge::client::{Client, ClientError, Scan, Timeouts};
use host_bridge::emulated_link::{EmulatedLink, PatternSource, StreamFault};
use host_bridge::scan::{run_session, Plan};
use host_bridge::serial::{Link, SerialLink};
use host_bridge::simulate::SceneSource;
use host_bridge::synthetic::SceneArgs;
use lms_core::device::emulator::{
    scan_period_us, Event as EmuEvent, FnSource, Handled, ScanSource,
};
use lms_core::telegram::{Baud, MeasuredValues};
use lms_core::Unit;
use lms_core::Variant;

mod common;
use common::{run, BIN};

/// A fresh scratch directory for this test process and `name`.
fn scratch(name: &str) -> PathBuf {
    common::scratch("scan", name)
}

/// Run `plan` on `client`, keeping the values of every scan.
fn collect<L: Link>(
    client: &mut Client<L>,
    plan: &Plan,
) -> anyhow::Result<(host_bridge::scan::Summary, Vec<MeasuredValues>)> {
    let mut got = Vec::new();
    let summary = run_session(client, plan, |_, _, scan| {
        got.push(scan.values.clone());
        Ok(())
    })?;
    Ok((summary, got))
}

/// The emulated sensor with the pattern source, on a line at 9600 Bd.
type Fake = EmulatedLink<PatternSource>;

fn fake_sensor() -> Fake {
    EmulatedLink::default()
}

fn fake_client(sensor: Fake) -> Client<Fake> {
    Client::new(sensor, Baud::B9600, Timeouts::default())
}

/// Run a plan against `client`, collecting the scans.
fn session<S: ScanSource>(
    client: &mut Client<EmulatedLink<S>>,
    plan: &Plan,
) -> (host_bridge::scan::Summary, Vec<Scan>) {
    let mut scans = Vec::new();
    let summary = run_session(client, plan, |i, _, scan| {
        assert_eq!(i, scans.len());
        scans.push(scan.clone());
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e:#}"));
    (summary, scans)
}

fn values(scans: &[Scan]) -> Vec<MeasuredValues> {
    scans.iter().map(|s| s.values.clone()).collect()
}

#[test]
fn fake_every_rate_variant_and_units() {
    for target in [Baud::B9600, Baud::B38400, Baud::B500000] {
        for variant in [Variant::Fov180Res50, Variant::Fov100Res25] {
            for units in [Unit::Millimetre, Unit::Centimetre] {
                for single in [false, true] {
                    let what = format!("{target:?} {variant:?} {units:?} single={single}");
                    let mut client = fake_client(fake_sensor());
                    let plan = Plan {
                        target: Some(target),
                        variant,
                        units,
                        scans: 5,
                        single,
                        ..Plan::default()
                    };
                    let (summary, scans) = session(&mut client, &plan);
                    let sensor = client.link();
                    assert_eq!(summary.scans, 5, "{what}");
                    assert_eq!(summary.found_baud, Baud::B9600, "{what}");
                    assert_eq!(summary.baud, target, "{what}");
                    // What came is what went, in order, nothing lost.
                    let sent = sensor.intact_scans();
                    assert!(sent.len() >= 5, "{what}");
                    assert_eq!(values(&scans), sent[..5].to_vec(), "{what}");
                    for s in &scans {
                        assert_eq!(s.values.count(), variant.beams(), "{what}");
                        assert_eq!(s.values.units(), units, "{what}");
                    }
                    let emu = sensor.emulator();
                    assert_eq!(emu.variant(), variant);
                    assert_eq!(emu.units(), units);
                    assert!(!emu.streaming());
                    // Put back at the power-on rate.
                    assert_eq!(emu.baud(), Baud::B9600, "{what}");
                    assert_eq!(summary.line.crc_errors, 0, "{what}");
                    assert_eq!(summary.line.bytes_skipped, 0, "{what}");
                    assert_eq!(summary.handshake.resends, 0, "{what}");
                    assert_eq!(summary.handshake.missing_acks, 0, "{what}");
                    // A streamed scan rate close to what the line allows:
                    // 361 values = 732 bytes = 14.6 ms at 500 kBd, but the
                    // mirror gives one scan per 26.7 ms (53.3 ms at 0.25°).
                    if !single && target == Baud::B500000 {
                        let mirror = 1e6 / scan_period_us(variant) as f64;
                        assert!(
                            (0.95 * mirror..=1.05 * mirror).contains(&summary.rate()),
                            "{what}: {} vs {mirror}",
                            summary.rate()
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn fake_finds_a_sensor_left_streaming_at_another_rate() {
    // Leave a sensor streaming at 38400 Bd.
    let mut client = fake_client(fake_sensor());
    client.set_baud(Baud::B38400).unwrap();
    client.start_stream().unwrap();
    let first = client.next_scan().unwrap();
    let sensor = client.into_link();
    assert!(sensor.emulator().streaming());

    // A new client starts at 9600 and finds it.
    let mut client = fake_client(sensor);
    let plan = Plan {
        target: None,
        scans: 3,
        ..Plan::default()
    };
    let (summary, scans) = session(&mut client, &plan);
    assert_eq!(summary.found_baud, Baud::B38400);
    assert_eq!(summary.baud, Baud::B38400);
    assert_eq!(scans.len(), 3);
    // Scans streamed before the stop are dropped while waiting for A0.
    assert!(client.stats().ignored > 0);
    assert_ne!(scans[0].values, first.values);
    assert_eq!(client.link().emulator().baud(), Baud::B9600);
}

/// A line on which, after the client switches to 500 kBd, the first bytes
/// received are `tail`: the end of a telegram the client dropped into
/// (`15` and `06` bytes of scan data), as when a client killed mid-stream
/// is followed by a new one.
struct MidTelegram {
    inner: Fake,
    tail: Vec<u8>,
    pending: Vec<u8>,
    at: Baud,
}

impl Link for MidTelegram {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.inner.send(bytes)
    }
    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        if !self.pending.is_empty() {
            let n = buf.len().min(self.pending.len());
            buf[..n].copy_from_slice(&self.pending[..n]);
            self.pending.drain(..n);
            return Ok(n);
        }
        self.inner.receive(buf, timeout)
    }
    fn set_baud(&mut self, baud: Baud) -> std::io::Result<()> {
        self.at = baud;
        self.inner.set_baud(baud)
    }
    fn discard_input(&mut self) -> std::io::Result<()> {
        if self.at == Baud::B500000 {
            self.pending = self.tail.clone();
        }
        self.inner.discard_input()
    }
    fn now(&self) -> Duration {
        self.inner.now()
    }
    fn name(&self) -> String {
        self.inner.name()
    }
}

/// A stream left running at 500 kBd; the new client drops into
/// the middle of a telegram whose data bytes read as `NAK`s and `ACK`s. They
/// are not answers: the sensor is found at 500 kBd all the same.
#[test]
fn fake_stray_nak_and_ack_bytes_in_a_stream_left_running_are_not_handshakes() {
    for tail in [
        vec![0x15; 2],
        vec![0x15, 0x06, 0x15, 0x15, 0x00, 0x15],
        vec![0x15; 40],
    ] {
        let mut client = fake_client(fake_sensor());
        client.set_baud(Baud::B500000).unwrap();
        client.start_stream().unwrap();
        client.next_scan().unwrap();
        let line = MidTelegram {
            inner: client.into_link(),
            tail: tail.clone(),
            pending: Vec::new(),
            at: Baud::B9600,
        };
        let mut client = Client::new(line, Baud::B9600, Timeouts::default());
        let plan = Plan {
            target: None,
            scans: 2,
            ..Plan::default()
        };
        let mut got = 0;
        let summary = run_session(&mut client, &plan, |_, _, _| {
            got += 1;
            Ok(())
        })
        .unwrap_or_else(|e| panic!("tail {tail:02X?}: {e:#}"));
        assert_eq!((summary.found_baud, got), (Baud::B500000, 2), "{tail:02X?}");
        assert!(
            client.framer_stats().naks >= 2,
            "{:?}",
            client.framer_stats()
        );
    }
}

/// A peer that answers only NAKs: the message says what came back at each
/// rate (not a bare "waited up to 0 ms").
#[test]
fn fake_no_sensor_message_says_what_the_peer_sent() {
    let mut client = fake_client(fake_sensor());
    client.link_mut().corrupt_next = 1000;
    let e = client.find_baud(&[Baud::B9600]).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ClientError::NoSensor { .. }), "{msg}");
    assert!(
        msg.contains("heard: 9600 Bd: ") && msg.contains(" NAK"),
        "{msg}"
    );
    assert!(!msg.contains("up to 0 ms"), "{msg}");
    let mut sensor = fake_sensor();
    sensor.mute = true;
    let msg = fake_client(sensor)
        .find_baud(&[Baud::B9600, Baud::B38400])
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("heard: 9600 Bd: nothing; 38400 Bd: nothing"),
        "{msg}"
    );
}

#[test]
fn fake_faults_on_the_line_are_skipped_counted_and_the_stream_goes_on() {
    let mut sensor = fake_sensor();
    // Stream scan indices: 1 corrupted (CRC), 3 truncated, 5 after noise
    // (with false STX bytes), 7 from another address, 9 corrupted in its
    // header (LEN).
    sensor.add_stream_fault(1, StreamFault::Corrupt { at: 100 });
    sensor.add_stream_fault(3, StreamFault::Truncate { keep: 200 });
    sensor.add_stream_fault(
        5,
        StreamFault::NoiseBefore(vec![0xFF, 0x02, 0x80, 0x10, 0x00, 0x55, 0x06, 0x15, 0x02]),
    );
    sensor.add_stream_fault(7, StreamFault::Address(0x81));
    sensor.add_stream_fault(9, StreamFault::Corrupt { at: 3 });
    // The first request of the session (the probe `20 25`) and the start of
    // the stream are hit by line noise: the sensor answers NAK.
    sensor.corrupt_next = 1;
    let mut client = fake_client(sensor);
    client.find_baud(&Baud::ALL).unwrap();
    assert_eq!(client.stats().resends, 1);
    client.set_variant(Variant::Fov180Res50).unwrap();
    client.set_baud(Baud::B500000).unwrap();
    // Two bits flipped on the way: the sensor's framer finds bad CRCs.
    client.link_mut().corrupt_next = 2;
    client.start_stream().unwrap();
    assert_eq!(client.stats().resends, 3);
    // The sensor started the stream once.
    assert_eq!(
        client
            .link()
            .events()
            .iter()
            .filter(|e| **e == EmuEvent::Request(Handled::Continuous))
            .count(),
        1
    );

    let before = client.framer_stats();
    let scans: Vec<Scan> = (0..12).map(|_| client.next_scan().unwrap()).collect();
    client.stop_stream().unwrap();
    let line = host_bridge::scan::framer_delta(&client.framer_stats(), &before);

    // Exactly the intact scans, in order: 1, 3, 7 and 9 never arrive.
    let sent = client.link().intact_scans().to_vec();
    assert_eq!(values(&scans), sent[..12].to_vec());
    assert!(line.crc_errors >= 2, "{line:?}");
    assert!(line.resyncs >= 4, "{line:?}");
    assert!(line.bytes_skipped >= 200 + 9, "{line:?}");
    assert_eq!(client.stats().wrong_address, 1);
}

#[test]
fn fake_missing_ack_is_tolerated() {
    let mut sensor = fake_sensor();
    sensor.drop_acks = true;
    let mut client = fake_client(sensor);
    let plan = Plan {
        scans: 2,
        single: true,
        ..Plan::default()
    };
    let (_, scans) = session(&mut client, &plan);
    assert_eq!(scans.len(), 2);
    assert!(client.stats().missing_acks >= 5);
}

#[test]
fn fake_silent_sensor_and_timeouts_name_what_was_sent() {
    // Nobody there: every rate tried, the message lists them.
    let mut sensor = fake_sensor();
    sensor.mute = true;
    let mut client = fake_client(sensor);
    let e = client.find_baud(&Baud::ALL).unwrap_err();
    assert!(matches!(e, ClientError::NoSensor { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("emulated-lms") && msg.contains("9600, 19200, 38400, 500000"),
        "{msg}"
    );
    assert!(
        msg.contains("20 25") && msg.contains("02 00 02 00 20 25 35 08"),
        "{msg}"
    );

    // A sensor that goes quiet: the time-out names the request and the wait.
    let mut client = fake_client(fake_sensor());
    client.find_baud(&Baud::ALL).unwrap();
    client.link_mut().mute = true;
    let t0 = client.link().now();
    let e = client.start_stream().unwrap_err();
    let waited = client.link().now() - t0;
    let msg = e.to_string();
    assert!(matches!(e, ClientError::Timeout { .. }), "{msg}");
    assert!(msg.contains("20 24 (continuous output)"), "{msg}");
    assert!(msg.contains("ACK"), "{msg}");
    assert!(
        msg.contains(&format!("{} ms", waited.as_millis())),
        "{msg} vs {waited:?}"
    );

    // A stream that stops: the time-out says what it waited for.
    let mut client = fake_client(fake_sensor());
    client.find_baud(&Baud::ALL).unwrap();
    client.start_stream().unwrap();
    client.next_scan().unwrap();
    client.link_mut().mute = true;
    let e = loop {
        // What was on the line still arrives; then the time-out.
        match client.next_scan() {
            Ok(_) => continue,
            Err(e) => break e,
        }
    };
    let msg = e.to_string();
    assert!(
        msg.contains("the next streamed scan") && msg.contains("20 24"),
        "{msg}"
    );
}

#[test]
fn fake_nak_every_time_gives_up_after_the_retries() {
    let mut client = fake_client(fake_sensor());
    client.find_baud(&Baud::ALL).unwrap();
    client.retries = 2;
    client.link_mut().corrupt_next = 100;
    let e = client.set_variant(Variant::Fov100Res50).unwrap_err();
    assert!(matches!(e, ClientError::Nak { attempts: 3, .. }), "{e}");
    assert!(e.to_string().contains("3B (variant 100°/0.5°)"), "{e}");
}

#[test]
fn fake_scans_recorded_into_a_capture_read_back_bit_exact() {
    let mut client = fake_client(fake_sensor());
    let plan = Plan {
        variant: Variant::Fov100Res25,
        units: Unit::Centimetre,
        scans: 4,
        ..Plan::default()
    };
    let mut writer = CaptureWriter::new(Vec::new()).unwrap();
    run_session(&mut client, &plan, |_, t, scan| {
        writer.write(t.as_micros() as u64, &scan.telegram)?;
        Ok(())
    })
    .unwrap();
    let bytes = writer.finish().unwrap();
    let dir = scratch("capture");
    let path = dir.join("fake.lmscap");
    std::fs::write(&path, &bytes).unwrap();
    let back: Vec<_> = capture::read_values(&path)
        .unwrap()
        .collect::<anyhow::Result<_>>()
        .unwrap();
    let sent = client.link().intact_scans();
    assert_eq!(back.len(), 4);
    for (i, scan) in back.iter().enumerate() {
        assert_eq!(scan.index, i);
        assert_eq!(scan.values, sent[i]);
    }
    // Times are non-decreasing and at the line's pace (≥ 26.7 ms apart).
    for w in back.windows(2) {
        assert!(
            w[1].time_us >= w[0].time_us + 26_000,
            "{:?}",
            (w[0].time_us, w[1].time_us)
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cli_port_that_does_not_exist_is_named() {
    let out = run(&[
        "scan",
        "--port",
        "/dev/no-such-lms-port",
        "--scans",
        "1",
        "--no-save",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/dev/no-such-lms-port") && err.contains("cannot open serial port"),
        "{err}"
    );
}

#[test]
fn cli_bad_arguments_are_explained() {
    for (args, needle) in [
        (
            &["scan", "--port", "/dev/null", "--baud", "115200"][..],
            "115200",
        ),
        (
            &["scan", "--port", "/dev/null", "--variant", "180/0.25"][..],
            "180/0.25",
        ),
        (
            &["scan", "--port", "/dev/null", "--units", "m"][..],
            "units",
        ),
        (
            &["scan", "--port", "/dev/null", "--scans", "0"][..],
            "--scans",
        ),
        (
            &["scan", "--port", "/dev/null", "--no-save"][..],
            "not a serial port",
        ),
        (&["scan"][..], "--port"),
        // No -o and no --no-save: refused before anything is sent.
        (&["scan", "--port", "/dev/null"][..], "--output"),
        (
            &["scan", "--port", "/dev/null", "-o", "x.lmscap", "--no-save"][..],
            "cannot be used with",
        ),
        // A directory, or a directory that does not exist.
        (
            &["scan", "--port", "/dev/null", "-o", "/tmp"][..],
            "that is a directory",
        ),
        (
            &["scan", "--port", "/dev/null", "-o", "/no-such-dir/a.lmscap"][..],
            "does not exist",
        ),
    ] {
        let out = run(args);
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn cli_extract_reads_a_capture_and_rejects_a_broken_one() {
    let dir = scratch("extract");
    // A capture of two scans from the fake sensor.
    let mut client = fake_client(fake_sensor());
    let path = dir.join("two.lmscap");
    let mut file = capture::CaptureFile::create(&path).unwrap();
    run_session(
        &mut client,
        &Plan {
            scans: 2,
            ..Plan::default()
        },
        |_, t, scan| file.write(t.as_micros() as u64, &scan.telegram),
    )
    .unwrap();
    file.commit().unwrap();
    let out = run(&["extract", path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 2);
    let rec: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert_eq!(rec["n"], 361);
    // The first value of the pattern: word 1 mm... as the sensor sent it.
    let sent = &client.link().intact_scans()[0];
    let r0 = rec["ranges"][1].as_f64().unwrap();
    assert!((r0 - f64::from(sent.values()[1]) / 1000.0).abs() < 1e-6);

    // Cut inside the second record (a kill, a power loss):
    // the complete first record is read, and the warning says where and why.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.join("cut.lmscap");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    let out = run(&["extract", cut.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 1);
    let second = 8 + 10 + 732;
    assert!(
        err.contains("cut.lmscap") && err.contains(&format!("truncated record 1 at byte {second}")),
        "{err}"
    );
    assert!(
        err.contains("the 1 complete records before it are used"),
        "{err}"
    );
    // Damage inside the file (not a cut) is still an error.
    let mut bad = bytes.clone();
    bad[8 + 10 + 20] ^= 0x01;
    std::fs::write(&cut, &bad).unwrap();
    let out = run(&["extract", cut.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("record 0 at byte 8"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A capture cut at any byte yields every complete
/// record before the cut, and says where it is cut.
#[test]
fn capture_cut_at_every_byte_keeps_every_complete_record() {
    let mut client = fake_client(fake_sensor());
    let mut w = CaptureWriter::new(Vec::new()).unwrap();
    let mut ends = vec![8usize];
    run_session(
        &mut client,
        &Plan {
            scans: 3,
            variant: Variant::Fov100Res100,
            ..Plan::default()
        },
        |_, t, scan| {
            w.write(t.as_micros() as u64, &scan.telegram)
                .map_err(anyhow::Error::new)?;
            ends.push(w.bytes() as usize);
            Ok(())
        },
    )
    .unwrap();
    let full = w.finish().unwrap();
    let sent = client.link().intact_scans()[..3].to_vec();
    for cut in 8..=full.len() {
        let reader = capture::CaptureReader::new(&full[..cut]).unwrap();
        let mut scans = capture::CaptureScans::new(reader, std::path::Path::new("c.lmscap"));
        let got: Vec<_> = scans.by_ref().collect::<anyhow::Result<_>>().unwrap();
        let complete = ends.iter().filter(|&&e| e <= cut).count() - 1;
        assert_eq!(got.len(), complete, "cut at byte {cut}");
        for (g, s) in got.iter().zip(&sent) {
            assert_eq!(&g.values, s, "cut at byte {cut}");
        }
        let at_boundary = ends.contains(&cut);
        assert_eq!(scans.cut().is_none(), at_boundary, "cut at byte {cut}");
        if let Some(m) = scans.cut_message() {
            let start = ends[complete];
            assert!(
                m.contains(&format!("truncated record {complete} at byte {start}")),
                "{m}"
            );
        }
    }
    // Shorter than the magic: not a capture.
    assert!(capture::CaptureReader::new(&full[..7]).is_err());
}

// ---------------------------------------------------------------------------
// The client against the emulator with a recording source: the values the
// source made are the values the client got.

/// Scans the source handed to the emulator, in order.
type Sent = Arc<Mutex<Vec<Vec<u16>>>>;

/// A deterministic source that records what it produced.
fn recording_source(sent: Sent) -> impl ScanSource {
    FnSource(move |_variant: Variant, _units: Unit, out: &mut [u16]| {
        let mut sent = sent.lock().unwrap();
        let k = sent.len();
        for (j, w) in out.iter_mut().enumerate() {
            *w = ((j * 13 + k * 101) % 8100 + 1) as u16;
        }
        sent.push(out.to_vec());
        out.len()
    })
}

#[test]
fn emulator_left_streaming_at_38400_is_found() {
    let sent: Sent = Arc::default();
    let link = EmulatedLink::new(recording_source(sent.clone()));
    let mut client = Client::new(link, Baud::B9600, Timeouts::default());
    client.find_baud(&Baud::ALL).unwrap();
    client.set_baud(Baud::B38400).unwrap();
    client.start_stream().unwrap();
    client.next_scan().unwrap();
    let link = client.into_link();
    let mut client = Client::new(link, Baud::B9600, Timeouts::default());
    assert_eq!(client.find_baud(&Baud::ALL).unwrap(), Baud::B38400);
    let scan = client.single_scan().unwrap();
    let sent = sent.lock().unwrap();
    assert_eq!(scan.values.values(), &sent.last().unwrap()[..]);
}

#[test]
fn emulator_corrupted_request_is_naked_and_resent() {
    let link = EmulatedLink::new(recording_source(Arc::default()));
    let mut client = Client::new(link, Baud::B9600, Timeouts::default());
    client.find_baud(&Baud::ALL).unwrap();
    // Send a corrupted copy of `3B` by hand first: the emulator NAKs it,
    // and the client's own request right after goes through.
    let mut bad = [0u8; 16];
    let n = lms_core::telegram::Request::set_variant(Variant::Fov100Res50)
        .emit(0, &mut bad)
        .unwrap();
    bad[5] ^= 0x40;
    client.link_mut().send(&bad[..n]).unwrap();
    client.set_variant(Variant::Fov100Res50).unwrap();
    assert_eq!(client.link().emulator().stats().naks, 1);
    // The NAK (for the corrupted copy) made the client send its `3B` again.
    assert_eq!(client.stats().resends, 1);
    assert_eq!(client.link().emulator().variant(), Variant::Fov100Res50);
}

// ---------------------------------------------------------------------------
// Over a real pseudo-terminal: `host-bridge simulate` on one side, the
// client (library or binary) on the other, the simulator's clock and pacing
// real. The simulator's scans come from its seeded scene; the test draws the
// same scans from `host_bridge::simulate::SceneSource` with the same options
// (the simulator asks its source only for the scans it sends, in order).

/// Scene options given to every simulator here.
const SEED: u64 = 7;
const COUNT: usize = 5;

/// Waits of the client in these tests: the simulator answers within
/// milliseconds, so 1 s for a reply is ample and keeps failures quick.
fn pty_timeouts() -> Timeouts {
    Timeouts {
        ack: Duration::from_millis(300),
        reply: Duration::from_secs(1),
        probe: Duration::from_millis(300),
    }
}

/// A running `host-bridge simulate`, killed when dropped.
struct Simulator {
    child: Child,
    pty: PathBuf,
    log: PathBuf,
}

impl Simulator {
    fn start(name: &str) -> Simulator {
        let seed = SEED.to_string();
        let count = COUNT.to_string();
        Simulator::start_with(name, &["--seed", &seed, "--count", &count])
    }

    fn start_with(name: &str, source: &[&str]) -> Simulator {
        let dir = scratch(&format!("sim-{name}"));
        let log = dir.join("simulate.log");
        let mut child = Command::new(BIN)
            .args(["simulate", "--verbose", "--quit-after", "120"])
            .args(source)
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("cannot start host-bridge simulate");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let pty = PathBuf::from(line.trim());
        assert!(
            pty.starts_with("/dev/"),
            "simulate printed {line:?}; its log:\n{}",
            std::fs::read_to_string(&log).unwrap_or_default()
        );
        Simulator { child, pty, log }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Freeze the simulator (SIGSTOP): the pty stays, nothing answers.
    fn freeze(&self) {
        let ok = Command::new("kill")
            .args(["-STOP", &self.child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok);
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-CONT", &self.child.id().to_string()])
            .status();
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The first `n` scans the simulator's source gives for a variant and units.
fn scene_scans(variant: Variant, units: Unit, n: usize) -> Vec<Vec<u16>> {
    let args = SceneArgs {
        seed: SEED,
        count: COUNT,
        ..SceneArgs::default()
    };
    let mut source = SceneSource::new(&args).unwrap();
    (0..n)
        .map(|_| {
            let mut out = vec![0u16; variant.beams()];
            let written = source.next_scan(variant, units, &mut out);
            out[written..].fill(8191);
            out
        })
        .collect()
}

/// A client on the simulator's pty at 9600 Bd.
fn pty_client(sim: &Simulator) -> Client<SerialLink> {
    let link = SerialLink::open(&sim.pty, Baud::B9600).unwrap_or_else(|e| panic!("{e}"));
    Client::new(link, Baud::B9600, pty_timeouts())
}

/// Stream (or request) `scans` scans over the pty and compare them with the
/// scene.
fn pty_case(name: &str, target: Baud, variant: Variant, units: Unit, scans: usize, single: bool) {
    let started = std::time::Instant::now();
    let sim = Simulator::start(name);
    let mut client = pty_client(&sim);
    let plan = Plan {
        target: Some(target),
        variant,
        units,
        scans,
        single,
        // Leave the sensor at the target rate: the simulator is killed next.
        restore_9600: false,
        ..Plan::default()
    };
    let (summary, got) = collect(&mut client, &plan)
        .unwrap_or_else(|e| panic!("{name}: {e:#}\nsimulator log:\n{}", sim.log()));
    assert_eq!(summary.found_baud, Baud::B9600, "{name}");
    assert_eq!(summary.baud, target, "{name}");
    let expected = scene_scans(variant, units, scans);
    for (i, v) in got.iter().enumerate() {
        assert_eq!(v.units(), units, "{name}: scan {i}");
        assert_eq!(v.count(), variant.beams(), "{name}: scan {i}");
        assert_eq!(v.values(), &expected[i][..], "{name}: scan {i}");
    }
    assert_eq!(got.len(), scans);
    assert_eq!(summary.line.crc_errors, 0, "{name}");
    assert_eq!(summary.line.bytes_skipped, 0, "{name}");
    eprintln!(
        "{name}: {scans} scans at {} Bd, {:.1} scans/s, {:.2} s in all; handshake {:?}",
        target.bits_per_second(),
        summary.rate(),
        started.elapsed().as_secs_f64(),
        summary.handshake
    );
}

#[test]
fn pty_9600_180_half_mm() {
    // 361 values = 732 bytes = 0.76 s at 9600 Bd each.
    pty_case(
        "9600",
        Baud::B9600,
        Variant::Fov180Res50,
        Unit::Millimetre,
        2,
        false,
    );
}

#[test]
fn pty_38400_100_quarter_cm() {
    pty_case(
        "38400",
        Baud::B38400,
        Variant::Fov100Res25,
        Unit::Centimetre,
        4,
        false,
    );
}

#[test]
fn pty_500000_180_half_cm() {
    pty_case(
        "500k-180",
        Baud::B500000,
        Variant::Fov180Res50,
        Unit::Centimetre,
        30,
        false,
    );
}

#[test]
fn pty_500000_100_quarter_mm() {
    pty_case(
        "500k-100",
        Baud::B500000,
        Variant::Fov100Res25,
        Unit::Millimetre,
        15,
        false,
    );
}

#[test]
fn pty_single_scans_at_38400() {
    pty_case(
        "single",
        Baud::B38400,
        Variant::Fov180Res50,
        Unit::Millimetre,
        3,
        true,
    );
}

#[test]
fn pty_sensor_left_streaming_is_found_at_its_rate() {
    let sim = Simulator::start("left-streaming");
    let mut client = pty_client(&sim);
    client.find_baud(&Baud::ALL).unwrap();
    client.set_baud(Baud::B38400).unwrap();
    client.start_stream().unwrap();
    client.next_scan().unwrap();
    // The client goes away; the sensor streams on at 38400 Bd.
    drop(client);
    std::thread::sleep(Duration::from_millis(300));
    let mut client = pty_client(&sim);
    let found = client
        .find_baud(&Baud::ALL)
        .unwrap_or_else(|e| panic!("{e}\nsimulator log:\n{}", sim.log()));
    assert_eq!(found, Baud::B38400);
    let scan = client.single_scan().unwrap();
    assert_eq!(scan.values.count(), 181);
}

/// `simulate --bit-error-rate`: the client on a noisy line brings the
/// sensor up (retrying what the noise spoils), skips and counts damaged
/// telegrams, and records only scans the sensor really sent.
#[test]
fn pty_noisy_line_damaged_scans_are_counted_never_recorded() {
    let seed = SEED.to_string();
    let count = COUNT.to_string();
    let sim = Simulator::start_with(
        "noisy",
        &[
            "--seed",
            &seed,
            "--count",
            &count,
            "--bit-error-rate",
            "2e-5",
            "--fault-seed",
            "3",
        ],
    );
    let mut client = pty_client(&sim);
    let scans = 150;
    let plan = Plan {
        target: Some(Baud::B500000),
        variant: Variant::Fov180Res50,
        units: Unit::Millimetre,
        scans,
        restore_9600: false,
        ..Plan::default()
    };
    let (summary, got) = collect(&mut client, &plan)
        .unwrap_or_else(|e| panic!("{e:#}\nsimulator log:\n{}", sim.log()));
    // 5856 bits per B0: about 11 % of them are hit at 2e-5 per bit.
    assert_eq!(got.len(), scans);
    assert!(
        summary.line.crc_errors >= 3,
        "damage went unnoticed: {:?}",
        summary.line
    );
    let sent = scene_scans(Variant::Fov180Res50, Unit::Millimetre, COUNT);
    for (i, v) in got.iter().enumerate() {
        assert!(
            sent.iter().any(|s| v.values() == &s[..]),
            "scan {i} was never sent: a damaged scan was accepted"
        );
    }
    eprintln!(
        "noisy line: {scans} scans recorded intact, {} CRC errors, {} resyncs, {} bytes skipped; handshake {:?}",
        summary.line.crc_errors, summary.line.resyncs, summary.line.bytes_skipped, summary.handshake
    );
}

#[test]
fn pty_cli_scan_writes_a_capture_that_extract_reads() {
    let sim = Simulator::start("cli");
    let dir = scratch("pty-cli");
    let capture_path = dir.join("scans.lmscap");
    let out = run(&[
        "scan",
        "--port",
        sim.pty.to_str().unwrap(),
        "--baud",
        "9600",
        "--variant",
        "100/0.25",
        "--units",
        "cm",
        "--scans",
        "2",
        "--output",
        capture_path.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}\nsimulator log:\n{}", sim.log());
    // The summary.
    assert!(err.contains("2 scans from"), "{err}");
    assert!(
        err.contains("(100°/0.25°, 401 values, cm) at 9600 Bd"),
        "{err}"
    );
    assert!(
        err.contains("0 CRC errors, 0 resyncs, 0 bytes skipped"),
        "{err}"
    );
    assert!(err.contains("scans.lmscap (2 scans, 1652 bytes)"), "{err}");
    assert!(!capture::CaptureFile::partial_path(&capture_path).exists());
    // The capture holds what the scene sent.
    let expected = scene_scans(Variant::Fov100Res25, Unit::Centimetre, 2);
    let back: Vec<_> = capture::read_values(&capture_path)
        .unwrap()
        .collect::<anyhow::Result<_>>()
        .unwrap();
    assert_eq!(back.len(), 2);
    for (b, e) in back.iter().zip(&expected) {
        assert_eq!(b.values.values(), &e[..]);
        assert_eq!(b.values.units(), Unit::Centimetre);
    }
    // 401 values = 812 bytes = 0.85 s per scan at 9600 Bd.
    assert!(back[1].time_us - back[0].time_us >= 800_000);
    let out = run(&["extract", capture_path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 2);
    for line in text.lines() {
        let rec: serde_json::Value = serde_json::from_str(line).unwrap();
        assert_eq!(rec["n"], 401);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Start `scan` streaming at 500 kBd into `capture_path` and wait until
/// 20 scans are in the `.partial` file.
fn scan_streaming(sim: &Simulator, capture_path: &std::path::Path) -> Child {
    let partial = capture::CaptureFile::partial_path(capture_path);
    let child = Command::new(BIN)
        .args(["scan", "--port", sim.pty.to_str().unwrap()])
        .args(["--baud", "500000", "--scans", "100000", "--output"])
        .arg(capture_path)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until scans arrive (a 361-value scan is 732 bytes).
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while std::fs::metadata(&partial).map_or(0, |m| m.len()) < 20 * 732 {
        assert!(std::time::Instant::now() < deadline, "no scans recorded");
        std::thread::sleep(Duration::from_millis(50));
    }
    child
}

fn kill(child: &Child, signal: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok);
}

/// Ctrl-C, SIGHUP (a closed terminal) or SIGTERM during `scan`: it stops
/// the stream, puts the sensor back at 9600 Bd, leaves the scans so far in
/// the `.partial` file (flushed record by record: every one readable) and
/// exits non-zero.
#[test]
fn pty_cli_scan_interrupted_leaves_the_sensor_quiet() {
    let sim = Simulator::start("interrupted");
    for signal in ["INT", "HUP"] {
        let dir = scratch(&format!("pty-interrupted-{signal}"));
        let capture_path = dir.join("scans.lmscap");
        let partial = capture::CaptureFile::partial_path(&capture_path);
        let child = scan_streaming(&sim, &capture_path);
        kill(&child, signal);
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "SIG{signal}: {err}");
        assert!(err.contains("interrupted by a signal"), "{err}");
        assert!(!err.contains("signal: interrupted"), "said twice: {err}");
        assert!(err.contains("the capture is incomplete"), "{err}");
        assert!(!capture_path.exists());
        let mut scans = capture::read_values(&partial).unwrap();
        let kept = scans.by_ref().filter(|s| s.is_ok()).count();
        assert!(kept >= 20, "{kept} scans in the partial capture");
        assert!(
            scans.cut().is_none(),
            "SIG{signal}: the file ends on a whole record"
        );
        // The sensor was told: stream stopped, then back to 9600 Bd.
        let log = sim.log();
        let stopped = log.rfind("continuous output stopped").expect(&log);
        let back = log.rfind("line switched 500000 -> 9600 Bd");
        assert!(back.is_some_and(|b| b > stopped), "SIG{signal}: {log}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// SIGTERM while `scan` looks for a sensor that does not
/// answer ends the search at once, and the error says why.
#[test]
fn pty_cli_scan_signal_during_the_search_ends_it() {
    let sim = Simulator::start("search-signal");
    sim.freeze();
    let dir = scratch("pty-search-signal");
    let capture_path = dir.join("none.lmscap");
    let child = Command::new(BIN)
        .args(["scan", "--port", sim.pty.to_str().unwrap(), "-o"])
        .arg(&capture_path)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let sent = std::time::Instant::now();
    kill(&child, "TERM");
    let out = child.wait_with_output().unwrap();
    let took = sent.elapsed();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("looking for the sensor") && err.contains("interrupted by a signal"),
        "{err}"
    );
    // The whole search takes over 1.2 s (4 rates × 300 ms): it was cut short.
    assert!(took < Duration::from_millis(1000), "{took:?}");
    assert!(
        !CaptureFileExt::any_file(&dir),
        "a file was left in {}",
        dir.display()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

struct CaptureFileExt;

impl CaptureFileExt {
    fn any_file(dir: &std::path::Path) -> bool {
        std::fs::read_dir(dir).unwrap().next().is_some()
    }
}

/// A client killed with SIGKILL leaves the sensor
/// streaming at 500 kBd; the next `scan` finds it every time.
#[test]
fn pty_cli_scan_after_a_killed_scan_finds_the_sensor() {
    let sim = Simulator::start("killed");
    let dir = scratch("pty-killed");
    for round in 0..3 {
        let child = scan_streaming(&sim, &dir.join(format!("a{round}.lmscap")));
        kill(&child, "KILL");
        let _ = child.wait_with_output().unwrap();
        let b = dir.join(format!("b{round}.lmscap"));
        let out = run(&[
            "scan",
            "--port",
            sim.pty.to_str().unwrap(),
            "--scans",
            "5",
            "-o",
            b.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "round {round}: {err}\n{}", sim.log());
        assert_eq!(capture::read_values(&b).unwrap().count(), 5);
        // The killed run's partial file: every complete record readable.
        let partial = capture::CaptureFile::partial_path(&dir.join(format!("a{round}.lmscap")));
        let kept = capture::read_values(&partial)
            .unwrap()
            .filter(|s| s.is_ok())
            .count();
        assert!(kept >= 20, "{kept}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A capture recorded with `scan` is replayed by `simulate --replay` and
/// scanned again: the same values come back.
#[test]
fn pty_capture_replayed_by_simulate_gives_the_same_scans() {
    let dir = scratch("pty-replay");
    let capture_path = dir.join("first.lmscap");
    let second_path = dir.join("second.lmscap");
    let record = |sim: &Simulator, path: &PathBuf| {
        let out = run(&[
            "scan",
            "--port",
            sim.pty.to_str().unwrap(),
            "--baud",
            "500000",
            "--units",
            "mm",
            "--scans",
            "4",
            "--output",
            path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}\nsimulator log:\n{}",
            String::from_utf8_lossy(&out.stderr),
            sim.log()
        );
    };
    let sim = Simulator::start("replay-source");
    record(&sim, &capture_path);
    drop(sim);
    let sim = Simulator::start_with("replay", &["--replay", capture_path.to_str().unwrap()]);
    record(&sim, &second_path);
    let values = |p: &PathBuf| -> Vec<Vec<u16>> {
        capture::read_values(p)
            .unwrap()
            .map(|s| s.unwrap().values.values().to_vec())
            .collect()
    };
    let (first, second) = (values(&capture_path), values(&second_path));
    assert_eq!(first.len(), 4);
    assert_eq!(first, second, "the replayed scans equal the recorded ones");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pty_cli_sensor_that_does_not_answer() {
    let sim = Simulator::start("frozen");
    sim.freeze();
    let dir = scratch("pty-frozen");
    let capture_path = dir.join("none.lmscap");
    let started = std::time::Instant::now();
    let out = run(&[
        "scan",
        "--port",
        sim.pty.to_str().unwrap(),
        "--scans",
        "1",
        "-o",
        capture_path.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let pty = sim.pty.display().to_string();
    assert!(
        err.contains(&format!("no LMS 2xx answers on {pty}")),
        "{err}"
    );
    assert!(
        err.contains("20 25 (values on request) [02 00 02 00 20 25 35 08]"),
        "{err}"
    );
    assert!(err.contains("9600, 19200, 38400, 500000"), "{err}");
    // A failed search leaves no file at all.
    assert!(
        err.contains("no scan was recorded (nothing saved)"),
        "{err}"
    );
    assert!(!capture_path.exists());
    assert!(!capture::CaptureFile::partial_path(&capture_path).exists());
    // Four rates, each 300 ms plus one longest telegram's line time.
    assert!(started.elapsed() < Duration::from_secs(10));
    std::fs::remove_dir_all(&dir).unwrap();
}
