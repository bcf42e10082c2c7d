//! A sensor model that looks like a real LMS 2xx, beside
//! the plain [`NoiseModel`](crate::NoiseModel) (which stays as it was: the
//! existing tests and pinned results use it).
//!
//! What it adds, per beam `j` at bearing `φ_j`:
//!
//! * **Interleaved mirror turns.** In the 0.5° modes the LMS measures the
//!   1° grid in one mirror turn and the half-degree beams in the next, 13.3 ms
//!   later ([`LmsModel::turn_time`]); at 0.25° four turns. Beam `j` belongs
//!   to turn `j mod k` (k = 1°/step) and is cast from the pose the platform
//!   has reached by then ([`LmsModel::motion`], sensor-frame velocity).
//! * **Beam footprint and mixed pixels.** Three sub-rays at `φ_j` and
//!   `φ_j ± divergence/2`; where they disagree by more than
//!   [`MIXED_JUMP`] (a jump edge inside the footprint), with probability
//!   [`LmsModel::mixed`] the reading is a mix of the near and far ranges
//!   (uniform weight), else the centre ray's.
//! * **Incidence-dependent noise** `σ(θ, d)² = σ₀² + (κ·d·tan θ)²`, θ the
//!   angle between the ray and the surface normal, `tan θ ≤ tan 85°`
//!   ([`LmsModel::sigma0`], [`LmsModel::kappa`]): the footprint spread along
//!   a grazing wall.
//! * **Quantisation** to [`LmsModel::step`] (1 mm, 1 cm, or the 5 cm of some
//!   recorders), then to the mode's unit.
//! * **Each mode's error codes and the fill values logs use**
//!   ([`LogMode`], [`NoEcho`]): no echo is the mode's code 8191 (81.91 m in
//!   cm, 8.191 m in the 8 m mm mode, 32.767 m in the 32 m mm mode) or a
//!   recorder's constant fill (≈ 50 m in the Acapulco log); ranges beyond the
//!   mode's maximum give the code 8183 ("above the maximum").
//! * **Dropouts** with probability [`LmsModel::dropout`].
//!
//! Every beam takes exactly five draws in beam order (dropout, noise, mixed
//! or not, mix weight, spare), so a beam's noise depends only on the seed and
//! its index.

use rand::Rng;
use rand_distr::StandardNormal;

use crate::bearings::Bearings;
use crate::geometry::{Point, Pose};
use crate::noise::Reading;
use crate::scene::{Scene, Surface};

/// Sub-ray range spread (m) above which the footprint straddles a jump.
pub const MIXED_JUMP: f64 = 0.05;

/// Largest incidence the noise term uses (rad, 85°).
pub const MAX_INCIDENCE: f64 = 85.0 * std::f64::consts::PI / 180.0;

/// Range mode of the recording: unit, maximum range and error codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogMode {
    /// mm, 8 m mode: codes 8183 … 8191 mm.
    Mm8,
    /// mm, 32 m mode: codes 32759 … 32767 mm.
    Mm32,
    /// cm, 80 m mode: codes 81.83 … 81.91 m.
    Cm80,
}

impl LogMode {
    /// Metres per unit.
    pub fn unit(self) -> f64 {
        match self {
            LogMode::Mm8 | LogMode::Mm32 => 0.001,
            LogMode::Cm80 => 0.01,
        }
    }

    /// The no-echo code (m).
    pub fn no_echo(self) -> f64 {
        match self {
            LogMode::Mm8 => 8.191,
            LogMode::Mm32 => 32.767,
            LogMode::Cm80 => 81.91,
        }
    }

    /// The "above the maximum" code, the first error code (m).
    pub fn above_max(self) -> f64 {
        self.no_echo() - 8.0 * self.unit()
    }

    /// Largest range reported as a range (m).
    pub fn max_range(self) -> f64 {
        self.above_max() - self.unit()
    }
}

