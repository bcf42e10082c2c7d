//! Plane geometry in metres and radians: points, the sensor pose and polar
//! lines (`x·cos α + y·sin α = r`, ALGORITHM.md §7).

use std::f64::consts::{PI, TAU};
use std::ops::{Add, Mul, Neg, Sub};

/// A point (or vector) in the plane, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// x in metres.
    pub x: f64,
    /// y in metres.
    pub y: f64,
}

impl Point {
    /// The origin (0, 0).
    pub const ORIGIN: Point = Point::new(0.0, 0.0);

    /// The point `(x, y)` in metres.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// The point at `range` metres along the direction `angle` (radians).
    pub fn polar(range: f64, angle: f64) -> Self {
        let (s, c) = angle.sin_cos();
        Self::new(range * c, range * s)
    }

    /// Dot product (m²).
    pub fn dot(self, o: Point) -> f64 {
        self.x * o.x + self.y * o.y
    }

    /// z component of the cross product `self × o` (m²).
    pub fn cross(self, o: Point) -> f64 {
        self.x * o.y - self.y * o.x
    }

    /// Euclidean length (m).
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Distance to `o` (m).
    pub fn distance(self, o: Point) -> f64 {
        (self - o).norm()
    }

    /// Direction of the vector from the origin, radians in (−π, π].
    pub fn angle(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// The vector rotated counter-clockwise by `angle` radians.
    pub fn rotated(self, angle: f64) -> Self {
        let (s, c) = angle.sin_cos();
        Self::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl Add for Point {
    type Output = Point;
    fn add(self, o: Point) -> Point {
        Point::new(self.x + o.x, self.y + o.y)
    }
}

impl Sub for Point {
    type Output = Point;
    fn sub(self, o: Point) -> Point {
        Point::new(self.x - o.x, self.y - o.y)
    }
}

impl Mul<f64> for Point {
    type Output = Point;
    fn mul(self, k: f64) -> Point {
        Point::new(self.x * k, self.y * k)
    }
}

impl Neg for Point {
    type Output = Point;
    fn neg(self) -> Point {
        Point::new(-self.x, -self.y)
    }
}

/// Pose of the sensor in scene coordinates: position (m) and heading
/// `theta` (rad, counter-clockwise from the scene's x axis). The sensor frame
/// has x forward and y to the left.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// x of the sensor in scene coordinates (m).
    pub x: f64,
    /// y of the sensor in scene coordinates (m).
    pub y: f64,
    /// Heading of the sensor's x axis (rad).
    pub theta: f64,
}

impl Pose {
    /// The sensor at the scene origin, looking along the scene's x axis.
    pub const IDENTITY: Pose = Pose::new(0.0, 0.0, 0.0);

    /// A pose at `(x, y)` metres with heading `theta` radians.
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// The sensor position in scene coordinates (m).
    pub fn position(self) -> Point {
        Point::new(self.x, self.y)
    }

    /// A scene point expressed in the sensor frame.
    pub fn to_sensor(self, scene: Point) -> Point {
        (scene - self.position()).rotated(-self.theta)
    }

    /// A sensor-frame point expressed in scene coordinates.
    pub fn to_scene(self, sensor: Point) -> Point {
        sensor.rotated(self.theta) + self.position()
    }
}

/// `a` wrapped into (−π, π] (radians).
pub fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

/// An infinite straight line in polar form: the points with
/// `x·cos α + y·sin α = r`, where `r ≥ 0` (m) is the distance from the origin
/// and `α ∈ (−π, π]` (rad) the direction of the normal towards the line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolarLine {
    /// Direction of the normal from the origin to the line (rad).
    pub alpha: f64,
    /// Distance of the line from the origin (m, ≥ 0).
    pub r: f64,
}

impl PolarLine {
    /// The line through `a` and `b`, or `None` if they coincide. For a line
    /// through the origin (`r = 0`) the normal is the one of the two that
    /// points to the left of `a → b`.
    pub fn through(a: Point, b: Point) -> Option<Self> {
        let e = b - a;
        let len = e.norm();
        if len == 0.0 || !len.is_finite() {
            return None;
        }
        let mut n = Point::new(-e.y, e.x) * (1.0 / len);
        let mut r = n.dot(a);
        if r < 0.0 {
            r = -r;
            n = -n;
        }
        Some(Self {
            alpha: wrap_angle(n.angle()),
            r,
        })
    }

    /// Signed distance of `p` from the line (m), positive on the far side
    /// from the origin.
    pub fn distance(&self, p: Point) -> f64 {
        p.x * self.alpha.cos() + p.y * self.alpha.sin() - self.r
    }

    /// Range (m) at which a ray from the origin at `bearing` (rad) meets the
    /// line: `r / cos(bearing − α)`, or `None` if the ray points away from it.
    pub fn range_at(&self, bearing: f64) -> Option<f64> {
        let c = (bearing - self.alpha).cos();
        (c > 0.0).then(|| self.r / c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_range() {
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-15);
        assert!((wrap_angle(-0.25) + 0.25).abs() < 1e-15);
    }

    #[test]
    fn pose_round_trip() {
        let pose = Pose::new(1.5, -0.7, 2.3);
        let p = Point::new(-3.25, 4.0);
        let q = pose.to_scene(pose.to_sensor(p));
        assert!(p.distance(q) < 1e-12);
        // The sensor's x axis points along theta.
        let ahead = pose.to_scene(Point::new(1.0, 0.0)) - pose.position();
        assert!((ahead.angle() - 2.3).abs() < 1e-12);
    }

    #[test]
    fn polar_line_of_points() {
        // The line x = 2 has α = 0, r = 2 whichever way it is walked.
        for (a, b) in [
            (Point::new(2.0, -1.0), Point::new(2.0, 3.0)),
            (Point::new(2.0, 3.0), Point::new(2.0, -1.0)),
        ] {
            let l = PolarLine::through(a, b).unwrap();
            assert!(l.alpha.abs() < 1e-15 && (l.r - 2.0).abs() < 1e-15);
        }
        // y = −1.5: the normal points to −y.
        let l = PolarLine::through(Point::new(-4.0, -1.5), Point::new(1.0, -1.5)).unwrap();
        assert!((l.alpha + PI / 2.0).abs() < 1e-15 && (l.r - 1.5).abs() < 1e-15);
        assert!(l.distance(Point::new(7.0, -1.5)).abs() < 1e-15);
        assert!((l.range_at(-PI / 2.0).unwrap() - 1.5).abs() < 1e-15);
        assert!(l.range_at(PI / 2.0).is_none());
        assert!(PolarLine::through(Point::ORIGIN, Point::ORIGIN).is_none());
    }
}
