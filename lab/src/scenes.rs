//! The synthetic scans of the evaluation: four scene families cast at the
//! LMS 180°/0.5° bearings, each scan with its ground truth.
//!
//! * [`Family::RandomRoom`] — `lms_scene::Scene::random_room`: a 4–8 wall
//!   star-shaped room with up to three boxes, two clutter boxes and two
//!   pillars, sensor at the origin.
//! * [`Family::Corridor`] — `Scene::corridor` (2 m wide, with a niche) seen
//!   from a random pose along it, looking either way.
//! * [`Family::RoomWithBox`] — `Scene::room_with_box` seen from a random
//!   pose inside the room (clear of the box), any heading.
//! * [`Family::Arcs`] — built here from `lms-scene`'s building blocks (the
//!   crate has no such scene): a rectangular room whose front wall is a
//!   circular arc (radius 1.5–5 m, concave), with probability ½ a second,
//!   convex arc bulging into the room from a side wall, and with probability
//!   0.7 a round pillar; turned by up to ±0.3 rad.
//!
//! Scan `k` of a family draws its scene, pose and noise from
//! `seeded_rng(seed ⊕ family ⊕ k)`, and the noise model draws the same
//! numbers whatever σ (see `lms_scene::NoiseModel`), so the scans of two
//! noise levels are the same scenes with the same noise pattern, scaled:
//! comparisons across σ are paired.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use anyhow::Result;
use lms_core::Frame;
use lms_scene::{seeded_rng, Bearings, NoiseModel, Point, Pose, Scene, TrueScan, Unit};
use rand::Rng;

use host_bridge::synthetic::frame_from_readings;

/// A family of synthetic scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Random rooms with boxes, clutter and pillars.
    RandomRoom,
    /// The corridor with a niche, random poses.
    Corridor,
    /// The room with a box, random poses.
    RoomWithBox,
    /// Rooms with curved walls and pillars.
    Arcs,
}

impl Family {
    /// All families, in report order.
    pub const ALL: [Family; 4] = [
        Family::RandomRoom,
        Family::Corridor,
        Family::RoomWithBox,
        Family::Arcs,
    ];

    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Family::RandomRoom => "random room",
            Family::Corridor => "corridor",
            Family::RoomWithBox => "room with box",
            Family::Arcs => "arcs",
        }
    }

    pub(crate) fn salt(self) -> u64 {
        match self {
            Family::RandomRoom => 0x1000_0000,
            Family::Corridor => 0x2000_0000,
            Family::RoomWithBox => 0x3000_0000,
            Family::Arcs => 0x4000_0000,
        }
    }
}

/// One synthetic scan with its truth.
#[derive(Clone, Debug)]
pub struct Sample {
    /// The family it was drawn from.
    pub family: Family,
    /// Index within the family.
    pub index: usize,
    /// The scene (scene coordinates).
    pub scene: Scene,
    /// The noise-free scan and its ground truth (sensor frame).
    pub truth: TrueScan,
    /// The noisy frame handed to the extractors.
    pub frame: Frame,
    /// Standard deviation of the range noise (m).
    pub sigma: f64,
}

/// How the synthetic sensor corrupts ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseSpec {
    /// Gaussian range noise (m).
    pub sigma: f64,
    /// Probability of a no-echo dropout per beam.
    pub dropout: f64,
}

impl NoiseSpec {
    fn model(&self) -> NoiseModel {
        NoiseModel::gaussian(self.sigma)
            .with_quantisation(Unit::Millimetre)
            .with_dropout(self.dropout)
    }
}

/// Scan `index` of `family` with `noise`, drawn from `seed`.
pub fn sample(family: Family, index: usize, seed: u64, noise: NoiseSpec) -> Result<Sample> {
    let mut rng = seeded_rng(seed ^ family.salt() ^ ((index as u64) << 32));
    let (scene, pose) = match family {
        Family::RandomRoom => (Scene::random_room(&mut rng), Pose::IDENTITY),
        Family::Corridor => corridor_pose(&mut rng),
        Family::RoomWithBox => room_with_box_pose(&mut rng),
        Family::Arcs => (arc_room(&mut rng), Pose::IDENTITY),
    };
    let truth = scene.cast(&Bearings::lms_180_half_deg(), pose);
    let readings = truth.noisy(&noise.model(), &mut rng);
    let frame = frame_from_readings(&readings)?;
    Ok(Sample {
        family,
        index,
        scene,
        truth,
        frame,
        sigma: noise.sigma,
    })
}

/// The corridor and a pose in it: 1.5 m behind to 12 m ahead of the
/// corridor's origin, 0.3 m clear of the side walls, heading within
/// ±0.5 rad of the corridor's axis, looking back with probability 0.3.
fn corridor_pose<R: Rng + ?Sized>(rng: &mut R) -> (Scene, Pose) {
    let frame = Pose::new(0.0, 0.0, 2f64.to_radians());
    let local = Point::new(rng.random_range(-1.5..12.0), rng.random_range(-0.6..0.8));
    let mut heading = rng.random_range(-0.5..0.5);
    if rng.random_bool(0.3) {
        heading += PI;
    }
    let p = frame.to_scene(local);
    (
        Scene::corridor(),
        Pose::new(p.x, p.y, frame.theta + heading),
    )
}

