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
