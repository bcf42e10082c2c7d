//! The evaluation's replicas of the core are the core: the §7–8 back end on
//! the core's segments, and the experimental smoothing pass with the spec's
//! options, give the extractor's results bit for bit.

use lms_core::{Extractor, Params};
use lms_lab::baselines::{extraction_from_d, features_from_segments, Tables};
use lms_lab::scenes::{sample, Family, NoiseSpec};
use lms_lab::variants::{self, Options};

#[test]
fn evaluate_back_end_and_smoothing_replicas_match_the_core_bit_for_bit() {
    let mut ex = Extractor::new();
    let mut scans = 0;
    for family in Family::ALL {
        for k in 0..6 {
            for (sigma, shared, iterations) in [(0.005, true, 30), (0.02, false, 7)] {
                let s = sample(
                    family,
                    k,
                    3,
                    NoiseSpec {
                        sigma,
                        dropout: 0.02,
                    },
                )
                .unwrap();
                let params = Params::PAPER
                    .with_sigma(sigma as f32)
                    .with_fit_shared_points(shared)
                    .with_iterations(iterations);
                let tables = Tables::for_frame(&s.frame);
                let mut trace = lms_core::Trace::new();
                let f = ex
                    .run_traced(&s.frame, &params.validate().unwrap(), &mut trace)
                    .clone();
                let (lines, corners) = features_from_segments(
                    &s.frame,
                    &tables,
                    s.frame.ranges(),
                    f.segments(),
                    &params,
                );
                assert_eq!(lines, f.lines().to_vec(), "{family:?} {k}");
                assert_eq!(corners, f.corners().to_vec(), "{family:?} {k}");
                let d = trace.mahalanobis().to_vec();
                let smoothed = ex.smoothed().to_vec();
                let x = extraction_from_d(&s.frame, &tables, &d, &params);
                assert_eq!(x.segments, f.segments().to_vec());
                assert_eq!(x.lines, f.lines().to_vec());

                let (r, dv) = variants::smooth(&s.frame, &params, &Options::default());
                assert_eq!(r, smoothed, "{family:?} {k}: smoothed ranges");
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&dv), bits(&d), "{family:?} {k}: D");
                let v = variants::extract(&s.frame, &tables, &params, &Options::default());
                assert_eq!(v.lines, f.lines().to_vec());
                scans += 1;
            }
        }
    }
    assert_eq!(scans, 48);
}
