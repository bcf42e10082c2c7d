//! `panic-proof`: a link-time proof that the core, as the firmware uses it,
//! contains no reachable panic.
//!
//! Built for the firmware's target with the firmware's release profile (LTO,
//! its per-package opt-levels, one codegen unit) and the core's firmware features,
//! this program drives every entry point of `lms-core` that the firmware
//! reaches — the co-processor's `poll` over two serial ports, and directly
//! the framer, the telegram parsers and emitters, `B0` decoding, the feature
//! telegrams, the LMS emulator and the pipeline with any frame and any
//! parameters — on inputs the optimiser cannot see: every byte, count,
//! time, flag and float comes through [`black_box`]. Its panic handler calls
//! `__reachable_panic_in_firmware`, a symbol no object defines, so the
//! program links only if optimisation removed every call to the panic
//! handler, i.e. if no panic is reachable from those entry points for any
//! input:
//!
//! ```sh
//! cd firmware
//! cargo build --release --features panic-proof --bin panic-proof   # the firmware's ELF is untouched
//! ```
//!
//! A panic path in the core fails the link with
//! `undefined symbol: __reachable_panic_in_firmware`. The ELF is a proof
//! artefact only: it is never run. What it does not cover — the board shell
//! and its crates (UART queues, logger, semihosting) — is listed in the
//! README's "Robustness" section, with `firmware/panic-sites.sh`, which
//! lists the panic call sites left in the real firmware and checks that none
//! comes from the core.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;
use embedded_io::{ErrorType, Read, ReadReady, Write};

use lms_core::device::coprocessor::{CoProcessor, SensorSetup};
use lms_core::device::emulator::{Emulator, FnSource, ScanSource, Settings};
use lms_core::frame::MAX_BEAMS;
use lms_core::telegram::features::{emit_features, EchoedParams, FeatureAssembler};
use lms_core::telegram::{
    Config, Direction, Event, Framer, Handshake, MeasuredValues, MeasuredView, RangeBits, Reply,
    Request, SensorStatus, StatusBlock, Telegram, MAX_TELEGRAM_LEN,
};
use lms_core::Unit;
use lms_core::{Extractor, Frame, Geometry, Invalid, Params, ValidParams, Variant};
// The device's interrupt vector table, as in the firmware.
use stm32f4 as _;

/// A port whose bytes, counts, readiness and failures are unknown to the
/// optimiser. `read` may even return more than it was asked for (an
/// `embedded-io` contract violation the core must survive); `write` accepts
/// everything, as the firmware's blocking UART does (`write_all` in
/// `embedded-io` itself panics on a port that returns `Ok(0)`).
struct OpaquePort;

/// A port failure, decided opaquely.
type PortError = embedded_io::ErrorKind;

impl ErrorType for OpaquePort {
    type Error = PortError;
}

impl Read for OpaquePort {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        if black_box(false) {
            return Err(PortError::Other);
        }
        black_box(&mut *buf);
        Ok(black_box(buf.len()))
    }
}

impl ReadReady for OpaquePort {
    fn read_ready(&mut self) -> Result<bool, PortError> {
        if black_box(false) {
            return Err(PortError::Other);
        }
        Ok(black_box(false))
    }
}

impl Write for OpaquePort {
    fn write(&mut self, buf: &[u8]) -> Result<usize, PortError> {
        if black_box(false) {
            return Err(PortError::Other);
        }
        black_box(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), PortError> {
        Ok(())
    }
}

impl lms_core::device::coprocessor::WriteRoom for OpaquePort {
    fn write_room(&mut self) -> Result<usize, PortError> {
        if black_box(false) {
            return Err(PortError::Other);
        }
        Ok(black_box(usize::MAX))
    }
}

/// Any `f32`, including NaN, infinities, zero, negatives and subnormals.
fn any_f32() -> f32 {
    f32::from_bits(black_box(0))
}

/// Parameters with every field unknown (`Extractor::run` validates them).
fn any_params() -> Params {
    Params::from_sources(any_f32, || black_box(30), || black_box(true))
}

#[entry]
fn main() -> ! {
    // Big state lives in statics in the firmware; here on the stack of an
    // ELF that never runs.
    let mut cop = CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT);
    cop.start(black_box(0));
    let mut extractor = Extractor::new();
    let mut framer = Framer::new(Direction::SensorToHost, black_box(Handshake::Expected));
    let mut host_framer = Framer::new(Direction::HostToSensor, black_box(Handshake::Ignored));
    let mut assembler = FeatureAssembler::new();
    let mut emulator = Emulator::new(
        FnSource::new(|_: Variant, _: Unit, out: &mut [u16]| {
            black_box(&mut *out);
            black_box(out.len())
        }),
        Settings::DEFAULT,
        black_box(0),
    );
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    let mut bytes = [0u8; 2 * MAX_TELEGRAM_LEN];
    let mut out = [0u8; MAX_TELEGRAM_LEN];
    let (mut sensor, mut host) = (OpaquePort, OpaquePort);
    loop {
        black_box(&mut bytes);
        let len = black_box(bytes.len());
        let input = bytes.get(..len).unwrap_or_default();
        let now_us = black_box(0u64);
        match black_box(0u8) {
            0 => reach_coprocessor(&mut cop, &mut sensor, &mut host, now_us),
            1 => {
                let f = if black_box(false) {
                    &mut host_framer
                } else {
                    &mut framer
                };
                reach_framer(f, input, &mut assembler, &mut frame);
            }
            2 => reach_parsers(input, &mut out, &mut assembler),
            3 => reach_pipeline(&mut extractor, &mut frame, &mut host),
            _ => reach_emulator(&mut emulator, input, &mut out, now_us),
        }
    }
}

