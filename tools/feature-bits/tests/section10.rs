//! The ALGORITHM.md §10 options in a build with and without them (feature
//! `section10` of the core). `cargo test -p feature-bits --test section10`
//! builds the core without it, as the firmware does; `cargo test
//! --workspace` with it (the host crates enable it). The defaults give the
//! same bits either way: CI compares `feature-bits` output with and without
//! the feature on real logs (`.ci/run`), and the pinned digests hold in
//! both builds.

use lms_core::params::SECTION10_BUILT;
use lms_core::{Extractor, Features, Frame, ParamError, Params, Trace, Variant};

/// A corridor wall seen at grazing incidence, with a 12 mm offset between
/// the two interleaved mirror turns: every §10 option changes its result.
fn grazing_wall() -> Frame {
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    for j in 0..frame.len() {
        let phi = frame.geometry().bearing(j);
        let turn = if j % 2 == 0 { 0.0 } else { 0.012 };
        let c = (f64::from(phi) - 0.6).cos() as f32;
        frame.set_metres(j, if c > 0.2 { (1.2 + turn) / c } else { 0.0 });
    }
    frame
}

/// The grazing wall, and the defaults' features and `D` on it.
fn defaults_on_the_grazing_wall() -> (Frame, Features, Vec<f32>) {
    let frame = grazing_wall();
    let (mut ex, mut trace) = (Extractor::new(), Trace::new());
    let default = ex
        .run_traced(&frame, &Params::DEFAULT.validate().unwrap(), &mut trace)
        .clone();
    let default_d = trace.mahalanobis().to_vec();
    (frame, default, default_d)
}

#[test]
fn each_option_is_refused_by_name_or_changes_the_result() {
    let options: [(&str, Params); 3] = [
        ("grazing_noise", Params::DEFAULT.with_grazing_noise(0.5)),
        ("fit_sigma", Params::DEFAULT.with_fit_sigma(0.02)),
        ("per_turn", Params::DEFAULT.with_per_turn(true)),
    ];
    let (frame, default, default_d) = defaults_on_the_grazing_wall();
    let mut trace = Trace::new();
    assert!(!default.lines().is_empty());
    for (name, params) in options {
        match (params.validate(), SECTION10_BUILT) {
            (Ok(valid), true) => {
                let mut ex = Extractor::new();
                let got = ex.run_traced(&frame, &valid, &mut trace);
                let same = got.lines() == default.lines()
                    && got.segments() == default.segments()
                    && trace.mahalanobis() == &default_d[..];
                assert!(!same, "{name} changes nothing on the grazing wall");
            }
            (Err(e), false) => {
                assert_eq!(e, ParamError::NotInBuild { option: name });
                let text = e.to_string();
                assert!(text.contains(name) && text.contains("section10"), "{text}");
            }
            (result, built) => panic!("{name}: {result:?} with section10 built in: {built}"),
        }
    }
}

#[test]
fn same_turn_windows_are_in_every_build_and_can_be_switched_off() {
    // On by default (ALGORITHM.md §10 (a)): built with and without the
    // other §10 options, and windows of consecutive beams (with no work
    // bound, no anchor gate, no turn offsets and pairs kept, as
    // `Params::V2` has them) validate in both and change the result.
    const { assert!(Params::DEFAULT.same_turn_windows) };
    let consecutive_windows = Params::DEFAULT
        .with_same_turn_windows(false)
        .with_split_budget(0)
        .with_merge_anchor_gate(f32::INFINITY)
        .with_turn_offsets(false)
        .with_arc_pairs(false);
    let (frame, default, default_d) = defaults_on_the_grazing_wall();
    let (mut ex, mut trace) = (Extractor::new(), Trace::new());
    let windows = consecutive_windows
        .validate()
        .expect("consecutive windows in every build");
    let got = ex.run_traced(&frame, &windows, &mut trace);
    assert!(
        got.segments() != default.segments() && trace.mahalanobis() != &default_d[..],
        "same-turn windows change nothing on the grazing wall"
    );
}

/// `params::HOST_ONLY`, which the host's co-processor paths refuse, names
/// exactly what validation refuses in a build without the options: each of
/// them set by name to another value is refused naming it here, and runs
/// where the options are built in.
#[test]
fn the_host_only_list_is_what_validation_refuses() {
    use lms_core::params::{field, Value, HOST_ONLY};
    for name in HOST_ONLY {
        let other = match (field(name).expect("a parameter").get)(&Params::DEFAULT) {
            Value::Real(x) => format!("{}", x + 1.0),
            Value::Flag(b) => format!("{}", !b),
            Value::Count(n) => format!("{}", n + 1),
        };
        let mut p = Params::DEFAULT;
        p.set(name, &other).unwrap();
        match (p.validate(), SECTION10_BUILT) {
            (Err(e), false) => assert_eq!(e, ParamError::NotInBuild { option: name }),
            (Ok(_), true) => {}
            (result, built) => {
                panic!("{name}={other}: {result:?} with section10 built in: {built}")
            }
        }
    }
}
