//! Writes the seed corpora `fuzz/target/corpus/<target>/` from real telegrams: the
//! CRC vectors of PROTOCOL.md §4, `B0` telegrams built from the CARMEN logs
//! in `../shared/data/carmen/`, the feature telegrams of those scans, and
//! recorded sessions of the LMS emulator and the co-processor.
//!
//! ```sh
//! cd fuzz && cargo run --example seeds            # rewrites target/corpus/*/
//! ```
//!
//! Deterministic: the same files every run.

use std::path::{Path, PathBuf};

// host-bridge's capture writer, from its source file (see Cargo.toml).
#[allow(dead_code)]
#[path = "../../host-bridge/src/capture.rs"]
mod capture;

use lms_core::carmen::{self, ReadError};
use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
use lms_core::device::emulator::{Emulator, FnSource, Settings};
use lms_core::telegram::features::{emit_features, EchoedParams};
use lms_core::telegram::{Head, MeasuredValues, RangeBits, Request, ACK};
use lms_core::{test_support, Unit};
use lms_core::{Beam, Extractor, Params, Variant};
use lms_fuzz::{
    encode_features, encode_pipeline_words, units_byte, FramerInput, Ops, Output, Port,
    FRAMER_ABANDON, FRAMER_HANDSHAKE, FRAMER_HOST_TO_SENSOR,
};

/// Telegrams of PROTOCOL.md §4 (hex).
const HOST_VECTORS: &[&str] = &[
    "02000100311512",
    "020002003001 3118",
    "02000200202434 08",
    "02000200202535 08",
    "02000200204252 08",
    "02000200204151 08",
    "02000200204050 08",
    "02000200204858 08",
    "02000A00200053494 34B5F4C4D53BEC5",
    "020005003BB40032003B1F",
    "020005003B64001900E772",
    "02000100745012",
    "020001003A1E12",
    "02000100103412",
];
const SENSOR_VECTORS: &[&str] = &[
    "02800300A00010160A",
    "02810300A00010361A",
    "02800700BB01B40032001003 9D",
    "02800200921 07F33",
];