/// How a beam without an echo is written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoEcho {
    /// The mode's no-echo code.
    Code,
    /// A recorder's constant fill (m).
    Fill(f64),
}

/// One beam as a log holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LogValue {
    /// A range (m).
    Range(f64),
    /// An error code (m, in the mode's unit).
    Code(f64),
    /// A fill value (m): looks like a range.
    Fill(f64),
}

impl LogValue {
    /// The number in the log (m).
    pub fn metres(self) -> f64 {
        match self {
            LogValue::Range(d) | LogValue::Code(d) | LogValue::Fill(d) => d,
        }
    }

    /// As a [`Reading`]: codes and fills are no return.
    pub fn reading(self) -> Reading {
        match self {
            LogValue::Range(d) => Reading::Range(d),
            _ => Reading::NoReturn,
        }
    }
}

/// The realistic LMS model (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmsModel {
    /// Range mode.
    pub mode: LogMode,
    /// Quantisation step (m), at least the mode's unit.
    pub step: f64,
    /// Range noise at normal incidence (m).
    pub sigma0: f64,
    /// Incidence term κ (rad): `σ² = σ₀² + (κ·d·tan θ)²`.
    pub kappa: f64,
    /// Full beam divergence (rad).
    pub divergence: f64,
    /// Probability of a mixed pixel where the footprint straddles a jump.
    pub mixed: f64,
    /// Time between mirror turns (s).
    pub turn_time: f64,
    /// Platform velocity in the sensor frame: (vx, vy) m/s, ω rad/s.
    pub motion: [f64; 3],
    /// Probability that a beam with an echo reports none.
    pub dropout: f64,
    /// How no echo is written.
    pub no_echo: NoEcho,
}

impl LmsModel {
    /// An LMS 200 in the 80 m cm mode at rest, with the values fitted to
    /// the shared cm logs (docs/evaluation, "Sensor model"): σ₀ = 5 mm,
    /// κ = 0.0044 rad, divergence 0.25°, 30 % mixed pixels, 1 % dropouts.
    pub const fn lms200_cm() -> Self {
        LmsModel {
            mode: LogMode::Cm80,
            step: 0.01,
            sigma0: 0.005,
            kappa: 0.0044,
            divergence: 0.25 * std::f64::consts::PI / 180.0,
            mixed: 0.3,
            turn_time: 0.0133,
            motion: [0.0; 3],
            dropout: 0.01,
            no_echo: NoEcho::Code,
        }
    }

    /// The same sensor in the 8 m mm mode.
    pub const fn lms200_mm() -> Self {
        LmsModel {
            mode: LogMode::Mm8,
            step: 0.001,
            ..Self::lms200_cm()
        }
    }

    /// This model with range noise `sigma0` (m) at normal incidence.
    pub const fn with_sigma(self, sigma0: f64) -> Self {
        Self { sigma0, ..self }
    }

    /// This model moving at `motion` ((vx, vy) m/s, ω rad/s; sensor frame).
    pub const fn moving(self, motion: [f64; 3]) -> Self {
        Self { motion, ..self }
    }

    /// Mirror turns interleaved at `bearings`' step (1 at 1°, 2 at 0.5°, 4 at 0.25°).
    pub fn turns(bearings: &Bearings) -> usize {
        let k = (1f64.to_radians() / bearings.step).round();
        if k >= 1.0 {
            k as usize
        } else {
            1
        }
    }

    /// The pose of mirror turn `k` when turn 0 is at `pose`.
    pub fn turn_pose(&self, pose: Pose, k: usize) -> Pose {
        self.pose_after(pose, self.turn_time * k as f64)
    }

    /// The pose `t` seconds after `pose` (before it for `t < 0`) at the
    /// model's motion.
    pub fn pose_after(&self, pose: Pose, t: f64) -> Pose {
        let [vx, vy, w] = self.motion;
        let (c, s) = (pose.theta.cos(), pose.theta.sin());
        Pose::new(
            pose.x + (vx * c - vy * s) * t,
            pose.y + (vx * s + vy * c) * t,
            pose.theta + w * t,
        )
    }

