//! The whole pipeline (`Extractor::run`: smoothing passes, segmentation, line
//! fits, merging, corners) on the real 361-beam frames of the CSAIL log: the
//! defaults at 1, 5 (theirs) and 30 passes (the paper's scale), and at the
//! log's own σ (10 mm, what `host-bridge extract LOG` uses without flags)
//! with and without per-turn extraction (`Params::per_turn`, §10 (d)); at
//! 30 passes with `Params::V2` (no footprint weights, no merge across
//! rejected segments), at 5 and 10 mm, for the cost of §10 (e), (f) as a
//! ratio on the same machine; and at 10 mm with the defaults less some of
//! their additions, for the cost of each: [`CONSECUTIVE_WINDOWS`] (windows
//! of consecutive beams, for the cost of same-turn windows, §10 (a)),
//! [`NO_ANCHOR_GATE`] (for the cost of the anchor gate and the turns'
//! offsets) and [`ARC_PAIRS_KEPT`] (for the cost of the arcs' pairs and of
//! the strided pass at every stride).
//!
//! One benchmark iteration runs every frame of the log once (406 frames), so
//! the reported time is for the whole log and the throughput is in frames
//! per second: time per frame = time / 406. Flat sampling with 10 samples
//! keeps each case near 3 s even at 30 passes.
//!
//! `cargo bench -p lms-core --bench pipeline`

use std::hint::black_box;
use std::time::Duration;

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use lms_core::{test_support, Extractor, Frame, Params};

/// The defaults with pairs of lines kept whatever a circle says of them.
const ARC_PAIRS_KEPT: Params = Params::DEFAULT.with_arc_pairs(false);

/// [`ARC_PAIRS_KEPT`] with no anchor gate on the merges and no turn offsets
/// in the fits' χ².
const NO_ANCHOR_GATE: Params = ARC_PAIRS_KEPT
    .with_merge_anchor_gate(f32::INFINITY)
    .with_turn_offsets(false);

/// [`NO_ANCHOR_GATE`] with windows of consecutive beams in every mode
/// (§2–6) and no work bound on split before reject.
const CONSECUTIVE_WINDOWS: Params = NO_ANCHOR_GATE
    .with_same_turn_windows(false)
    .with_split_budget(0);

/// All FLASER frames of the CSAIL log through the one CARMEN reader
/// (`lms_core::test_support`; 361 beams, cm error codes invalid).
fn load_frames() -> Vec<Frame> {
    let frames = test_support::load_frames("csail-corrected", usize::MAX);
    assert!(!frames.is_empty(), "no FLASER frames in the CSAIL log");
    assert!(
        frames.iter().all(|f| f.len() == 361),
        "the CSAIL log has 361-beam frames"
    );
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
    let cm = Params::default().with_sigma(0.01);
    let passes = Params::DEFAULT.iterations;
    let cases = [1u16, passes, 30]
        .map(|passes| {
            let params = Params::default().with_iterations(passes);
            (BenchmarkId::new("passes", passes), params)
        })
        .into_iter()
        .chain([
            (BenchmarkId::new("sigma_10mm", passes), cm),
            (
                BenchmarkId::new("sigma_10mm_per_turn", passes),
                cm.with_per_turn(true),
            ),
            (
                BenchmarkId::new("arc_pairs_kept_sigma_10mm", passes),
                ARC_PAIRS_KEPT.with_sigma(0.01),
            ),
            (
                BenchmarkId::new("no_anchor_gate_sigma_10mm", passes),
                NO_ANCHOR_GATE.with_sigma(0.01),
            ),
            (
                BenchmarkId::new("consecutive_windows_sigma_10mm", passes),
                CONSECUTIVE_WINDOWS.with_sigma(0.01),
            ),
            (BenchmarkId::new("v2", 30), Params::V2),
            (
                BenchmarkId::new("v2_sigma_10mm", 30),
                Params::V2.with_sigma(0.01),
            ),
        ]);
    for (id, params) in cases {
        group.bench_with_input(id, &params, |b, params| {
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
