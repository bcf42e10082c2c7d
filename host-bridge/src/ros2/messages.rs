//! The ROS 2 messages of one frame, CDR-encoded: what the MCAP and rosbag2
//! outputs write and the live view publishes.
//!
//! Three streams ([`CHANNELS`]):
//!
//! * [`SCAN`] — `/scan`, `sensor_msgs/msg/LaserScan`: the ranges in metres,
//!   a beam without an echo `+inf`, any other invalid beam NaN
//!   ([`laser_scan()`]).
//! * [`MARKERS`] — `/features/markers`, `visualization_msgs/msg/MarkerArray`:
//!   the features drawn for RViz and Foxglove. Each array starts with a
//!   `DELETEALL` marker, so a frame's markers replace the previous frame's.
//!   Then namespace `lines` (one `LINE_LIST`: a segment between each line's
//!   end points), `corners` (one `POINTS`: well-conditioned corners orange,
//!   the others grey), `corner_ellipses` (one closed `LINE_STRIP` per corner
//!   whose covariance is positive definite: its 95 % confidence ellipse, the covariance scaled by χ²₂(0.95) = 5.991)
//!   and `edges` (one `POINTS` at the edge beams' ranges). An empty kind
//!   has no marker.
//! * [`FEATURES`] — `/features`, `lms_features_msgs/msg/Features`: the
//!   features for programs, every `f32` as the library computed it. Its
//!   definition is the `.msg` files of `ros2/lms_features_msgs/`, embedded
//!   here as they are.
//!
//! Every schema is `ros2msg` text: the type's definition, then each type it
//! uses after a line of 80 `=` and `MSG: package/Type`, as ROS 2 tools
//! write it. The `Marker` layout is that of ROS 2 Humble and later. Every message is CDR, little-endian, after the 4-byte
//! encapsulation header `00 01 00 00`.

use lms_core::{Beam, Corner, Features, Frame, Invalid, Line};

use serde::Serialize;

use super::cdr;
use super::laser_scan::{self, Header, LaserScan, Time};

/// One published stream: topic, ROS 2 type name, ros2msg schema text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    /// The topic, e.g. `/scan`.
    pub topic: &'static str,
    /// The ROS 2 type name, e.g. `sensor_msgs/msg/LaserScan`.
    pub type_name: &'static str,
    /// The type's definition with its dependencies (encoding `ros2msg`).
    pub schema: &'static str,
}

/// The scans.
pub const SCAN: Channel = Channel {
    topic: "/scan",
    type_name: laser_scan::SCHEMA_NAME,
    schema: laser_scan::SCHEMA_TEXT,
};

/// The features drawn (lines, corners with their ellipses, edge points).
pub const MARKERS: Channel = Channel {
    topic: "/features/markers",
    type_name: "visualization_msgs/msg/MarkerArray",
    schema: MARKER_ARRAY_SCHEMA,
};

/// The features for programs (`lms_features_msgs/msg/Features`).
pub const FEATURES: Channel = Channel {
    topic: "/features",
    type_name: "lms_features_msgs/msg/Features",
    schema: FEATURES_SCHEMA,
};

/// Every stream, in the order they are written for a frame.
pub const CHANNELS: [Channel; 3] = [SCAN, MARKERS, FEATURES];

/// The frame id of scans whose source names none (CARMEN logs, captures,
/// a sensor).
pub const DEFAULT_FRAME_ID: &str = "laser";

/// Stamp and frame id of one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stamp {
    /// Nanoseconds since the epoch (or since the recording's start).
    pub ns: i64,
    /// The frame of reference of the scan, e.g. `laser`.
    pub frame_id: String,
}

impl Stamp {
    /// The stamp as a ROS 2 header.
    pub fn header(&self) -> Header {
        Header {
            stamp: Time::from_nanos(self.ns),
            frame_id: self.frame_id.clone(),
        }
    }
}

/// The largest distance an LMS 2xx reports (m): 8183 cm, its first error
/// code in centimetre mode.
pub const RANGE_MAX: f32 = 81.83;

/// The scan as a `sensor_msgs/msg/LaserScan`: bearings from the frame's
/// geometry, the ranges in metres; a beam without an echo (or above the
/// sensor's maximum) is `+inf`, any other invalid beam NaN (REP 117).
/// `scan_time` and `time_increment` are 0 (not known from a frame).
pub fn laser_scan(stamp: &Stamp, frame: &Frame) -> LaserScan {
    let g = frame.geometry();
    let ranges = frame
        .ranges()
        .iter()
        .zip(frame.beams())
        .map(|(&r, b)| match b {
            Beam::Valid => r,
            Beam::Invalid(Invalid::NoEcho | Invalid::AboveMax) => f32::INFINITY,
            Beam::Invalid(_) => f32::NAN,
        })
        .collect();
    LaserScan {
        header: stamp.header(),
        angle_min: g.first_bearing,
        angle_max: g.bearing(frame.len().saturating_sub(1)),
        angle_increment: g.step,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: 0.0,
        range_max: RANGE_MAX,
        ranges,
        intensities: Vec::new(),
    }
}

