//! Scene geometry — straight walls and circular arcs, each with a surface id —
//! and ray casting in scene coordinates.

use std::f64::consts::TAU;

use crate::bearings::Bearings;
use crate::geometry::{Point, Pose};
use crate::truth::{self, TrueScan};

/// Identifies one wall or arc of a [`Scene`]; unique within the scene.
pub type SurfaceId = u32;

/// Default maximum range of a simulated scan (m).
pub const DEFAULT_MAX_RANGE: f64 = 8.0;

/// The largest range the LMS 2xx reports in its mm mode (m): 8182 mm, one
/// below the first error code 8183.
pub const LMS_MM_MAX_RANGE: f64 = 8.182;

/// Hits closer than this to the ray's origin are ignored (m).
const MIN_T: f64 = 1e-9;

/// Slack on a wall's segment parameter, so that a ray through the vertex
/// shared by two walls hits one of them.
const SEGMENT_SLACK: f64 = 1e-12;

/// Slack on an arc's angular extent (rad), for the same reason.
const ARC_SLACK: f64 = 1e-12;

/// A straight wall from `a` to `b` (scene coordinates, m). Both sides reflect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    /// Surface id.
    pub id: SurfaceId,
    /// First endpoint (m).
    pub a: Point,
    /// Second endpoint (m).
    pub b: Point,
}

impl Wall {
    /// A wall with the given id from `a` to `b`.
    pub const fn new(id: SurfaceId, a: Point, b: Point) -> Self {
        Self { id, a, b }
    }

    /// Length (m).
    pub fn length(&self) -> f64 {
        self.a.distance(self.b)
    }

    /// Distance along the ray `origin + t·dir` (`dir` a unit vector) at
    /// which it crosses the wall, if it does at `t > 0`. A ray parallel to
    /// the wall never hits it.
    fn intersect(&self, origin: Point, dir: Point) -> Option<f64> {
        // origin + t·dir = a + s·e, solved with cross products.
        let e = self.b - self.a;
        let denom = dir.cross(e);
        if denom.abs() <= 1e-15 * e.norm() {
            return None;
        }
        let w = self.a - origin;
        let t = w.cross(e) / denom;
        let s = w.cross(dir) / denom;
        (t > MIN_T && (-SEGMENT_SLACK..=1.0 + SEGMENT_SLACK).contains(&s)).then_some(t)
    }
}

/// A circular arc (scene coordinates): the points
/// `center + radius·(cos θ, sin θ)` for θ from `start` counter-clockwise
/// through `sweep` radians. `sweep ≥ 2π` is a full circle. Both sides
/// reflect (a pillar seen from outside, a round wall from inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// Surface id.
    pub id: SurfaceId,
    /// Centre (m).
    pub center: Point,
    /// Radius (m, > 0).
    pub radius: f64,
    /// Angle of the first end, seen from the centre (rad).
    pub start: f64,
    /// Angular extent, counter-clockwise (rad, > 0).
    pub sweep: f64,
}

impl Arc {
    /// An arc with the given id; angles in radians, lengths in metres.
    pub const fn new(id: SurfaceId, center: Point, radius: f64, start: f64, sweep: f64) -> Self {
        Self {
            id,
            center,
            radius,
            start,
            sweep,
        }
    }

    /// A full circle.
    pub const fn circle(id: SurfaceId, center: Point, radius: f64) -> Self {
        Self::new(id, center, radius, 0.0, TAU)
    }

    /// `true` if the arc closes on itself (`sweep ≥ 2π`).
    pub fn is_full_circle(&self) -> bool {
        self.sweep >= TAU
    }

    /// The point of the circle at angle `theta` (rad) seen from the centre.
    pub fn point_at(&self, theta: f64) -> Point {
        self.center + Point::polar(self.radius, theta)
    }

    /// Whether the direction `theta` (rad, from the centre) lies on the arc.
    pub fn covers(&self, theta: f64) -> bool {
        self.is_full_circle() || (theta - self.start).rem_euclid(TAU) <= self.sweep + ARC_SLACK
    }

    /// The two ends of the arc, or `None` for a full circle.
    pub fn endpoints(&self) -> Option<[Point; 2]> {
        (!self.is_full_circle()).then(|| {
            [
                self.point_at(self.start),
                self.point_at(self.start + self.sweep),
            ]
        })
    }