    /// Noise σ (m) at range `d` and incidence `theta` (rad).
    pub fn sigma_at(&self, d: f64, theta: f64) -> f64 {
        let t = theta.abs().min(MAX_INCIDENCE).tan();
        (self.sigma0 * self.sigma0 + (self.kappa * d * t).powi(2)).sqrt()
    }

    /// One scan of `scene` from `pose` (turn 0) at `bearings`: the log's
    /// value of every beam.
    pub fn scan<R: Rng + ?Sized>(
        &self,
        scene: &Scene,
        bearings: &Bearings,
        pose: Pose,
        rng: &mut R,
    ) -> Vec<LogValue> {
        let turns = Self::turns(bearings);
        (0..bearings.n)
            .map(|j| {
                let p = self.turn_pose(pose, j % turns);
                self.beam(scene, p, bearings.bearing(j), rng)
            })
            .collect()
    }

    /// The range and incidence of the ray from `pose` at sensor bearing `phi`.
    fn ray(scene: &Scene, pose: Pose, phi: f64) -> Option<(f64, f64)> {
        let angle = pose.theta + phi;
        let hit = scene.ray(pose.position(), angle)?;
        let dir = Point::polar(1.0, angle);
        let normal = match scene.surface(hit.surface)? {
            Surface::Wall(w) => {
                let e = w.b - w.a;
                Point::new(-e.y, e.x)
            }
            Surface::Arc(a) => hit.point - a.center,
        };
        let n = normal.norm().max(1e-12);
        let cos = (dir.dot(normal) / n).abs().min(1.0);
        Some((hit.range, cos.acos()))
    }