/// The scan as a `sensor_msgs/msg/LaserScan` (CDR; see [`laser_scan()`]).
pub fn scan_cdr(stamp: &Stamp, frame: &Frame) -> Vec<u8> {
    laser_scan::encode(&laser_scan(stamp, frame))
}

/// The features drawn, as a `visualization_msgs/msg/MarkerArray` (CDR).
pub fn markers_cdr(stamp: &Stamp, frame: &Frame, features: &Features) -> Vec<u8> {
    let markers = markers(stamp, frame, features);
    cdr::encode(&MarkerArray {
        markers: markers.iter().map(Marker::message).collect(),
    })
}

/// The features as a `lms_features_msgs/msg/Features` (CDR).
pub fn features_cdr(stamp: &Stamp, features: &Features) -> Vec<u8> {
    let mut stats = [0u16; lms_core::Stats::FIELDS.len()];
    for (slot, (_, read)) in stats.iter_mut().zip(lms_core::Stats::FIELDS) {
        *slot = read(features.stats());
    }
    cdr::encode(&FeaturesMessage {
        header: stamp.header(),
        lines: features.lines().iter().map(LineMessage::from).collect(),
        corners: features.corners().iter().map(CornerMessage::from).collect(),
        edge_points: features.edges().iter().collect(),
        stats,
    })
}

/// `lms_features_msgs/msg/Features`, field by field as its `.msg` file.
#[derive(Serialize)]
struct FeaturesMessage {
    header: Header,
    lines: Vec<LineMessage>,
    corners: Vec<CornerMessage>,
    edge_points: Vec<u16>,
    /// `lms_features_msgs/msg/Stats`: every counter in [`lms_core::Stats::FIELDS`] order.
    stats: [u16; lms_core::Stats::FIELDS.len()],
}

/// `lms_features_msgs/msg/Line`.
#[derive(Serialize)]
struct LineMessage {
    alpha: f32,
    r: f32,
    covariance: [f32; 4],
    first_beam: u16,
    last_beam: u16,
    points: u16,
    chi2: f32,
    endpoints: [f32; 4],
}

impl From<&Line> for LineMessage {
    fn from(l: &Line) -> Self {
        let [[x0, y0], [x1, y1]] = l.endpoints;
        LineMessage {
            alpha: l.alpha,
            r: l.r,
            covariance: [l.cov.a, l.cov.b, l.cov.b, l.cov.c],
            first_beam: l.first,
            last_beam: l.last,
            points: l.points,
            chi2: l.chi2,
            endpoints: [x0, y0, x1, y1],
        }
    }
}

/// `lms_features_msgs/msg/Corner`.
#[derive(Serialize)]
struct CornerMessage {
    x: f32,
    y: f32,
    covariance: [f32; 4],
    angle_deg: f32,
    well_conditioned: bool,
    line_a: u8,
    line_b: u8,
}

impl From<&Corner> for CornerMessage {
    fn from(c: &Corner) -> Self {
        CornerMessage {
            x: c.x,
            y: c.y,
            covariance: [c.cov.a, c.cov.b, c.cov.b, c.cov.c],
            angle_deg: c.angle_deg,
            well_conditioned: c.well_conditioned,
            line_a: c.line_a,
            line_b: c.line_b,
        }
    }
}

/// `geometry_msgs/msg/Point` (and `Vector3`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
struct Point {
    x: f64,
    y: f64,
    z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
struct Quaternion {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
struct Pose {
    position: Point,
    orientation: Quaternion,
}

/// The identity pose: the marker's points are in the scan's frame.
const IDENTITY: Pose = Pose {
    position: Point {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    },
    orientation: Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    },
};

/// `std_msgs/msg/ColorRGBA`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
struct Color {
    r: f32,
    g: f32,
    b: f32,
    a: f32,
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Serialize)]
struct Duration {
    sec: i32,
    nanosec: u32,
}

/// `sensor_msgs/msg/CompressedImage`.
#[derive(Serialize)]
struct CompressedImage {
    header: Header,
    format: String,
    data: Vec<u8>,
}

/// `visualization_msgs/msg/UVCoordinate`.
#[derive(Serialize)]
struct UvCoordinate {
    u: f32,
    v: f32,
}