    /// Nearest distance `t > 0` along `origin + t·dir` (`dir` a unit
    /// vector) at which the ray meets the arc.
    fn intersect(&self, origin: Point, dir: Point) -> Option<f64> {
        // |p + t·dir|² = R² with p = origin − centre.
        let p = origin - self.center;
        let b = p.dot(dir);
        let disc = b * b - (p.dot(p) - self.radius * self.radius);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [-b - s, -b + s]
            .into_iter()
            .filter(|&t| t > MIN_T)
            .find(|&t| self.covers((p + dir * t).angle()))
    }
}

/// A surface of a scene, looked up by id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface<'a> {
    /// A straight wall.
    Wall(&'a Wall),
    /// A circular arc.
    Arc(&'a Arc),
}

impl Surface<'_> {
    /// The surface's endpoints: two for a wall or an open arc, none for a
    /// full circle. Surfaces sharing an endpoint are adjacent.
    pub fn endpoints(&self) -> Vec<Point> {
        match self {
            Surface::Wall(w) => vec![w.a, w.b],
            Surface::Arc(a) => a.endpoints().map_or(Vec::new(), Vec::from),
        }
    }
}

/// The nearest surface along a ray (scene coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance from the ray's origin (m).
    pub range: f64,
    /// The surface hit.
    pub surface: SurfaceId,
    /// The hit point in scene coordinates (m).
    pub point: Point,
}

/// A 2-D scene of walls and arcs in scene coordinates (m). The fields are
/// public; the `add_*` methods give each new surface a fresh id.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Straight walls.
    pub walls: Vec<Wall>,
    /// Circular arcs.
    pub arcs: Vec<Arc>,
}

impl Scene {
    /// An empty scene.
    pub fn new() -> Self {
        Self::default()
    }

    /// The id the next `add_*` call will use: one above the largest in use.
    pub fn next_id(&self) -> SurfaceId {
        let walls = self.walls.iter().map(|w| w.id);
        let arcs = self.arcs.iter().map(|a| a.id);
        walls.chain(arcs).max().map_or(0, |m| m + 1)
    }

    /// Add a wall from `a` to `b` (m); returns its id.
    pub fn add_wall(&mut self, a: Point, b: Point) -> SurfaceId {
        let id = self.next_id();
        self.walls.push(Wall::new(id, a, b));
        id
    }

    /// Add an open chain of walls through `points`; returns their ids.
    pub fn add_polyline(&mut self, points: &[Point]) -> Vec<SurfaceId> {
        points
            .windows(2)
            .map(|p| self.add_wall(p[0], p[1]))
            .collect()
    }

    /// Add a closed polygon of walls (the last point joins the first);
    /// returns their ids in the order of the points.
    pub fn add_polygon(&mut self, points: &[Point]) -> Vec<SurfaceId> {
        let mut ids = self.add_polyline(points);
        if let (Some(&first), Some(&last)) = (points.first(), points.last()) {
            if points.len() > 2 {
                ids.push(self.add_wall(last, first));
            }
        }
        ids
    }

    /// Add a rectangular box of `length × width` metres centred at `center`,
    /// its length along the direction `angle` (rad); returns its four ids.
    pub fn add_box(
        &mut self,
        center: Point,
        length: f64,
        width: f64,
        angle: f64,
    ) -> Vec<SurfaceId> {
        self.add_polygon(&rectangle(center, length, width, angle))
    }

    /// Add an arc (see [`Arc`]); returns its id.
    pub fn add_arc(&mut self, center: Point, radius: f64, start: f64, sweep: f64) -> SurfaceId {
        let id = self.next_id();
        self.arcs.push(Arc::new(id, center, radius, start, sweep));
        id
    }

    /// Add a full circle (a pillar, or a round room); returns its id.
    pub fn add_circle(&mut self, center: Point, radius: f64) -> SurfaceId {
        self.add_arc(center, radius, 0.0, TAU)
    }

