//! Built-in scenes. All place the sensor at the scene origin looking along
//! +x (cast them with [`Pose::IDENTITY`](crate::Pose::IDENTITY)) unless said
//! otherwise.

use std::f64::consts::{PI, TAU};

use rand::Rng;

use crate::geometry::{Point, Pose};
use crate::scene::{rectangle, Scene};

/// Length of the walls of [`Scene::single_wall`] on each side of the foot
/// of the perpendicular (m): far beyond the maximum range.
const SINGLE_WALL_HALF_LENGTH: f64 = 20.0;

impl Scene {
    /// A 6 m × 4 m room (walls 0 right, 1 front, 2 left, 3 back) with a
    /// 0.6 m × 0.4 m box (walls 4–7) in front of the sensor.
    ///
    /// The room's centre lies at (1.5, 0.2) m and it is turned by 0.125 rad;
    /// the box's centre lies at (2.15, 0.15) m, turned by 0.45 rad. So no
    /// wall is perpendicular to a beam, and every vertex in the field of
    /// view lies at least 0.15 beam steps from a beam, for every LMS
    /// variant. From the origin every beam of a 180° or 100° scan hits: the
    /// right, front and left walls with their two corners, and two faces of
    /// the box with its convex corner, between two jumps.
    pub fn room_with_box() -> Scene {
        let mut s = Scene::new();
        s.add_polygon(&rectangle(Point::new(1.5, 0.2), 6.0, 4.0, 0.125));
        s.add_box(Point::new(2.15, 0.15), 0.6, 0.4, 0.45);
        s
    }

    /// A corridor 2 m wide and 16 m long, turned by 2° against the sensor's
    /// x axis; the sensor stands 2 m from its back end, 0.9 m from the
    /// right-hand wall (id 0). The left-hand wall is broken by a
    /// 1.5 m × 0.4 m niche 2 to 3.5 m ahead, so its two pieces (ids 2 and 6)
    /// are collinear walls; the near side of the niche is hidden, its back
    /// and far side are seen, with two corners and a jump. Every vertex
    /// within 8 m lies at least 0.1 beam steps from a beam. Beams along the
    /// corridor reach no wall within 8 m: no return.
    pub fn corridor() -> Scene {
        let frame = Pose::new(0.0, 0.0, 2f64.to_radians());
        let outline = [
            (-2.0, -0.9),
            (14.0, -0.9),
            (14.0, 1.1),
            (3.5, 1.1),
            (3.5, 1.5),
            (2.0, 1.5),
            (2.0, 1.1),
            (-2.0, 1.1),
        ]
        .map(|(x, y)| frame.to_scene(Point::new(x, y)));
        let mut s = Scene::new();
        s.add_polygon(&outline);
        s
    }

    /// One 40 m wall (id 0) on the line `x·cos α + y·sin α = distance` of
    /// the sensor frame: `distance` metres away along the bearing `angle`
    /// (rad). A beam at bearing φ meets it at `distance / cos(φ − angle)`.
    pub fn single_wall(distance: f64, angle: f64) -> Scene {
        let foot = Point::polar(distance, angle);
        let along = Point::polar(SINGLE_WALL_HALF_LENGTH, angle + PI / 2.0);
        let mut s = Scene::new();
        s.add_wall(foot - along, foot + along);
        s
    }

    /// A full circle (id 0) of `radius` metres around `center`: a pillar
    /// seen from outside, or a round room if the sensor is inside.
    pub fn arc(radius: f64, center: Point) -> Scene {
        let mut s = Scene::new();
        s.add_circle(center, radius);
        s
    }

    /// Two 2.5 m walls (ids 0 and 1) meeting at a vertex 3 m ahead, at a
    /// bearing of 4.35° (never on a beam of an LMS variant), opening
    /// towards the sensor with `angle_between_deg` degrees between them
    /// (90° is a room corner). The bisector is turned slightly off the line
    /// of sight, so the two walls are not mirror images in the scan. The
    /// corner's folded angle (ALGORITHM.md §8) is
    /// `min(angle_between_deg, 180 − angle_between_deg)`.
    ///
    /// # Panics
    /// If `angle_between_deg` is not strictly between 0 and 180.
    pub fn two_walls_corner(angle_between_deg: f64) -> Scene {
        assert!(
            angle_between_deg > 0.0 && angle_between_deg < 180.0,
            "angle between the walls must be in (0°, 180°), got {angle_between_deg}"
        );
        let half = angle_between_deg.to_radians() / 2.0;
        let vertex = Point::polar(3.0, 4.35f64.to_radians());
        // Keep the sensor inside the wedge: the skew is below the half angle.
        let bisector = (-vertex).angle() + (0.3 * half).min(0.05);
        let mut s = Scene::new();
        s.add_polyline(&[
            vertex + Point::polar(2.5, bisector - half),
            vertex,
            vertex + Point::polar(2.5, bisector + half),
        ]);
        s
    }