/// `visualization_msgs/msg/MeshFile`.
#[derive(Serialize)]
struct MeshFile {
    filename: String,
    data: Vec<u8>,
}

/// `visualization_msgs/msg/Marker` (the layout of ROS 2 Humble and later).
#[derive(Serialize)]
struct MarkerMessage {
    header: Header,
    ns: String,
    id: i32,
    #[serde(rename = "type")]
    kind: i32,
    action: i32,
    pose: Pose,
    scale: Point,
    color: Color,
    lifetime: Duration,
    frame_locked: bool,
    points: Vec<Point>,
    colors: Vec<Color>,
    texture_resource: String,
    texture: CompressedImage,
    uv_coordinates: Vec<UvCoordinate>,
    text: String,
    mesh_resource: String,
    mesh_file: MeshFile,
    mesh_use_embedded_materials: bool,
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Serialize)]
struct MarkerArray {
    markers: Vec<MarkerMessage>,
}

/// The fields of a `visualization_msgs/msg/Marker` that these markers set;
/// the others are empty (identity pose, lifetime 0 = forever, no texture,
/// text or mesh).
#[derive(Clone, Debug)]
struct Marker<'a> {
    stamp: &'a Stamp,
    ns: &'static str,
    id: i32,
    kind: i32,
    action: i32,
    /// `scale.x` (= `scale.y`): the line width, or the point size (m).
    width: f64,
    color: Color,
    points: Vec<Point>,
    colors: Vec<Color>,
}

const LINE_STRIP: i32 = 4;
const LINE_LIST: i32 = 5;
const POINTS: i32 = 8;
const ADD: i32 = 0;
const DELETEALL: i32 = 3;

/// χ² with 2 degrees of freedom at 95 %: the ellipse `dᵀ C⁻¹ d = 5.991`.
const CHI2_2DOF_95: f64 = 5.991_464_547_107_979;
/// Vertices of a corner's ellipse (the strip is closed: one more point).
const ELLIPSE_VERTICES: usize = 36;

const fn rgba(r: f32, g: f32, b: f32, a: f32) -> Color {
    Color { r, g, b, a }
}
const LINE_COLOR: Color = rgba(0.1, 0.8, 0.2, 1.0);
const CORNER_COLOR: Color = rgba(1.0, 0.55, 0.0, 1.0);
const WEAK_CORNER_COLOR: Color = rgba(0.6, 0.6, 0.6, 1.0);
const ELLIPSE_COLOR: Color = rgba(1.0, 0.3, 0.0, 0.8);
const EDGE_COLOR: Color = rgba(0.2, 0.5, 1.0, 1.0);

impl<'a> Marker<'a> {
    /// An `ADD` marker of `kind` drawing `points`, `width` m wide in `color`.
    fn drawing(stamp: &'a Stamp, ns: &'static str, kind: i32, points: Vec<Point>) -> Self {
        Marker {
            stamp,
            ns,
            id: 0,
            kind,
            action: ADD,
            width: 0.0,
            color: Color::default(),
            points,
            colors: Vec::new(),
        }
    }

    fn sized(mut self, width: f64, color: Color) -> Self {
        self.width = width;
        self.color = color;
        self
    }

    /// The whole `visualization_msgs/msg/Marker`.
    fn message(&self) -> MarkerMessage {
        let header = self.stamp.header();
        MarkerMessage {
            header: header.clone(),
            ns: self.ns.to_owned(),
            id: self.id,
            kind: self.kind,
            action: self.action,
            pose: IDENTITY,
            scale: Point {
                x: self.width,
                y: self.width,
                z: 0.0,
            },
            color: self.color,
            lifetime: Duration { sec: 0, nanosec: 0 },
            frame_locked: false,
            points: self.points.clone(),
            colors: self.colors.clone(),
            texture_resource: String::new(),
            texture: CompressedImage {
                header,
                format: String::new(),
                data: Vec::new(),
            },
            uv_coordinates: Vec::new(),
            text: String::new(),
            mesh_resource: String::new(),
            mesh_file: MeshFile {
                filename: String::new(),
                data: Vec::new(),
            },
            mesh_use_embedded_materials: false,
        }
    }
}

fn point(x: f32, y: f32) -> Point {
    Point {
        x: f64::from(x),
        y: f64::from(y),
        z: 0.0,
    }
}