/// The co-processor, exactly as the firmware's loop calls it.
fn reach_coprocessor(
    cop: &mut CoProcessor,
    sensor: &mut OpaquePort,
    host: &mut OpaquePort,
    now_us: u64,
) {
    let _ = black_box(cop.poll(sensor, host, now_us));
    if black_box(false) {
        cop.note_sensor_overflow();
    }
    cop.note_sensor_lost(black_box(7));
    black_box(cop.counters());
    black_box(cop.features().lines().len());
    black_box(cop.link().step());
}

/// The framer in arbitrary chunks, both directions, and what is done with
/// its telegrams.
fn reach_framer(f: &mut Framer, input: &[u8], assembler: &mut FeatureAssembler, frame: &mut Frame) {
    f.set_handshake(black_box(Handshake::Expected));
    let mut rest = input;
    loop {
        let fed = f.feed(rest);
        rest = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => {
                let _ = black_box(Request::parse(&t));
                let _ = black_box(Reply::parse(&t));
                if let Ok(view) = MeasuredView::parse(&t) {
                    let _ = black_box(view.to_frame_into(RangeBits::Bits13, frame));
                    let _ = black_box(view.to_frame(RangeBits::Bits15));
                    black_box(view.to_values(black_box(0x10)));
                }
                let _ = black_box(MeasuredValues::parse(&t));
                if let Ok(a) = assembler.push(&t) {
                    black_box(&a);
                }
            }
            Some(e) => {
                black_box(e);
            }
            None => break,
        }
    }
    if black_box(false) {
        black_box(f.abandon());
    }
    if black_box(false) {
        black_box(f.discard());
    }
    black_box(f.stats());
}

/// Parsers and emitters on bytes that did not come through the framer
/// (checked and unchecked views).
fn reach_parsers(input: &[u8], out: &mut [u8], assembler: &mut FeatureAssembler) {
    let direction = if black_box(false) {
        Direction::HostToSensor
    } else {
        Direction::SensorToHost
    };
    let t = Telegram::new_unchecked(input, direction);
    let _ = black_box(Telegram::new_checked(input, direction));
    black_box((t.command(), t.data(), t.status(), t.payload(), t.crc()));
    black_box(t.compute_crc());
    if let Ok(r) = Request::parse(&t) {
        let _ = black_box(r.emit(black_box(0), out));
    }
    if let Ok(r) = Reply::parse(&t) {
        let _ = black_box(r.emit(black_box(0), black_box(SensorStatus(0x10)), out));
    }
    if let Ok(v) = MeasuredView::new(input) {
        let _ = black_box(v.to_frame(RangeBits::Bits14));
    }
    if let Some(block) = StatusBlock::from_slice(input) {
        black_box((block.fields(), block.variant(), block.baud(), block.units()));
    }
    if let Some(config) = Config::from_slice(input) {
        black_box((config.blanking(), config.units_code()));
    }
    if let Ok(a) = assembler.push(&t) {
        black_box(&a);
    }
}

/// The pipeline on any frame and any parameters.
fn reach_pipeline(extractor: &mut Extractor, frame: &mut Frame, host: &mut OpaquePort) {
    let geometry = Geometry {
        first_bearing: any_f32(),
        step: any_f32(),
    };
    let n = black_box(MAX_BEAMS);
    if let Ok(mut f) = Frame::new(geometry, n) {
        for j in 0..black_box(n) {
            if black_box(false) {
                f.set_invalid(j, Invalid::OtherCode(black_box(0)));
            } else {
                f.set_metres(j, any_f32());
            }
        }
        *frame = f;
    }
    let mut ranges = [0.0f32; MAX_BEAMS];
    black_box(&mut ranges);
    if let Ok(f) = Frame::from_metres(geometry, ranges.get(..n).unwrap_or_default()) {
        black_box(f.valid_count());
    }
    black_box(MeasuredValues::from_frame(
        frame,
        Unit::Millimetre,
        RangeBits::Bits14,
        black_box(0x10),
    ));
    let params = any_params();
    if let Ok(params) = params.validate() {
        let features = extractor.run(frame, &params);
        black_box(features.lines().len());
        let mut trace = lms_core::Trace::new();
        let features = extractor.run_traced(frame, &params, &mut trace);
        black_box(features.lines().len());
        black_box(trace.mahalanobis());
    }
    black_box(extractor.smoothed());
    let _ = emit_features(
        black_box(0),
        black_box(0),
        &EchoedParams::from(&params),
        extractor.features(),
        black_box(0),
        |t| host.write_all(t),
    );
}

/// The LMS emulator fed any host bytes at any times.
fn reach_emulator<S: ScanSource>(
    emulator: &mut Emulator<S>,
    input: &[u8],
    out: &mut [u8],
    now_us: u64,
) {
    emulator.receive(now_us, input);
    let n = emulator.transmit(black_box(0), out);
    black_box(out.get(..n));
    while let Some(e) = emulator.next_event() {
        black_box(e);
    }
    black_box(emulator.next_wakeup_us());
    if black_box(false) {
        emulator.power_on(now_us);
    }
}

/// Every panic lands here; the symbol it calls exists nowhere, so the link
/// succeeds only if this handler is unreachable.
#[panic_handler]
#[allow(unsafe_code)]
fn panic(_info: &PanicInfo) -> ! {
    // SAFETY: never executed: a binary that references this symbol does not link.
    unsafe { __reachable_panic_in_firmware() }
}

extern "C" {
    fn __reachable_panic_in_firmware() -> !;
}