    /// A random room around the sensor: a star-shaped polygon of 4–8 walls
    /// with vertices 2.5–5.5 m away (so every beam hits within 8 m), up to
    /// three boxes (0.3–1 m × 0.2–0.6 m), up to two small clutter boxes
    /// (0.1–0.25 m) and up to two round pillars (radius 0.08–0.3 m), placed
    /// mostly in front of the sensor, clear of the walls, each other and
    /// the sensor. The same generator state gives the same room.
    pub fn random_room<R: Rng + ?Sized>(rng: &mut R) -> Scene {
        let n = rng.random_range(4..=8usize);
        let offset = rng.random_range(0.0..TAU);
        let outline: Vec<Point> = (0..n)
            .map(|k| {
                let a = offset + TAU * (k as f64 + rng.random_range(-0.3..0.3)) / n as f64;
                Point::polar(rng.random_range(2.5..5.5), a)
            })
            .collect();
        let mut s = Scene::new();
        s.add_polygon(&outline);

        let mut placed: Vec<(Point, f64)> = Vec::new();
        let boxes = rng.random_range(0..=3);
        let clutter = rng.random_range(0..=2);
        let pillars = rng.random_range(0..=2);
        for k in 0..boxes + clutter {
            let (length, width) = if k < boxes {
                (rng.random_range(0.3..1.0), rng.random_range(0.2..0.6))
            } else {
                (rng.random_range(0.1..0.25), rng.random_range(0.1..0.25))
            };
            let angle = rng.random_range(0.0..PI);
            let bound = 0.5 * f64::hypot(length, width);
            if let Some(c) = free_spot(rng, &outline, &placed, bound) {
                s.add_box(c, length, width, angle);
                placed.push((c, bound));
            }
        }
        for _ in 0..pillars {
            let radius = rng.random_range(0.08..0.3);
            if let Some(c) = free_spot(rng, &outline, &placed, radius) {
                s.add_circle(c, radius);
                placed.push((c, radius));
            }
        }
        s
    }
}

/// A centre for an object of bounding radius `radius` (m) inside the
/// polygon `outline`, 0.2 m clear of its walls and of the `placed` objects
/// (centre, bounding radius) and 0.4 m clear of the sensor; `None` after
/// 50 failed tries.
fn free_spot<R: Rng + ?Sized>(
    rng: &mut R,
    outline: &[Point],
    placed: &[(Point, f64)],
    radius: f64,
) -> Option<Point> {
    const CLEARANCE: f64 = 0.2;
    for _ in 0..50 {
        let c = Point::polar(rng.random_range(0.8..5.0), rng.random_range(-1.7..1.7));
        let clear_of_sensor = c.norm() > radius + 0.4;
        let inside = contains(outline, c)
            && edges(outline).all(|(a, b)| segment_distance(c, a, b) > radius + CLEARANCE);
        let apart = placed
            .iter()
            .all(|&(p, r)| p.distance(c) > r + radius + CLEARANCE);
        if clear_of_sensor && inside && apart {
            return Some(c);
        }
    }
    None
}

/// The edges of a closed polygon.
fn edges(polygon: &[Point]) -> impl Iterator<Item = (Point, Point)> + '_ {
    polygon
        .iter()
        .zip(polygon.iter().cycle().skip(1))
        .map(|(&a, &b)| (a, b))
}

/// Even-odd test: is `p` inside the closed polygon?
fn contains(polygon: &[Point], p: Point) -> bool {
    edges(polygon)
        .filter(|(a, b)| (a.y > p.y) != (b.y > p.y))
        .filter(|(a, b)| p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y))
        .count()
        % 2
        == 1
}

/// Distance from `p` to the segment `a`–`b` (m).
fn segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let e = b - a;
    let t = ((p - a).dot(e) / e.dot(e)).clamp(0.0, 1.0);
    p.distance(a + e * t)
}
