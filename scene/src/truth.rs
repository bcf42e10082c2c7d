//! One cast scan and its ground truth: per-beam hits, the true lines and
//! corners, the classification of every three-beam window, and the jumps.

use rand::Rng;

use crate::bearings::Bearings;
use crate::geometry::{wrap_angle, Point, PolarLine, Pose};
use crate::noise::{NoiseModel, Reading};
use crate::scene::{Scene, Surface, SurfaceId, Wall};

/// Points closer than this are one vertex; walls whose endpoints lie this
/// close to each other's line are collinear (m).
const GEOMETRY_TOL: f64 = 1e-9;

/// Angular slack when deciding whether a vertex lies between two beams (rad).
const BEARING_TOL: f64 = 1e-9;

/// Distance by which another surface must be nearer than a vertex to hide
/// it from the sensor (m).
const OCCLUSION_TOL: f64 = 1e-6;

/// Where one beam hit, in the sensor frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// True range (m).
    pub range: f64,
    /// The surface hit.
    pub surface: SurfaceId,
    /// The hit point in the sensor frame (m): `range·(cos φ, sin φ)`.
    pub point: Point,
}

/// A wall hit by at least two beams, as the line it lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueLine {
    /// The wall.
    pub surface: SurfaceId,
    /// Normal direction of `x·cos α + y·sin α = r` in the sensor frame
    /// (rad, in (−π, π]).
    pub alpha: f64,
    /// Distance of the line from the sensor (m, ≥ 0).
    pub r: f64,
    /// First beam hitting the wall.
    pub first_beam: usize,
    /// Last beam hitting the wall (other surfaces may hide some beams in
    /// between).
    pub last_beam: usize,
    /// Number of beams hitting the wall.
    pub beams: usize,
    /// Hit point of `first_beam`, sensor frame (m).
    pub first_point: Point,
    /// Hit point of `last_beam`, sensor frame (m).
    pub last_point: Point,
}

/// A vertex shared by two walls that are both [`TrueLine`]s of the scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueCorner {
    /// The two walls, lower id first.
    pub walls: [SurfaceId; 2],
    /// The vertex in the sensor frame (m).
    pub point: Point,
    /// Angle between the two walls' lines folded into [0°, 90°] (degrees),
    /// as in ALGORITHM.md §8.
    pub angle_deg: f64,
    /// Fractional beam index of the vertex's bearing (see
    /// [`Bearings::index_of`]).
    pub beam: f64,
    /// `true` if the vertex itself is in the field of view, within the
    /// maximum range and not hidden by a nearer surface.
    pub visible: bool,
}

/// What the three true hit points of a window `j, j+1, j+2` lie on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WindowTruth {
    /// One straight wall, or walls on one line.
    Straight,
    /// At least one point on an arc, no jump, not all on one line.
    Curved,
    /// Two walls meeting at a vertex between the beams.
    Corner,
    /// A jump between `j, j+1` or `j+1, j+2` (see [`TrueScan::jumps`]).
    Jump,
}

impl WindowTruth {
    /// `true` unless the window is [`WindowTruth::Straight`]: its middle
    /// point is a true edge point (ALGORITHM.md §6).
    pub fn is_edge(self) -> bool {
        self != WindowTruth::Straight
    }
}

/// One noise-free scan and its ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct TrueScan {
    /// The bearings cast.
    pub bearings: Bearings,
    /// The sensor pose in scene coordinates.
    pub pose: Pose,
    /// Maximum range (m); farther hits are no returns.
    pub max_range: f64,
    /// Per beam: the nearest hit within the maximum range, or `None`.
    pub hits: Vec<Option<Hit>>,
    /// Walls hit by at least two beams, ordered by first beam.
    pub lines: Vec<TrueLine>,
    /// Vertices between two walls of `lines` (not between collinear walls),
    /// ordered by beam.
    pub corners: Vec<TrueCorner>,
    /// Per window `j` (beams `j, j+1, j+2`; `n−2` windows): what its points
    /// lie on, `None` if any of the three beams has no return.
    pub windows: Vec<Option<WindowTruth>>,
    /// Every `j` where beams `j` and `j+1` both return but the surface is
    /// not continuous between them: different surfaces that are neither on
    /// one line nor joined at a vertex lying between the two beams.
    pub jumps: Vec<usize>,
}

impl TrueScan {
    /// Number of beams.
    pub fn len(&self) -> usize {
        self.hits.len()
    }

