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
