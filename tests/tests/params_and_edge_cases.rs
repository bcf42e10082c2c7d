//! Parameter validation and degenerate frames (no panic, sensible output).

use lms_core::frame::{Frame, FrameError, Geometry, Invalid, Variant, MAX_BEAMS};
use lms_core::{Extractor, ParamError, Params, ValidParams};

fn frame_with(n: usize, range: impl Fn(usize) -> f32) -> Frame {
    let g = Geometry {
        first_bearing: -50f32.to_radians(),
        step: (100.0 / (n.max(2) - 1) as f32).to_radians(),
    };
    let ranges: Vec<f32> = (0..n).map(range).collect();
    Frame::from_metres(g, &ranges).expect("a valid frame")
}

#[test]
fn nonsense_parameters_are_refused_with_the_right_error() {
    let frame = Frame::from_metres(Variant::Fov180Res50.geometry(), &[2.0; 361]).unwrap();
    let mut ex = Extractor::new();
    let d = Params::default();
    // (parameters, the field out of its range)
    let cases: Vec<(Params, &str)> = vec![
        (d.with_sigma(0.0), "sigma"),
        (d.with_sigma(-0.005), "sigma"),
        (d.with_sigma(f32::NAN), "sigma"),
        (d.with_sigma(f32::INFINITY), "sigma"),
        (d.with_q(-1e-6), "q"),
        (d.with_q(f32::NAN), "q"),
        (d.with_iterations(0), "iterations"),
        (d.with_tau(0.0), "tau"),
        (d.with_tau(-9.0), "tau"),
        (d.with_tau(f32::NAN), "tau"),
        (d.with_min_points(2), "min_points"),
        (d.with_max_chi2(0.0), "max_chi2"),
        (d.with_max_chi2(f32::NAN), "max_chi2"),
        (d.with_min_length(-0.1), "min_length"),
        (d.with_merge_gate(0.0), "merge_gate"),
        (d.with_corner_gap(f32::NAN), "corner_gap"),
        (d.with_min_corner_angle_deg(91.0), "min_corner_angle_deg"),
        (
            d.with_min_corner_angle_deg(f32::NAN),
            "min_corner_angle_deg",
        ),
    ];
    for (params, name) in cases {
        let field = lms_core::params::field(name).unwrap();
        let want = ParamError::OutOfRange {
            name: field.name,
            range: field.range,
        };
        assert_eq!(params.validate(), Err(want), "{params:?}");
        assert_eq!(ValidParams::try_from(params), Err(want), "{params:?}");
    }
    // Several faults: one error, and the run refuses.
    let bad = d.with_sigma(f32::NAN).with_tau(0.0).with_iterations(0);
    assert!(bad.validate().is_err());
    // The defaults and the edges of the valid ranges pass.
    for ok in [d, d.with_iterations(1), d.with_q(0.0).with_min_points(3)] {
        let valid = ok.validate().expect("valid");
        assert_eq!(*valid.get(), ok);
        ex.run(&frame, &valid);
    }
}

#[test]
fn frames_of_the_wrong_size_are_refused_at_construction() {
    let g = Variant::Fov180Res50.geometry();
    assert_eq!(
        Frame::from_metres(g, &[1.0; 2]).unwrap_err(),
        FrameError::BeamCount { got: 2 }
    );
    assert_eq!(
        Frame::from_metres(g, &[1.0; MAX_BEAMS + 1]).unwrap_err(),
        FrameError::BeamCount { got: MAX_BEAMS + 1 }
    );
    let bad = Geometry {
        first_bearing: 0.0,
        step: f32::NAN,
    };
    assert_eq!(
        Frame::from_metres(bad, &[1.0; 10]).unwrap_err(),
        FrameError::BadGeometry
    );
}