    /// `true` for a scan without beams.
    pub fn is_empty(&self) -> bool {
        self.hits.is_empty()
    }

    /// True range per beam (m), `None` without a return.
    pub fn ranges(&self) -> Vec<Option<f64>> {
        self.hits.iter().map(|h| h.map(|h| h.range)).collect()
    }

    /// Surface hit per beam, `None` without a return.
    pub fn surfaces(&self) -> Vec<Option<SurfaceId>> {
        self.hits.iter().map(|h| h.map(|h| h.surface)).collect()
    }

    /// Number of beams with a return.
    pub fn returns(&self) -> usize {
        self.hits.iter().flatten().count()
    }

    /// The true line of this wall, if it is one.
    pub fn line(&self, wall: SurfaceId) -> Option<&TrueLine> {
        self.lines.iter().find(|l| l.surface == wall)
    }

    /// The middle beams `j+1` of the windows whose three points are not on
    /// one straight wall (corners, jumps, arcs), in increasing order.
    pub fn true_edge_points(&self) -> Vec<usize> {
        self.windows
            .iter()
            .enumerate()
            .filter(|(_, w)| w.is_some_and(WindowTruth::is_edge))
            .map(|(j, _)| j + 1)
            .collect()
    }

    /// The true ranges as readings, without noise.
    pub fn noise_free(&self) -> Vec<Reading> {
        self.hits
            .iter()
            .map(|h| h.map_or(Reading::NoReturn, |h| Reading::Range(h.range)))
            .collect()
    }

    /// One noisy scan drawn from `noise` with `rng` (use a seeded
    /// [`rand_chacha::ChaCha8Rng`] for reproducible scans).
    pub fn noisy<R: Rng + ?Sized>(&self, noise: &NoiseModel, rng: &mut R) -> Vec<Reading> {
        self.hits
            .iter()
            .map(|h| noise.reading(h.map(|h| h.range), rng))
            .collect()
    }
}

/// Cast `bearings` from `pose` into `scene` and derive the ground truth.
pub(crate) fn cast(scene: &Scene, bearings: &Bearings, pose: Pose, max_range: f64) -> TrueScan {
    let origin = pose.position();
    let hits: Vec<Option<Hit>> = bearings
        .iter()
        .map(|phi| {
            let h = scene.ray(origin, pose.theta + phi)?;
            (h.range <= max_range).then(|| Hit {
                range: h.range,
                surface: h.surface,
                point: Point::polar(h.range, phi),
            })
        })
        .collect();

    let topo = Topology {
        scene,
        bearings,
        pose,
    };
    let jump_after: Vec<bool> = hits
        .windows(2)
        .enumerate()
        .map(|(j, p)| match (p[0], p[1]) {
            (Some(a), Some(b)) => topo.is_jump(j, a.surface, b.surface),
            _ => false,
        })
        .collect();
    let windows = hits
        .windows(3)
        .enumerate()
        .map(|(j, w)| {
            let s = [w[0]?.surface, w[1]?.surface, w[2]?.surface];
            Some(topo.classify(s, jump_after[j] || jump_after[j + 1]))
        })
        .collect();
    let jumps = (0..jump_after.len()).filter(|&j| jump_after[j]).collect();
    let lines = true_lines(scene, pose, &hits);
    let corners = true_corners(&topo, max_range, &lines);

    TrueScan {
        bearings: *bearings,
        pose,
        max_range,
        hits,
        lines,
        corners,
        windows,
        jumps,
    }
}

/// How the surfaces of a scene connect, as seen in one scan.
struct Topology<'a> {
    scene: &'a Scene,
    bearings: &'a Bearings,
    pose: Pose,
}