/// The room with a box and a pose in it: 0.4 m clear of the walls, 0.4 m
/// clear of the box's bounding circle, any heading.
fn room_with_box_pose<R: Rng + ?Sized>(rng: &mut R) -> (Scene, Pose) {
    // Scene::room_with_box: room centre (1.5, 0.2), 6 m × 4 m, turned by
    // 0.125 rad; box centre (2.15, 0.15), 0.6 m × 0.4 m.
    let room = Pose::new(1.5, 0.2, 0.125);
    let box_centre = Point::new(2.15, 0.15);
    let box_bound = 0.5 * f64::hypot(0.6, 0.4);
    let p = loop {
        let local = Point::new(rng.random_range(-2.6..2.6), rng.random_range(-1.6..1.6));
        let p = room.to_scene(local);
        if p.distance(box_centre) > box_bound + 0.4 {
            break p;
        }
    };
    (
        Scene::room_with_box(),
        Pose::new(p.x, p.y, rng.random_range(-PI..PI)),
    )
}

/// A room with curved walls around the origin (see the module docs).
pub fn arc_room<R: Rng + ?Sized>(rng: &mut R) -> Scene {
    let front = rng.random_range(3.0..5.0);
    let back = rng.random_range(1.0..2.0);
    let left = rng.random_range(1.5..3.0);
    let right = rng.random_range(1.5..3.0);
    let turn = rng.random_range(-0.3..0.3);
    let at = |x: f64, y: f64| Point::new(x, y).rotated(turn);
    let (fr, fl, bl, br) = (
        at(front, -right),
        at(front, left),
        at(-back, left),
        at(-back, -right),
    );
    let mut s = Scene::new();
    // Front: a concave arc from front-right to front-left, centre inside.
    let chord = fr.distance(fl);
    let radius = rng.random_range((0.5 * chord + 1.0).max(1.5)..(0.5 * chord + 3.0).max(5.0));
    add_arc_through(&mut s, fr, fl, radius, true);
    // Left wall, possibly with a convex bump in the middle.
    let bump = rng.random_bool(0.5);
    if bump {
        let len = rng.random_range(0.8..1.6);
        let mid = rng.random_range(0.2 * front..0.6 * front).max(0.6);
        let (a, b) = (at(mid + 0.5 * len, left), at(mid - 0.5 * len, left));
        s.add_wall(fl, a);
        let r = rng.random_range(0.6 * len..1.5 * len);
        add_arc_through(&mut s, a, b, r, false);
        s.add_wall(b, bl);
    } else {
        s.add_wall(fl, bl);
    }
    s.add_wall(bl, br);
    s.add_wall(br, fr);
    if rng.random_bool(0.7) {
        // A pillar 0.3 m clear of the walls (and of a bump) and 0.8 m of the sensor.
        let r = rng.random_range(0.1..0.4);
        for _ in 0..50 {
            let c = Point::new(rng.random_range(0.0..front), rng.random_range(-right..left));
            let clear = c.x < front - r - 0.3
                && c.y < left - r - 0.75
                && c.y > -right + r + 0.3
                && c.norm() > r + 0.8;
            if clear {
                s.add_circle(c.rotated(turn), r);
                break;
            }
        }
    }
    s
}

/// Add the minor arc of `radius` from `a` to `b`. `towards_origin`: the
/// centre lies on the origin's side of the chord (the arc bulges away from
/// the sensor, a concave wall); else on the far side (it bulges towards it).
fn add_arc_through(s: &mut Scene, a: Point, b: Point, radius: f64, towards_origin: bool) {
    let mid = (a + b) * 0.5;
    let half = 0.5 * a.distance(b);
    let radius = radius.max(half * 1.0001);
    let h = (radius * radius - half * half).sqrt();
    let normal = (b - a).rotated(FRAC_PI_2) * (1.0 / (2.0 * half));
    // The normal pointing towards the origin or away from it.
    let to_origin = if normal.dot(-mid) > 0.0 {
        normal
    } else {
        -normal
    };
    let centre = if towards_origin {
        mid + to_origin * h
    } else {
        mid - to_origin * h
    };
    let (ta, tb) = ((a - centre).angle(), (b - centre).angle());
    let sweep = lms_scene::wrap_angle(tb - ta);
    let (start, sweep) = if sweep >= 0.0 {
        (ta, sweep)
    } else {
        (tb, -sweep)
    };
    s.add_arc(centre, radius, start.rem_euclid(TAU), sweep);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_seeded_and_paired_across_sigma() {
        for family in Family::ALL {
            let a = sample(
                family,
                3,
                7,
                NoiseSpec {
                    sigma: 0.01,
                    dropout: 0.01,
                },
            )
            .unwrap();
            let b = sample(
                family,
                3,
                7,
                NoiseSpec {
                    sigma: 0.01,
                    dropout: 0.01,
                },
            )
            .unwrap();
            let c = sample(
                family,
                3,
                7,
                NoiseSpec {
                    sigma: 0.02,
                    dropout: 0.01,
                },
            )
            .unwrap();
            assert_eq!(a.frame.ranges(), b.frame.ranges());
            assert_eq!(a.truth, c.truth);
            assert!(
                a.truth.returns() > 100,
                "{family:?}: {} returns",
                a.truth.returns()
            );
            assert!(!a.truth.lines.is_empty(), "{family:?}");
        }
    }

    #[test]
    fn arc_rooms_have_arcs_that_are_hit() {
        let mut hit_arcs = 0;
        for k in 0..20 {
            let s = sample(
                Family::Arcs,
                k,
                1,
                NoiseSpec {
                    sigma: 0.0,
                    dropout: 0.0,
                },
            )
            .unwrap();
            assert!(!s.scene.arcs.is_empty());
            let arc_ids: Vec<_> = s.scene.arcs.iter().map(|a| a.id).collect();
            if s.truth
                .hits
                .iter()
                .flatten()
                .any(|h| arc_ids.contains(&h.surface))
            {
                hit_arcs += 1;
            }
        }
        assert_eq!(hit_arcs, 20);
    }
}
