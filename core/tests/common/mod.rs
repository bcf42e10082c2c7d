//! Shared by the integration tests that run the co-processor in memory
//! (each test uses part of it).
#![allow(dead_code)]

/// The test room seen from its middle: a wall 3 m ahead, side walls 2 m
/// away, a box 1.5 m ahead between −0.2 and 0.1 rad; the distance (m) along
/// bearing `phi` (rad), `+inf` where nothing is hit.
pub fn room_distance_m(phi: f64) -> f64 {
    let (c, s) = (phi.cos(), phi.sin());
    let mut d = f64::INFINITY;
    if c > 1e-6 {
        d = d.min(3.0 / c);
    }
    if s.abs() > 1e-6 {
        d = d.min(2.0 / s.abs());
    }
    if (-0.2..0.1).contains(&phi) {
        d = d.min(1.5 / c);
    }
    d
}

/// One step of the simulated LMS on the co-processor's sensor port at
/// `now_us`: it hears what the co-processor wrote since the last step,
/// sends what it has due (into `port.rx`, and to `sent`), and its events
/// are dropped.
pub fn lms_step<S: lms_core::device::emulator::ScanSource>(
    lms: &mut lms_core::device::emulator::Emulator<S>,
    port: &mut lms_core::test_support::Port,
    now_us: u64,
    mut sent: impl FnMut(&[u8]),
) {
    let mut buf = [0u8; 4096];
    let to_sensor = std::mem::take(&mut port.tx);
    lms.receive(now_us, &to_sensor);
    loop {
        let n = lms.transmit(now_us, &mut buf);
        if n == 0 {
            break;
        }
        port.rx.extend(&buf[..n]);
        sent(&buf[..n]);
    }
    while lms.next_event().is_some() {}
}

/// A wall `x·cos α + y·sin α = r` seen at 0.5°, the odd beams (the second
/// mirror turn) from a pose moved `offset` metres towards the wall; a
/// ±`ripple` deterministic pattern as noise. Beams off the wall's front
/// half: 0 (ALGORITHM.md §10: tests/same_turn.rs, tests/per_turn.rs).
pub fn interleaved_wall(alpha: f32, r: f32, offset: f32, ripple: f32) -> lms_core::Frame {
    let mut frame = lms_core::Frame::for_variant(lms_core::Variant::Fov180Res50);
    for j in 0..frame.len() {
        let phi = frame.geometry().bearing(j);
        let c = libm::cosf(phi - alpha);
        if c < 0.25 {
            frame.set_metres(j, 0.0);
            continue;
        }
        let shift = if j % 2 == 1 { offset } else { 0.0 };
        let noise = ripple * (((j * 7919) % 11) as f32 / 5.0 - 1.0);
        frame.set_metres(j, (r - shift) / c + noise);
    }
    frame
}

/// A 180°/1° scan (one mirror turn) of a wall 3 m away, normal at 0.4 rad,
/// clipped at incidences over 72.5°, ±4 mm deterministic noise.
pub fn one_degree_room() -> lms_core::Frame {
    let mut frame = lms_core::Frame::for_variant(lms_core::Variant::Fov180Res100);
    for j in 0..frame.len() {
        let phi = frame.geometry().bearing(j);
        let c = libm::cosf(phi - 0.4).max(0.3);
        let noise = 0.004 * (((j * 31) % 7) as f32 / 3.0 - 1.0);
        frame.set_metres(j, 3.0 / c + noise);
    }
    frame
}
