//! A tiny local ray caster for random polygon scenes, independent of
//! `lms-scene`, used where the tests want many random frames (reference
//! agreement) or one exact wall (line statistics). Everything is `f64`; the
//! ranges handed to the core are rounded to `f32` once.

use rand::Rng;
use rand_distr::{Distribution, Normal};

/// A wall: the segment from `p` to `q` (sensor frame, metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    /// One end.
    pub p: [f64; 2],
    /// The other end.
    pub q: [f64; 2],
}

/// Distance along the ray at bearing `phi` from the origin to the nearest
/// wall, if any.
pub fn cast(walls: &[Wall], phi: f64) -> Option<f64> {
    let (dx, dy) = (phi.cos(), phi.sin());
    let mut best: Option<f64> = None;
    for w in walls {
        // Solve t·(dx, dy) = p + s·(q − p), t > 0, s ∈ [0, 1].
        let (ex, ey) = (w.q[0] - w.p[0], w.q[1] - w.p[1]);
        let det = dx * (-ey) - dy * (-ex);
        if det.abs() < 1e-15 {
            continue;
        }
        let (px, py) = (w.p[0], w.p[1]);
        let t = (px * (-ey) - py * (-ex)) / det;
        let s = (dx * py - dy * px) / det;
        if t > 1e-9 && (-1e-12..=1.0 + 1e-12).contains(&s) && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    }
    best
}

/// Distance along the ray at bearing `phi` from the origin to the circle of
/// `radius` about `center` (the near side), if the ray meets it in front.
pub fn cast_circle(center: [f64; 2], radius: f64, phi: f64) -> Option<f64> {
    // |t·u − c|² = R²  ⇒  t² − 2t(u·c) + |c|² − R² = 0.
    let (ux, uy) = (phi.cos(), phi.sin());
    let uc = ux * center[0] + uy * center[1];
    let disc = uc * uc - (center[0] * center[0] + center[1] * center[1] - radius * radius);
    if disc < 0.0 {
        return None;
    }
    let t = uc - disc.sqrt();
    (t > 0.0).then_some(t)
}

/// Noise-free ranges of `n` beams at `first + j·step`; `None` where no wall is hit.
pub fn true_ranges(walls: &[Wall], first: f64, step: f64, n: usize) -> Vec<Option<f64>> {
    (0..n)
        .map(|j| cast(walls, first + j as f64 * step))
        .collect()
}

/// A scan: the true ranges plus Gaussian noise `sigma`, rounded to `f32`;
/// beams without a hit, and a fraction `p_invalid` of the others, invalid
/// (range 0).
pub fn noisy_scan<R: Rng>(
    truth: &[Option<f64>],
    sigma: f64,
    p_invalid: f64,
    rng: &mut R,
) -> (Vec<f32>, Vec<bool>) {
    let noise = Normal::new(0.0, sigma.max(0.0)).expect("sigma >= 0");
    let mut ranges = Vec::with_capacity(truth.len());
    let mut valid = Vec::with_capacity(truth.len());
    for t in truth {
        match t {
            Some(d) if rng.random::<f64>() >= p_invalid => {
                let r = (d + noise.sample(rng)) as f32;
                ranges.push(r.max(1e-3));
                valid.push(true);
            }
            _ => {
                ranges.push(0.0);
                valid.push(false);
            }
        }
    }
    (ranges, valid)
}

/// A random star-shaped room around the sensor: 4–9 vertices at sorted
/// random angles with radii in `1..15` m, plus a random box (0.3–1.2 m
/// sides) somewhere in front. Every bearing hits a wall.
pub fn random_room<R: Rng>(rng: &mut R) -> Vec<Wall> {
    use std::f64::consts::TAU;
    let m = rng.random_range(4..=9);
    let mut angles: Vec<f64> = (0..m).map(|_| rng.random_range(0.0..TAU)).collect();
    angles.sort_by(f64::total_cmp);
    // Keep gaps below π so the polygon surrounds the origin.
    let mut fixed = Vec::new();
    for (i, &a) in angles.iter().enumerate() {
        fixed.push(a);
        let next = if i + 1 < m {
            angles[i + 1]
        } else {
            angles[0] + TAU
        };
        let mut x = a;
        while next - x > 2.5 {
            x += 2.0;
            fixed.push(x);
        }
    }
    let vertices: Vec<[f64; 2]> = fixed
        .iter()
        .map(|&a| {
            let r = rng.random_range(1.0..15.0);
            [r * a.cos(), r * a.sin()]
        })
        .collect();
    let mut walls: Vec<Wall> = (0..vertices.len())
        .map(|i| Wall {
            p: vertices[i],
            q: vertices[(i + 1) % vertices.len()],
        })
        .collect();
    // A box at 0.6–0.9 of the room's distance in its direction.
    let dir = rng.random_range(-1.4..1.4f64);
    if let Some(far) = cast(&walls, dir) {
        let dist = far * rng.random_range(0.4..0.8);
        if dist > 0.8 {
            let (cx, cy) = (dist * dir.cos(), dist * dir.sin());
            let half = rng.random_range(0.15..0.6f64).min(dist * 0.3);
            let rot = rng.random_range(0.0..std::f64::consts::FRAC_PI_2);
            let corners: Vec<[f64; 2]> = (0..4)
                .map(|k| {
                    let a = rot + k as f64 * std::f64::consts::FRAC_PI_2;
                    let rr = half * std::f64::consts::SQRT_2;
                    [cx + rr * a.cos(), cy + rr * a.sin()]
                })
                .collect();
            for k in 0..4 {
                walls.push(Wall {
                    p: corners[k],
                    q: corners[(k + 1) % 4],
                });
            }
        }
    }
    walls
}

/// The infinite line `x·cos α + y·sin α = r` as a long wall (±`half` m
/// about the foot of the normal).
pub fn polar_wall(alpha: f64, r: f64, half: f64) -> Wall {
    let (c, s) = (alpha.cos(), alpha.sin());
    let foot = [r * c, r * s];
    let along = [-s, c];
    Wall {
        p: [foot[0] - half * along[0], foot[1] - half * along[1]],
        q: [foot[0] + half * along[0], foot[1] + half * along[1]],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_ahead_is_hit_at_its_distance() {
        let w = polar_wall(0.0, 2.0, 10.0);
        assert!((cast(&[w], 0.0).unwrap() - 2.0).abs() < 1e-12);
        assert!((cast(&[w], 0.5).unwrap() - 2.0 / 0.5f64.cos()).abs() < 1e-12);
        assert!(cast(&[w], std::f64::consts::PI).is_none());
    }
}
