//! The whole pipeline (`Extractor::run`: smoothing passes, segmentation, line
//! fits, merging, corners) on the real 361-beam frames of the CSAIL log, at
//! 1, 20 and 30 passes (the paper's scales).
//!
//! One benchmark iteration runs every frame of the log once (406 frames), so
//! the reported time is for the whole log and the throughput is in frames
//! per second: time per frame = time / 406. Flat sampling with 10 samples
//! keeps each case near 3 s even at 30 passes.
//!
//! `cargo bench -p lms-core --bench pipeline`

use std::hint::black_box;
use std::io::{BufRead, BufReader};
use std::time::Duration;

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use lms_core::{Extractor, Frame, Invalid, Params, Variant};

const LOG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/carmen/csail-corrected.log.gz"
);

/// All FLASER frames of the log (361 beams; values ≥ 81.83 m are cm error codes).
fn load_frames() -> Vec<Frame> {
    let file = std::fs::File::open(LOG).unwrap_or_else(|e| panic!("cannot open {LOG}: {e}"));
    let reader = BufReader::new(flate2::read::GzDecoder::new(file));
    let mut frames = Vec::new();
    for line in reader.lines() {
        let line = line.expect("read error");
        let mut fields = line.split_ascii_whitespace();
        if fields.next() != Some("FLASER") {
            continue;
        }
        let n: usize = fields.next().and_then(|s| s.parse().ok()).expect("n");
        assert_eq!(n, 361, "the CSAIL log has 361-beam frames");
        let ranges: Vec<f32> = fields.take(n).map(|s| s.parse().expect("range")).collect();
        let mut frame =
            Frame::from_metres(Variant::Fov180Res50.geometry(), &ranges).expect("frame");
        for (j, &r) in ranges.iter().enumerate() {
            if r >= 81.83 {
                let cm = (r * 100.0).round() as u16;
                frame.set_invalid(j, Invalid::from_code_offset(8191u16.saturating_sub(cm)));
            }
        }
        frames.push(frame);
    }
    assert!(!frames.is_empty(), "no FLASER frames in {LOG}");
    frames
}

fn pipeline(c: &mut Criterion) {
    let frames = load_frames();
    let mut group = c.benchmark_group(format!("pipeline_csail_{}_frames", frames.len()));
    group.throughput(Throughput::Elements(frames.len() as u64));
    group.sampling_mode(SamplingMode::Flat);
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    for passes in [1u16, 20, 30] {
        let params = Params {
            iterations: passes,
            ..Params::default()
        };
        group.bench_with_input(BenchmarkId::new("passes", passes), &params, |b, params| {
            let mut ex = Extractor::new();
            b.iter(|| {
                let mut lines = 0usize;
                for frame in &frames {
                    let features =
                        ex.run(black_box(frame), &params.validate().expect("valid params"));
                    lines += features.lines().len();
                }
                black_box(lines)
            });
        });
    }
    group.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