    fn beam<R: Rng + ?Sized>(&self, scene: &Scene, pose: Pose, phi: f64, rng: &mut R) -> LogValue {
        let u_drop: f64 = rng.random();
        let z: f64 = rng.sample(StandardNormal);
        let u_mixed: f64 = rng.random();
        let w: f64 = rng.random();
        let _spare: f64 = rng.random();
        let no_echo = match self.no_echo {
            NoEcho::Code => LogValue::Code(self.mode.no_echo()),
            NoEcho::Fill(f) => LogValue::Fill(f),
        };
        let Some((d0, theta)) = Self::ray(scene, pose, phi) else {
            return no_echo;
        };
        if u_drop < self.dropout {
            return no_echo;
        }
        let h = 0.5 * self.divergence;
        let side: Vec<f64> = [phi - h, phi + h]
            .iter()
            .filter_map(|&p| Self::ray(scene, pose, p).map(|r| r.0))
            .collect();
        let (lo, hi) = side
            .iter()
            .fold((d0, d0), |(lo, hi), &r| (lo.min(r), hi.max(r)));
        let mut d = d0;
        if hi - lo > MIXED_JUMP && u_mixed < self.mixed {
            d = lo + w * (hi - lo);
        }
        d += self.sigma_at(d0, theta) * z;
        let step = self.step.max(self.mode.unit());
        d = (d / step).round() * step;
        d = (d / self.mode.unit()).round() * self.mode.unit();
        if d > self.mode.max_range() {
            LogValue::Code(self.mode.above_max())
        } else if d <= 0.0 {
            no_echo
        } else {
            LogValue::Range(d)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeded_rng;

    fn quiet() -> LmsModel {
        LmsModel {
            sigma0: 0.0,
            kappa: 0.0,
            mixed: 0.0,
            dropout: 0.0,
            ..LmsModel::lms200_mm()
        }
    }

    #[test]
    fn modes_codes_and_fill() {
        assert!((LogMode::Cm80.no_echo() - 81.91).abs() < 1e-9);
        assert!((LogMode::Cm80.above_max() - 81.83).abs() < 1e-9);
        assert!((LogMode::Mm8.above_max() - 8.183).abs() < 1e-9);
        assert!((LogMode::Mm32.no_echo() - 32.767).abs() < 1e-9);
        // A beam into nothing: the code, or the recorder's fill.
        let scene = Scene::single_wall(20.0, 0.0);
        let b = Bearings::lms_180_1deg();
        let mut rng = seeded_rng(1);
        let v = quiet().scan(&scene, &b, Pose::IDENTITY, &mut rng);
        // 20 m is beyond the 8 m mode: "above the maximum".
        assert_eq!(v[90], LogValue::Code(LogMode::Mm8.above_max()));
        assert_eq!(v[0], LogValue::Code(8.191));
        let fill = LmsModel {
            no_echo: NoEcho::Fill(50.5),
            mode: LogMode::Cm80,
            ..quiet()
        };
        let v = fill.scan(&scene, &b, Pose::IDENTITY, &mut rng);
        assert_eq!(v[0], LogValue::Fill(50.5));
        assert!((v[90].metres() - 20.0).abs() < 1e-9);
    }

    #[test]
    fn interleaved_turns_see_the_platform_move() {
        // Driving at 1 m/s towards a wall 3 m ahead: the half-degree beams
        // (turn 1) are 13.3 mm closer.
        let scene = Scene::single_wall(3.0, 0.0);
        let b = Bearings::lms_180_half_deg();
        let m = quiet().moving([1.0, 0.0, 0.0]);
        let v = m.scan(&scene, &b, Pose::IDENTITY, &mut seeded_rng(2));
        let (even, odd) = (v[180].metres(), v[181].metres());
        let expect = |j: usize, x: f64| (3.0 - x) / b.bearing(j).cos();
        assert!((even - expect(180, 0.0)).abs() < 6e-4, "{even}");
        assert!((odd - expect(181, 0.0133)).abs() < 6e-4, "{odd}");
        assert_eq!(LmsModel::turns(&Bearings::lms_100_quarter_deg()), 4);
        assert_eq!(LmsModel::turns(&Bearings::lms_180_1deg()), 1);
    }

    #[test]
    fn quantised_to_the_step() {
        let scene = Scene::single_wall(3.0, 0.3);
        let m = LmsModel {
            mode: LogMode::Cm80,
            step: 0.05,
            ..LmsModel::lms200_cm()
        };
        let v = m.scan(
            &scene,
            &Bearings::default(),
            Pose::IDENTITY,
            &mut seeded_rng(3),
        );
        let ranges: Vec<f64> = v
            .iter()
            .filter_map(|v| match v {
                LogValue::Range(d) => Some(*d),
                _ => None,
            })
            .collect();
        assert!(ranges.len() > 300);
        assert!(ranges
            .iter()
            .all(|d| ((d / 0.05) - (d / 0.05).round()).abs() < 1e-6));
    }

    #[test]
    fn noise_grows_with_incidence_and_mixed_pixels_sit_in_jumps() {
        let m = LmsModel {
            dropout: 0.0,
            ..LmsModel::lms200_mm().with_sigma(0.005)
        };
        assert!((m.sigma_at(2.0, 0.0) - 0.005).abs() < 1e-12);
        assert!(m.sigma_at(2.0, 80f64.to_radians()) > 0.05);
        // A box in front of a far wall: some readings at a jump edge fall
        // between the two surfaces.
        let mut scene = Scene::single_wall(4.0, 0.0);
        scene.add_box(Point::new(2.0, 0.0), 0.4, 1.0, 0.0);
        let b = Bearings::lms_180_1deg();
        let m = LmsModel {
            mixed: 1.0,
            divergence: 2f64.to_radians(),
            ..quiet()
        };
        let v = m.scan(&scene, &b, Pose::IDENTITY, &mut seeded_rng(4));
        let between = v
            .iter()
            .filter(|v| matches!(v, LogValue::Range(d) if *d > 2.0 && *d < 3.95))
            .count();
        assert!(between >= 2, "{between}");
    }
}
