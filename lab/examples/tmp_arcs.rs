use anyhow::Result;
use lms_core::{Extractor, Frame, Params};
use lms_lab::baselines::{run_core, Extraction};
use lms_lab::sweep::print_sweep_with;

/// Drop chains of ≥ `n` consecutive touching lines that turn the same way by < `max_deg` each.
fn curvature_z(frame: &Frame, l: &lms_core::Line, sigma: f64, kappa: f64) -> f64 {
    let (g, rg, b) = (frame.geometry(), frame.ranges(), frame.beams());
    let (ca, sa) = (f64::from(l.alpha).cos(), f64::from(l.alpha).sin());
    let mut pts = Vec::new();
    for j in usize::from(l.first)..=usize::from(l.last) {
        if !b[j].is_valid() {
            continue;
        }
        let (d, phi) = (f64::from(rg[j]), f64::from(g.bearing(j)));
        let (x, y) = (d * phi.cos(), d * phi.sin());
        let e = x * ca + y * sa - f64::from(l.r);
        let t = -x * sa + y * ca;
        let inc = (phi - f64::from(l.alpha)).cos().abs().max(0.05);
        let tan = (1.0 - inc * inc).sqrt() / inc;
        let var = (sigma * sigma + (kappa * d * tan).powi(2)) * inc * inc;
        pts.push((t, e, 1.0 / var));
    }
    if pts.len() < 5 {
        return 0.0;
    }
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let tm = pts.iter().map(|p| p.0 * p.2).sum::<f64>() / sw;
    let mut m = [[0.0f64; 3]; 3];
    let mut v = [0.0f64; 3];
    for &(t, e, w) in &pts {
        let u = t - tm;
        let f = [1.0, u, u * u];
        for i in 0..3 {
            for k in 0..3 {
                m[i][k] += w * f[i] * f[k];
            }
            v[i] += w * f[i] * e;
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if det.abs() < 1e-300 {
        return 0.0;
    }
    let inv22 = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
    let c20 = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
    let c21 = -(m[0][0] * m[2][1] - m[0][1] * m[2][0]) / det;
    (c20 * v[0] + c21 * v[1] + inv22 * v[2]) / inv22.sqrt()
}

fn drop_arcs(
    mut x: Extraction,
    n: usize,
    min_deg: f32,
    max_deg: f32,
    gap: f32,
    curved: &dyn Fn(&lms_core::Line) -> bool,
) -> Extraction {
    let l = &x.lines;
    let mut drop = vec![false; l.len()];
    let turn = |a: &lms_core::Line, b: &lms_core::Line| -> f32 {
        let mut d = b.alpha - a.alpha;
        while d > std::f32::consts::PI {
            d -= 2.0 * std::f32::consts::PI;
        }
        while d < -std::f32::consts::PI {
            d += 2.0 * std::f32::consts::PI;
        }
        d.to_degrees()
    };
    let touch = |a: &lms_core::Line, b: &lms_core::Line| {
        let dx = b.endpoints[0][0] - a.endpoints[1][0];
        let dy = b.endpoints[0][1] - a.endpoints[1][1];
        (dx * dx + dy * dy).sqrt() < gap
    };
    let mut i = 0;
    while i + 1 < l.len() {
        let mut j = i;
        let mut sign = 0.0f32;
        while j + 1 < l.len() && touch(&l[j], &l[j + 1]) {
            let t = turn(&l[j], &l[j + 1]);
            if t.abs() < min_deg || t.abs() > max_deg || (sign != 0.0 && t.signum() != sign) {
                break;
            }
            sign = t.signum();
            j += 1;
        }
        if j + 1 - i >= n && (n >= 3 || (i..=j).all(|k| curved(&l[k]))) {
            for k in i..=j {
                drop[k] = true;
            }
        }
        i = j.max(i + 1);
    }
    let mut k = 0;
    x.lines.retain(|_| {
        k += 1;
        !drop[k - 1]
    });
    x
}

const V: [(&str, usize, f32, f32, f64); 6] = [
    ("defaults", 0, 0.0, 0.0, 0.0),
    ("arcs ≥3, 5–40°", 3, 5.0, 40.0, 0.0),
    ("arcs ≥2 curved z>3, 5–40°", 2, 5.0, 40.0, 3.0),
    ("arcs ≥2 curved z>2, 5–40°", 2, 5.0, 40.0, 2.0),
    ("arcs ≥2 curved z>4, 5–40°", 2, 5.0, 40.0, 4.0),
    ("arcs ≥2 curved z>3, 2–40°", 2, 2.0, 40.0, 3.0),
];

fn main() -> Result<()> {
    let names: Vec<&str> = V.iter().map(|v| v.0).collect();
    print_sweep_with(
        &names,
        5,
        100,
        &|k, ex: &mut Extractor, f: &Frame, p: &Params| {
            let x = run_core(ex, f, p);
            let (s, kap, zk) = (f64::from(p.sigma), f64::from(p.footprint), V[k].4);
            let curved = |l: &lms_core::Line| curvature_z(f, l, s, kap).abs() > zk;
            if V[k].1 == 0 {
                x
            } else {
                drop_arcs(x, V[k].1, V[k].2, V[k].3, p.corner_gap, &curved)
            }
        },
    )
}