/// The markers of one frame (see the [module docs](self)).
fn markers<'a>(stamp: &'a Stamp, frame: &Frame, features: &Features) -> Vec<Marker<'a>> {
    let mut clear = Marker::drawing(stamp, "", LINE_LIST, Vec::new());
    clear.action = DELETEALL;
    let mut out = vec![clear];
    let lines = features.lines();
    if !lines.is_empty() {
        let ends = lines
            .iter()
            .flat_map(|l| l.endpoints.map(|[x, y]| point(x, y)))
            .collect();
        out.push(Marker::drawing(stamp, "lines", LINE_LIST, ends).sized(0.03, LINE_COLOR));
    }
    let corners = features.corners();
    if !corners.is_empty() {
        let at = corners.iter().map(|c| point(c.x, c.y)).collect();
        let mut m = Marker::drawing(stamp, "corners", POINTS, at).sized(0.12, CORNER_COLOR);
        m.colors = corners
            .iter()
            .map(|c| match c.well_conditioned {
                true => CORNER_COLOR,
                false => WEAK_CORNER_COLOR,
            })
            .collect();
        out.push(m);
    }
    for (id, c) in corners.iter().enumerate() {
        if let Some(ring) = ellipse(c) {
            let mut m = Marker::drawing(stamp, "corner_ellipses", LINE_STRIP, ring);
            m.id = i32::try_from(id).unwrap_or(i32::MAX);
            out.push(m.sized(0.01, ELLIPSE_COLOR));
        }
    }
    let edges = edge_points(frame, features);
    if !edges.is_empty() {
        out.push(Marker::drawing(stamp, "edges", POINTS, edges).sized(0.06, EDGE_COLOR));
    }
    out
}

/// The points of the edge beams, at their ranges.
fn edge_points(frame: &Frame, features: &Features) -> Vec<Point> {
    let g = frame.geometry();
    features
        .edges()
        .iter()
        .filter_map(|j| {
            let j = usize::from(j);
            let r = *frame.ranges().get(j)?;
            let phi = g.bearing(j);
            Some(point(r * phi.cos(), r * phi.sin()))
        })
        .collect()
}

/// The closed 95 % ellipse of a corner's covariance, or `None` if the
/// covariance is not positive definite (or not finite).
fn ellipse(c: &Corner) -> Option<Vec<Point>> {
    let (a, b, cc) = (f64::from(c.cov.a), f64::from(c.cov.b), f64::from(c.cov.c));
    // Cholesky factor L of the covariance: points centre + k·L·(cos t, sin t).
    let l11 = a.sqrt();
    let l21 = b / l11;
    let l22 = (cc - l21 * l21).sqrt();
    if !(l11 > 0.0 && l22 > 0.0 && l11.is_finite() && l21.is_finite() && l22.is_finite()) {
        return None;
    }
    let k = CHI2_2DOF_95.sqrt();
    let (x, y) = (f64::from(c.x), f64::from(c.y));
    let ring = (0..ELLIPSE_VERTICES).map(|i| {
        let t = std::f64::consts::TAU * i as f64 / ELLIPSE_VERTICES as f64;
        let (u, v) = (k * t.cos(), k * t.sin());
        Point {
            x: x + l11 * u,
            y: y + l21 * u + l22 * v,
            z: 0.0,
        }
    });
    let mut ring: Vec<Point> = ring.collect();
    if let Some(&first) = ring.first() {
        ring.push(first); // closed: the strip ends where it starts
    }
    Some(ring)
}

/// The line of 80 `=` and the `MSG:` line before each dependency.
macro_rules! dependency {
    ($name:literal, $text:expr) => {
        concat!(
            "\n================================================================================\nMSG: ",
            $name,
            "\n",
            $text
        )
    };
}

/// `lms_features_msgs/msg/Features` with its dependencies: the shipped
/// `.msg` files as they are.
pub const FEATURES_SCHEMA: &str = concat!(
    include_str!("../../../ros2/lms_features_msgs/msg/Features.msg"),
    dependency!(
        "lms_features_msgs/Line",
        include_str!("../../../ros2/lms_features_msgs/msg/Line.msg")
    ),
    dependency!(
        "lms_features_msgs/Corner",
        include_str!("../../../ros2/lms_features_msgs/msg/Corner.msg")
    ),
    dependency!(
        "lms_features_msgs/Stats",
        include_str!("../../../ros2/lms_features_msgs/msg/Stats.msg")
    ),
    dependency!(
        "std_msgs/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n"
    ),
    dependency!("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
);

/// `visualization_msgs/msg/MarkerArray` with its dependencies, as MCAP's
/// `ros2msg` encoding and a rosbag2's `type_description` want them: the
/// message's definition, then each dependency after a line of 80 `=` and
/// its `MSG:` line.
pub const MARKER_ARRAY_SCHEMA: &str = include_str!("visualization_msgs_MarkerArray.msg");