    /// The surface with this id.
    pub fn surface(&self, id: SurfaceId) -> Option<Surface<'_>> {
        self.walls
            .iter()
            .find(|w| w.id == id)
            .map(Surface::Wall)
            .or_else(|| self.arcs.iter().find(|a| a.id == id).map(Surface::Arc))
    }

    /// The nearest surface along the ray from `origin` in the direction
    /// `angle` (rad, scene coordinates), at any distance.
    pub fn ray(&self, origin: Point, angle: f64) -> Option<RayHit> {
        let dir = Point::polar(1.0, angle);
        let walls = self
            .walls
            .iter()
            .filter_map(|w| Some((w.intersect(origin, dir)?, w.id)));
        let arcs = self
            .arcs
            .iter()
            .filter_map(|a| Some((a.intersect(origin, dir)?, a.id)));
        walls
            .chain(arcs)
            .fold(None, |best: Option<(f64, SurfaceId)>, hit| match best {
                Some(b) if b.0 <= hit.0 => Some(b),
                _ => Some(hit),
            })
            .map(|(range, surface)| RayHit {
                range,
                surface,
                point: origin + dir * range,
            })
    }

    /// Cast one scan at `bearings` from the sensor at `pose`, with the
    /// default maximum range ([`DEFAULT_MAX_RANGE`]).
    pub fn cast(&self, bearings: &Bearings, pose: Pose) -> TrueScan {
        self.cast_with_max_range(bearings, pose, DEFAULT_MAX_RANGE)
    }

    /// Cast one scan; hits farther than `max_range` (m) give no return.
    pub fn cast_with_max_range(&self, bearings: &Bearings, pose: Pose, max_range: f64) -> TrueScan {
        truth::cast(self, bearings, pose, max_range)
    }
}

/// Corners of a `length × width` rectangle centred at `center`, its length
/// along `angle` (rad), counter-clockwise.
pub fn rectangle(center: Point, length: f64, width: f64, angle: f64) -> [Point; 4] {
    let (hl, hw) = (length / 2.0, width / 2.0);
    [(-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw)]
        .map(|(x, y)| center + Point::new(x, y).rotated(angle))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_hits_nearest_surface() {
        let mut s = Scene::new();
        let far = s.add_wall(Point::new(3.0, -1.0), Point::new(3.0, 1.0));
        let near = s.add_wall(Point::new(2.0, -0.1), Point::new(2.0, 0.1));
        assert_eq!((far, near), (0, 1));
        let hit = s.ray(Point::ORIGIN, 0.0).unwrap();
        assert_eq!(hit.surface, near);
        assert!((hit.range - 2.0).abs() < 1e-15);
        let hit = s.ray(Point::ORIGIN, 0.2).unwrap();
        assert_eq!(hit.surface, far);
        assert!((hit.range - 3.0 / 0.2f64.cos()).abs() < 1e-12);
        // Behind the sensor there is nothing.
        assert!(s.ray(Point::ORIGIN, 3.0).is_none());
    }

    #[test]
    fn ray_through_shared_vertex_hits() {
        let mut s = Scene::new();
        s.add_polyline(&[
            Point::new(2.0, -2.0),
            Point::new(2.0, 0.0),
            Point::new(4.0, 2.0),
        ]);
        let hit = s.ray(Point::ORIGIN, 0.0).unwrap();
        assert!((hit.range - 2.0).abs() < 1e-12);
    }

    #[test]
    fn arc_from_outside_and_inside() {
        let mut s = Scene::new();
        let c = s.add_circle(Point::new(3.0, 0.0), 1.0);
        let hit = s.ray(Point::ORIGIN, 0.0).unwrap();
        assert_eq!(hit.surface, c);
        assert!((hit.range - 2.0).abs() < 1e-12);
        // From the centre every direction is at the radius.
        let hit = s.ray(Point::new(3.0, 0.0), 1.234).unwrap();
        assert!((hit.range - 1.0).abs() < 1e-12);
        // The open half facing away from the origin: hit on the far side.
        let mut s = Scene::new();
        s.add_arc(Point::new(3.0, 0.0), 1.0, -TAU / 4.0, TAU / 2.0);
        let hit = s.ray(Point::ORIGIN, 0.0).unwrap();
        assert!((hit.range - 4.0).abs() < 1e-12);
    }

    #[test]
    fn ids_and_lookup() {
        let mut s = Scene::new();
        let walls = s.add_box(Point::new(1.0, 1.0), 0.6, 0.4, 0.3);
        let arc = s.add_circle(Point::new(-1.0, 0.0), 0.2);
        assert_eq!(walls, vec![0, 1, 2, 3]);
        assert_eq!(arc, 4);
        assert!(matches!(s.surface(2), Some(Surface::Wall(w)) if w.id == 2));
        assert!(matches!(s.surface(4), Some(Surface::Arc(_))));
        assert!(s.surface(5).is_none());
        // The box closes: consecutive walls share their endpoints.
        for k in 0..4 {
            assert_eq!(s.walls[k].b, s.walls[(k + 1) % 4].a);
            let len = s.walls[k].length();
            let expected = if k % 2 == 0 { 0.6 } else { 0.4 };
            assert!((len - expected).abs() < 1e-12);
        }
    }
}