fn hex(s: &str) -> Vec<u8> {
    let s: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

/// One scan of a log as value words in `units`, padded to a variant.
struct Scan {
    variant: Variant,
    units: Unit,
    bits: RangeBits,
    words: Vec<u16>,
}

/// Every `step`-th scan of a CARMEN log, at most `max`, through the core's
/// one reader: a mm log (Örebro) in the 32 m mode's 15 range bits, the cm
/// logs in 13; error codes and zeros back to their words.
fn log_scans(path: &Path, step: usize, max: usize) -> Vec<Scan> {
    let fail = |e: ReadError| -> ! { panic!("{}: {e}", path.display()) };
    let reader = test_support::open_log(path).unwrap_or_else(|e| fail(e));
    let units = reader.unit();
    let bits = match units {
        Unit::Millimetre => RangeBits::Bits15,
        _ => RangeBits::Bits13,
    };
    let scale = f64::from(units.per_metre());
    let mut out = Vec::new();
    for scan in reader.step_by(step).take(max) {
        let frame = scan.unwrap_or_else(|e| fail(e)).frame;
        let mut words: Vec<u16> = frame
            .ranges()
            .iter()
            .zip(frame.beams())
            .map(|(&r, beam)| match *beam {
                Beam::Valid => (f64::from(r) * scale).round() as u16,
                Beam::Invalid(why) => bits.encode_invalid(why),
            })
            .collect();
        // 180 and 360 beams miss the last one: "not valid".
        let variant = carmen::variant_for_beams(frame.len()).expect("a 180° log");
        words.resize(variant.beams(), bits.mask());
        out.push(Scan {
            variant,
            units,
            bits,
            words,
        });
    }
    out
}

/// The 100° part (40°…140°) of a 180° scan, and its 0.25° version
/// (each beam twice, the last once).
fn narrow(scan: &Scan) -> [Scan; 2] {
    let per_deg = (scan.words.len() - 1) / 180;
    let part: Vec<u16> = scan.words[40 * per_deg..=140 * per_deg].to_vec();
    let variant = if per_deg == 1 {
        Variant::Fov100Res100
    } else {
        Variant::Fov100Res50
    };
    let mut fine = Vec::new();
    for (i, &w) in part.iter().enumerate() {
        fine.push(w);
        if i + 1 < part.len() && per_deg == 2 {
            fine.push(w);
        }
    }
    let quarter = if per_deg == 2 {
        Scan {
            variant: Variant::Fov100Res25,
            units: scan.units,
            bits: scan.bits,
            words: fine,
        }
    } else {
        Scan {
            variant,
            units: scan.units,
            bits: scan.bits,
            words: part.clone(),
        }
    };
    [
        Scan {
            variant,
            units: scan.units,
            bits: scan.bits,
            words: part,
        },
        quarter,
    ]
}

fn b0_telegram(scan: &Scan) -> Vec<u8> {
    let v = MeasuredValues::from_raw(&scan.words, scan.units, 0x10).unwrap();
    let mut buf = vec![0u8; v.buffer_len()];
    let n = v.emit(0, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// The feature telegrams of a scan (σ = 1 cm for cm data, as the README says).
fn feature_telegrams(scan: &Scan, counter: u32) -> (Vec<Vec<u8>>, lms_core::Features, Params) {
    let v = MeasuredValues::from_raw(&scan.words, scan.units, 0x10).unwrap();
    let frame = v.to_frame(scan.bits).unwrap();
    let params = Params::DEFAULT.with_sigma(if scan.units == Unit::Millimetre {
        0.005
    } else {
        0.01
    });
    let mut extractor = Extractor::new();
    let features = extractor.run(&frame, &params.validate().unwrap()).clone();
    let mut out = Vec::new();
    emit_features(
        counter,
        frame.len() as u16,
        &EchoedParams::from(&params),
        &features,
        0,
        |t| {
            out.push(t.to_vec());
            Ok::<(), ()>(())
        },
    )
    .unwrap();
    (out, features, params)
}

struct Corpus {
    root: PathBuf,
    files: usize,
}

impl Corpus {
    fn put(&mut self, target: &str, name: &str, bytes: &[u8]) {
        let dir = self.root.join(target);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(name), bytes).unwrap();
        self.files += 1;
    }
}

/// A co-processor session with the emulator as the sensor, recorded as
/// the co-processor target's operations: `host_at` host requests at times
/// (µs), `until` µs in steps of `step` µs.
fn cop_session(scans: &[Scan], host_at: &[(u64, Vec<u8>)], until: u64, step: u64) -> Vec<u8> {
    let words: Vec<Vec<u16>> = scans.iter().map(|s| s.words.clone()).collect();
    let mut k = 0usize;
    let source = FnSource::new(move |v: Variant, _u, out: &mut [u16]| {
        let w = &words[k % words.len()];
        k += 1;
        if w.len() != v.beams() {
            return 0;
        }
        out.copy_from_slice(w);
        out.len()
    });
    let mut lms = Emulator::new(source, Settings::default(), 0);
    let mut cop = CoProcessor::new(
        Params::DEFAULT
            .with_iterations(2)
            .validate()
            .expect("2 passes are valid"),
        SensorSetup::DEFAULT,
    );
    cop.start(0);
    let (mut sensor, mut host) = (Port::default(), Port::default());
    let mut ops = Ops::default();
    ops.0.u8(1); // the target's first byte: 1 + 1 % 4 = 2 passes
    let mut now = 0;
    let mut buf = [0u8; 4096];
    while now < until {
        now += step;
        let to_sensor = std::mem::take(&mut sensor.tx);
        lms.receive(now, &to_sensor);
        let mut arrived = Vec::new();
        loop {
            let n = lms.transmit(now, &mut buf);
            if n == 0 {
                break;
            }
            arrived.extend_from_slice(&buf[..n]);
        }
        while lms.next_event().is_some() {}
        if !arrived.is_empty() {
            ops.sensor_bytes(&arrived);
            sensor.rx.extend(&arrived);
        }
        for (_, req) in host_at.iter().filter(|(t, _)| *t > now - step && *t <= now) {
            ops.cop_host_bytes(req);
            host.rx.extend(req);
        }
        ops.advance(step);
        cop.poll(&mut sensor, &mut host, now).unwrap();
        host.tx.clear();
    }
    ops.0 .0
}

fn request(r: Request<'_>) -> Vec<u8> {
    let mut buf = [0u8; 64];
    let n = r.emit(0, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn main() {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let data = here.join("../../shared/data/carmen");
    let root = here.join("target/corpus");
    for target in [
        "framer",
        "parsers",
        "b0_frame",
        "features",
        "emulator",
        "pipeline",
        "coprocessor",
        "carmen",
        "capture",
    ] {
        let _ = std::fs::remove_dir_all(root.join(target));
    }
    let mut c = Corpus { root, files: 0 };

    let host_vectors: Vec<Vec<u8>> = HOST_VECTORS.iter().map(|s| hex(s)).collect();
    let sensor_vectors: Vec<Vec<u8>> = SENSOR_VECTORS.iter().map(|s| hex(s)).collect();
    let mut scans = Vec::new();
    for (log, step, max) in [
        ("csail-corrected.log.gz", 67, 4),
        ("belgioioso-corrected.log.gz", 97, 2),
        ("intel-corrected.log.gz", 301, 2),
        ("freiburg-campus-corrected.log.gz", 997, 2),
        ("orebro-corrected.log.gz", 79, 2),
    ] {
        scans.extend(log_scans(&data.join(log), step, max));
    }
    let narrowed: Vec<Scan> = scans.iter().take(3).flat_map(narrow).collect();
    scans.extend(narrowed);
    let b0s: Vec<Vec<u8>> = scans.iter().map(b0_telegram).collect();

    // parsers: raw telegrams and `cmd | data`.
    for (i, t) in host_vectors.iter().chain(&sensor_vectors).enumerate() {
        c.put("parsers", &format!("vector-{i:02}"), t);
        c.put(
            "parsers",
            &format!("vector-{i:02}-cmd-data"),
            &t[4..t.len() - 2],
        );
    }
    for (i, t) in b0s.iter().enumerate().step_by(3) {
        c.put("parsers", &format!("b0-{i:02}"), t);
        c.put(
            "parsers",
            &format!("b0-{i:02}-cmd-data"),
            &t[4..t.len() - 3],
        );
    }
    let (features0, f0, p0) = feature_telegrams(&scans[0], 7);
    for t in &features0 {
        c.put("parsers", &format!("feature-{:02X}", t[4]), t);
    }

    // framer: streams as they are on the line, split at a few places.
    let mut sensor_stream = Vec::new();
    sensor_stream.push(ACK);
    sensor_stream.extend(&sensor_vectors[0]);
    for (b0, f) in b0s.iter().zip([&features0]) {
        sensor_stream.extend(b0);
        f.iter().for_each(|t| sensor_stream.extend(t));
    }
    c.put(
        "framer",
        "sensor-stream",
        &FramerInput::encode(FRAMER_HANDSHAKE, &[3, 100, 733, 734], &sensor_stream),
    );
    let mut garbled = sensor_stream.clone();
    garbled.truncate(600);
    garbled.extend([0xFF, 0x02, 0x80, 0x20, 0x03]);
    garbled.extend(&b0s[1]);
    c.put(
        "framer",
        "sensor-truncated-then-good",
        &FramerInput::encode(FRAMER_HANDSHAKE, &[599, 605], &garbled),
    );
    c.put(
        "framer",
        "sensor-abandon",
        &FramerInput::encode(FRAMER_HANDSHAKE | FRAMER_ABANDON, &[600], &garbled),
    );
    for (i, b0) in b0s.iter().enumerate().step_by(4) {
        c.put(
            "framer",
            &format!("b0-{i:02}"),
            &FramerInput::encode(0, &[(i * 37 % 700) as u16], b0),
        );
    }
    let host_stream: Vec<u8> = host_vectors.concat();
    c.put(
        "framer",
        "host-requests",
        &FramerInput::encode(FRAMER_HOST_TO_SENSOR, &[7, 15, 16], &host_stream),
    );
    for (i, t) in sensor_vectors.iter().enumerate() {
        c.put(
            "framer",
            &format!("sensor-vector-{i}"),
            &FramerInput::encode(FRAMER_HANDSHAKE, &[], t),
        );
    }

    // b0_frame: selector (variant), units, bits, status, words.
    for (i, s) in scans.iter().enumerate() {
        let idx = Variant::ALL.iter().position(|v| *v == s.variant).unwrap() as u8;
        let mut out = Output::default();
        out.u8(idx)
            .u8(units_byte(s.units))
            .u8(match s.bits {
                RangeBits::Bits13 => 0,
                RangeBits::Bits14 => 1,
                RangeBits::Bits15 => 2,
            })
            .u8(0x10);
        for &w in &s.words {
            out.u16(w);
        }
        c.put("b0_frame", &format!("scan-{i:02}"), &out.0);
    }

    // features: telegram sequences (mode 0) and feature values (mode 1).
    for (i, s) in scans.iter().enumerate().step_by(2) {
        let (telegrams, f, p) = feature_telegrams(s, i as u32);
        let mut out = Output::default();
        out.u8(0);
        for t in &telegrams {
            let body = &t[5..t.len() - 3];
            out.u8(t[4]).u16(body.len() as u16).bytes(body);
        }
        c.put("features", &format!("telegrams-{i:02}"), &out.0);
        let mut out = Output::default();
        out.u8(1);
        encode_features(&mut out, i as u32, s.words.len() as u16, &f);
        out.u16(p.iterations).f32(p.sigma).f32(p.q).f32(p.tau);
        c.put("features", &format!("values-{i:02}"), &out.0);
    }
    let mut out = Output::default();
    out.u8(1);
    encode_features(&mut out, 0, 361, &f0);
    out.u16(p0.iterations).f32(p0.sigma).f32(p0.q).f32(p0.tau);
    c.put("features", "values-first", &out.0);

    // pipeline: real scans, default parameters, several pass counts.
    for (i, s) in scans.iter().enumerate() {
        let iterations = [30, 1, 5, 20][i % 4];
        let bits_ok = s.bits == RangeBits::Bits13;
        let words: Vec<u16> = if bits_ok {
            s.words.clone()
        } else {
            // 15-bit mm words do not fit the 13-bit mode: clip to 8.182 m.
            s.words.iter().map(|&w| w.min(8182)).collect()
        };
        let units = if bits_ok { s.units } else { Unit::Millimetre };
        c.put(
            "pipeline",
            &format!("scan-{i:02}-{iterations}"),
            &encode_pipeline_words(s.variant, iterations, units, &words),
        );
    }

    // emulator: a client's session.
    let config_request = {
        let mut cfg = lms_core::telegram::Config::ZERO;
        cfg.set_units_code(1);
        request(Request::WriteConfig(cfg))
    };
    let bring_up = [
        request(Request::OnRequest),
        request(Request::SensorType),
        request(Request::Status),
        request(Request::set_variant(Variant::Fov180Res50)),
        request(Request::InstallationMode {
            password: *b"SICK_LMS",
        }),
        request(Request::ReadConfig),
        config_request.clone(),
        request(Request::SetBaud(lms_core::telegram::Baud::B500000)),
        request(Request::Continuous),
    ];
    let mut ops = Ops::default();
    ops.0.u8(0x11).u8(0x01).u16(0); // pattern seed, settings, start time
    ops.advance(40_000).transmit(31);
    for r in &bring_up {
        ops.host_bytes(r).advance(60_000).transmit(255).events();
    }
    for _ in 0..6 {
        ops.advance(20_000).transmit(127).events();
    }
    ops.host_bytes(&request(Request::OnRequest))
        .advance(40_000)
        .transmit(255);
    ops.host_bytes(&request(Request::OneScan))
        .advance(40_000)
        .transmit(255);
    ops.host_bytes(&request(Request::Reset))
        .advance(2_000_000)
        .transmit(255)
        .events();
    c.put("emulator", "client-session", &ops.0 .0);
    for (i, r) in bring_up.iter().chain(&host_vectors).enumerate() {
        let mut ops = Ops::default();
        ops.0.u8(i as u8).u8((i * 37) as u8).u16(0);
        ops.advance(40_000)
            .host_bytes(r)
            .advance(100_000)
            .transmit(255)
            .events();
        c.put("emulator", &format!("request-{i:02}"), &ops.0 .0);
    }
    let mut ops = Ops::default();
    ops.0.u8(0).u8(0).u16(0);
    let mut bad = request(Request::Status);
    bad[5] ^= 1;
    ops.host_bytes(&bad).advance(20_000).transmit(8);
    ops.host_bytes(&[0x02, 0x05, 0x01, 0x00, 0x31])
        .advance(60_000)
        .transmit(8);
    c.put("emulator", "bad-checksum-and-address", &ops.0 .0);

    // coprocessor: recorded sessions.
    let cm: Vec<Scan> = scans
        .iter()
        .filter(|s| s.variant == Variant::Fov180Res50 && s.bits == RangeBits::Bits13)
        .map(|s| Scan {
            variant: s.variant,
            units: s.units,
            bits: s.bits,
            words: s.words.clone(),
        })
        .collect();
    let stream = request(Request::Continuous);
    let counters = {
        let mut b = [0u8; 16];
        let n = lms_core::telegram::emit_telegram(
            &mut b,
            Head::to_sensor(lms_core::telegram::features::REQ_COUNTERS),
            &[],
            None,
        )
        .unwrap();
        b[..n].to_vec()
    };
    c.put(
        "coprocessor",
        "bring-up-and-stream",
        &cop_session(&cm, &[(10_000, stream.clone())], 560_000, 1000),
    );
    c.put(
        "coprocessor",
        "one-scan-and-counters",
        &cop_session(
            &cm[1..],
            &[
                (470_000, request(Request::OneScan)),
                (480_000, counters),
                (490_000, request(Request::Status)),
                (500_000, request(Request::SensorType)),
            ],
            520_000,
            1000,
        ),
    );
    c.put(
        "coprocessor",
        "bring-up-coarse",
        &cop_session(&cm[2..], &[(5_000, stream)], 600_000, 5000),
    );
    c.put(
        "coprocessor",
        "bring-up-only",
        &cop_session(&cm, &[], 470_000, 2000),
    );
    readers(&mut c, &data, &b0s);
    println!("wrote {} seed files under {}", c.files, c.root.display());
}

/// Seeds of the `carmen` and `capture` targets: the first lines of each
/// log (buffer capacity, unit and cut bytes first), and captures of the
/// `B0`s (cut bytes and the magic flag first; the magic in the file).
fn readers(c: &mut Corpus, data: &Path, b0s: &[Vec<u8>]) {
    use std::io::BufRead;
    for (i, log) in [
        "csail-corrected.log.gz",
        "intel-corrected.log.gz",
        "orebro-corrected.log.gz",
        "acapulco-corrected.log.gz",
    ]
    .iter()
    .enumerate()
    {
        let text =
            test_support::open_text(&data.join(log)).unwrap_or_else(|e| panic!("{log}: {e}"));
        let mut head = Vec::new();
        let mut flaser = 0;
        for line in text.split(b'\n') {
            let line = line.unwrap_or_else(|e| panic!("{log}: {e}"));
            flaser += usize::from(line.starts_with(b"FLASER"));
            head.extend_from_slice(&line);
            head.push(b'\n');
            if flaser == 3 {
                break;
            }
        }
        let mut seed = vec![(i * 17) as u8, i as u8, 0xA0, 0x7F];
        seed.extend_from_slice(&head);
        c.put("carmen", &format!("log-{i}"), &seed);
    }
    for (i, chunk) in b0s.chunks(3).enumerate() {
        let mut w = capture::CaptureWriter::new(Vec::new()).unwrap();
        for (k, t) in chunk.iter().enumerate() {
            w.write(26_667 * k as u64, t).unwrap();
        }
        let mut seed = vec![0x00, 0xC0, 0x00];
        seed.extend_from_slice(&w.finish().unwrap());
        c.put("capture", &format!("capture-{i:02}"), &seed);
    }
}