#[test]
fn a_frame_with_every_beam_invalid_gives_no_features() {
    let params = Params::default();
    let mut ex = Extractor::new();
    // Zeros, NaN and infinities: invalid on construction.
    let zeros = Frame::from_metres(Variant::Fov180Res50.geometry(), &[0.0; 361]).unwrap();
    let mut odd: Vec<f32> = vec![f32::NAN; 361];
    odd[10] = f32::INFINITY;
    odd[11] = -3.0;
    let odd = Frame::from_metres(Variant::Fov180Res50.geometry(), &odd).unwrap();
    // Valid-looking ranges overwritten with every error code.
    let mut codes = Frame::from_metres(Variant::Fov180Res100.geometry(), &[3.0; 181]).unwrap();
    let kinds = [
        Invalid::NoEcho,
        Invalid::Dazzle,
        Invalid::Overflow,
        Invalid::LowSignal,
        Invalid::ChannelError,
        Invalid::AboveMax,
        Invalid::OtherCode(3),
    ];
    for j in 0..codes.len() {
        codes.set_invalid(j, kinds[j % kinds.len()]);
    }
    for frame in [&zeros, &odd, &codes] {
        assert_eq!(frame.valid_count(), 0);
        let mut trace = lms_core::Trace::new();
        ex.run_traced(frame, &params.validate().unwrap(), &mut trace);
        let f = ex.features();
        assert!(
            f.segments().is_empty()
                && f.edges().is_empty()
                && f.lines().is_empty()
                && f.corners().is_empty()
        );
        assert_eq!(f.stats().valid_beams, 0);
        assert_eq!(f.stats().invalid_windows as usize, frame.len() - 2);
        assert!(trace.mahalanobis().iter().all(|d| *d == f32::INFINITY));
        // Invalid beams are never modified.
        assert_eq!(ex.smoothed(), frame.ranges());
    }
}

#[test]
fn three_beams_and_the_largest_frame_run() {
    let params = Params::default();
    let mut ex = Extractor::new();

    // 3 beams: one window; a collinear one does not break, but a segment of
    // 3 points is below min_points (5), so it is dropped and counted.
    let wall = |j: usize| 2.0 / ((-50f32 + 50.0 * j as f32).to_radians()).cos();
    let three = frame_with(3, wall);
    let mut trace = lms_core::Trace::new();
    ex.run_traced(&three, &params.validate().unwrap(), &mut trace);
    let f = ex.features();
    assert_eq!(trace.mahalanobis().len(), 1);
    assert!(
        trace.mahalanobis()[0] < 1.0,
        "D = {}",
        trace.mahalanobis()[0]
    );
    assert!(f.segments().is_empty() && f.lines().is_empty());
    assert_eq!(f.stats().short_segments, 1);
    ex.run(&three, &params.with_min_points(3).validate().unwrap());
    let f = ex.features();
    assert_eq!(f.segments().len(), 1);

    // 401 beams (100°/0.25°): a wall at 3 m, one line, no corner.
    let g = Variant::Fov100Res25.geometry();
    let ranges: Vec<f32> = (0..401).map(|j| 3.0 / g.bearing(j).cos()).collect();
    let big = Frame::from_metres(g, &ranges).unwrap();
    ex.run_traced(&big, &params.validate().unwrap(), &mut trace);
    let f = ex.features();
    assert_eq!(ex.smoothed().len(), 401);
    assert_eq!(trace.mahalanobis().len(), 399);
    assert_eq!(f.lines().len(), 1, "{:?}", f.lines());
    assert!((f.lines()[0].r - 3.0).abs() < 1e-3 && f.lines()[0].alpha.abs() < 1e-3);
    assert!(f.corners().is_empty());

    // 401 beams of alternating near/far ranges: every window of §2
    // (consecutive beams) breaks, no segment, and nothing panics. Same-turn
    // windows (the defaults) see one constant range per turn and hold
    // segments over both turns (past the split's work bound they reach §7
    // whole), but no line fits both turns' beams.
    let zigzag: Vec<f32> = (0..401)
        .map(|j| if j % 2 == 0 { 1.0 } else { 80.0 })
        .collect();
    let zz = Frame::from_metres(g, &zigzag).unwrap();
    let spec_windows = params.with_same_turn_windows(false);
    ex.run(&zz, &spec_windows.validate().unwrap());
    let f = ex.features();
    assert!(f.segments().is_empty() && f.lines().is_empty());
    ex.run(&zz, &params.validate().unwrap());
    assert!(ex.features().lines().is_empty());

    // Mixed: a single valid beam between invalid ones, and the maximum
    // number of passes.
    let mut sparse = Frame::from_metres(g, &ranges).unwrap();
    for j in (0..401).filter(|j| j % 3 != 0) {
        sparse.set_invalid(j, Invalid::NoEcho);
    }
    ex.run(
        &sparse,
        &params
            .with_iterations(lms_core::params::MAX_ITERATIONS)
            .validate()
            .unwrap(),
    );
    let f = ex.features();
    assert!(f.segments().is_empty());
    assert_eq!(ex.smoothed(), sparse.ranges());
}