impl Topology<'_> {
    fn wall(&self, id: SurfaceId) -> Option<&Wall> {
        match self.scene.surface(id)? {
            Surface::Wall(w) => Some(w),
            Surface::Arc(_) => None,
        }
    }

    /// Both surfaces are walls on one infinite line (a wall is on its own).
    fn same_line(&self, s1: SurfaceId, s2: SurfaceId) -> bool {
        match (self.wall(s1), self.wall(s2)) {
            (Some(w1), Some(w2)) => collinear(w1, w2),
            _ => false,
        }
    }

    /// Endpoints shared by two different surfaces (scene coordinates).
    fn shared_vertices(&self, s1: SurfaceId, s2: SurfaceId) -> Vec<Point> {
        let (Some(a), Some(b)) = (self.scene.surface(s1), self.scene.surface(s2)) else {
            return Vec::new();
        };
        let ends_b = b.endpoints();
        a.endpoints()
            .into_iter()
            .filter(|p| ends_b.iter().any(|q| p.distance(*q) <= GEOMETRY_TOL))
            .collect()
    }

    /// Is the surface broken between beam `j` (on `s1`) and `j+1` (on `s2`)?
    fn is_jump(&self, j: usize, s1: SurfaceId, s2: SurfaceId) -> bool {
        if s1 == s2 || self.same_line(s1, s2) {
            return false;
        }
        let lo = self.bearings.bearing(j);
        let joined_between = self.shared_vertices(s1, s2).into_iter().any(|v| {
            let d = wrap_angle(self.pose.to_sensor(v).angle() - lo);
            (-BEARING_TOL..=self.bearings.step + BEARING_TOL).contains(&d)
        });
        !joined_between
    }

    /// Classify a window on surfaces `s` (all returning).
    fn classify(&self, s: [SurfaceId; 3], has_jump: bool) -> WindowTruth {
        if has_jump {
            WindowTruth::Jump
        } else if self.same_line(s[0], s[1]) && self.same_line(s[1], s[2]) {
            WindowTruth::Straight
        } else if s.iter().any(|&id| self.wall(id).is_none()) {
            WindowTruth::Curved
        } else {
            WindowTruth::Corner
        }
    }
}

/// Walls `w1` and `w2` lie on one infinite line.
fn collinear(w1: &Wall, w2: &Wall) -> bool {
    let e = w1.b - w1.a;
    let len = e.norm();
    let off_line = |p: Point| (e.cross(p - w1.a) / len).abs();
    len > 0.0 && off_line(w2.a) <= GEOMETRY_TOL && off_line(w2.b) <= GEOMETRY_TOL
}

/// Angle between the lines of two walls, folded into [0°, 90°].
fn folded_angle_deg(w1: &Wall, w2: &Wall) -> f64 {
    let (e1, e2) = (w1.b - w1.a, w2.b - w2.a);
    e1.cross(e2).abs().atan2(e1.dot(e2).abs()).to_degrees()
}

fn true_lines(scene: &Scene, pose: Pose, hits: &[Option<Hit>]) -> Vec<TrueLine> {
    let mut lines: Vec<TrueLine> = scene
        .walls
        .iter()
        .filter_map(|w| {
            let on_wall: Vec<(usize, Point)> = hits
                .iter()
                .enumerate()
                .filter_map(|(j, h)| h.filter(|h| h.surface == w.id).map(|h| (j, h.point)))
                .collect();
            if on_wall.len() < 2 {
                return None;
            }
            let (first_beam, first_point) = on_wall[0];
            let (last_beam, last_point) = on_wall[on_wall.len() - 1];
            let line = PolarLine::through(pose.to_sensor(w.a), pose.to_sensor(w.b))?;
            Some(TrueLine {
                surface: w.id,
                alpha: line.alpha,
                r: line.r,
                first_beam,
                last_beam,
                beams: on_wall.len(),
                first_point,
                last_point,
            })
        })
        .collect();
    lines.sort_by_key(|l| l.first_beam);
    lines
}

fn true_corners(topo: &Topology, max_range: f64, lines: &[TrueLine]) -> Vec<TrueCorner> {
    let origin = topo.pose.position();
    let last_index = topo.bearings.n.saturating_sub(1) as f64;
    let mut corners = Vec::new();
    for (i, l1) in lines.iter().enumerate() {
        for l2 in &lines[i + 1..] {
            let (Some(w1), Some(w2)) = (topo.wall(l1.surface), topo.wall(l2.surface)) else {
                continue;
            };
            if collinear(w1, w2) {
                continue;
            }
            let angle_deg = folded_angle_deg(w1, w2);
            for v in topo.shared_vertices(w1.id, w2.id) {
                let point = topo.pose.to_sensor(v);
                let (dist, bearing) = (point.norm(), point.angle());
                let beam = topo.bearings.index_of(bearing);
                let unhidden = topo
                    .scene
                    .ray(origin, topo.pose.theta + bearing)
                    .is_none_or(|h| h.range >= dist - OCCLUSION_TOL);
                corners.push(TrueCorner {
                    walls: [w1.id.min(w2.id), w1.id.max(w2.id)],
                    point,
                    angle_deg,
                    beam,
                    visible: (0.0..=last_index).contains(&beam) && dist <= max_range && unhidden,
                });
            }
        }
    }
    corners.sort_by(|a, b| a.beam.total_cmp(&b.beam));
    corners
}
