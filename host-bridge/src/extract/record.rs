//! Run the extractor on frames and turn each result into a record: JSON
//! Lines, or ROS 2 messages.
//!
//! One [`FrameRecord`] per frame, written as one line of JSON (JSON Lines).
//! Every `f32` of the library is serialized as `f32`: serde_json prints the
//! shortest decimal that parses back to the same `f32` bits, so a reader
//! that parses the number (to f64 or f32) and rounds to `f32` gets the
//! library's value exactly. Non-finite values are written as `null`.
//!
//! The records also implement `Deserialize`, so other tools (`verify`,
//! `plot`) can read the output back into the same types.

use std::io::{self, Write};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lms_core::Stats;
use lms_core::{Extractor, Frame, Params, Trace};
use serde::{Deserialize, Serialize};

use crate::input::InputFrame;
use crate::ros2::messages::Stamp;
use crate::ros2::rosbag2_out::RosOut;

/// One frame's input, ranges and features.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Frame index in the source (the `FLASER` index of a log, counting from 0).
    pub frame: usize,
    /// Number of beams.
    pub n: usize,
    /// Raw ranges (m), `null` for invalid beams.
    pub ranges: Vec<Option<f32>>,
    /// Smoothed ranges after the last pass (m), `null` for invalid beams.
    pub smoothed: Vec<Option<f32>>,
    /// `D` of the last pass per window: entry `i` covers beams `i..=i+2`
    /// (`n − 2` entries), `null` where the window is invalid (`D = +inf`).
    pub mahalanobis: Vec<Option<f32>>,
    /// Edge points (beam indices), ascending.
    pub edges: Vec<u16>,
    /// Segments as `[first, last]` beam indices (inclusive).
    pub segments: Vec<[u16; 2]>,
    /// Accepted lines in scan order.
    pub lines: Vec<LineRecord>,
    /// Corners between consecutive lines.
    pub corners: Vec<CornerRecord>,
    /// What the run dropped or rejected.
    pub stats: StatsRecord,
    /// Laser pose `[x, y, θ]` from the log (m, m, rad); absent for synthetic
    /// frames and captures; a non-finite field is written `null` and read
    /// back as NaN.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "pose_with_nulls"
    )]
    pub pose: Option<[f64; 3]>,
}

/// A fitted line `x·cos α + y·sin α = r`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LineRecord {
    /// Normal direction α (rad), in (−π, π].
    pub alpha: f32,
    /// Distance from the sensor (m), ≥ 0.
    pub r: f32,
    /// Covariance of (α, r): `[[αα, αr], [αr, rr]]`.
    pub cov: [[f32; 2]; 2],
    /// First beam of the fitted segment.
    pub first: u16,
    /// Last beam of the fitted segment (inclusive).
    pub last: u16,
    /// Valid points in the fit.
    pub points: u16,
    /// Fit quality, ≈ 1 for a true line.
    pub chi2: f32,
    /// First and last points projected onto the line, `[[x, y], [x, y]]` (m).
    pub endpoints: [[f32; 2]; 2],
}

/// An intersection of two consecutive lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CornerRecord {
    /// x (m), forward.
    pub x: f32,
    /// y (m), left.
    pub y: f32,
    /// Covariance of (x, y): `[[xx, xy], [xy, yy]]` (m²).
    pub cov: [[f32; 2]; 2],
    /// Angle between the lines, in [0°, 90°].
    pub angle_deg: f32,
    /// `angle_deg >= min_corner_angle_deg`.
    pub well_conditioned: bool,
    /// Index of the first line in `lines`.
    pub line_a: u8,
    /// Index of the second line in `lines`.
    pub line_b: u8,
}

/// [`Stats`] of a run, field for field: in JSON an object with one key
/// per entry of [`Stats::FIELDS`], in that order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatsRecord(pub Stats);

impl From<&Stats> for StatsRecord {
    fn from(s: &Stats) -> Self {
        StatsRecord(*s)
    }
}

impl std::ops::Deref for StatsRecord {
    type Target = Stats;

    fn deref(&self) -> &Stats {
        &self.0
    }
}

impl Serialize for StatsRecord {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(Stats::FIELDS.len()))?;
        for (name, read) in Stats::FIELDS {
            map.serialize_entry(name, &read(&self.0))?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for StatsRecord {
    /// Counters by name, every one of [`Stats::FIELDS`] required (other
    /// keys are ignored).
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let by_name = std::collections::BTreeMap::<String, u16>::deserialize(deserializer)?;
        let values = Stats::FIELDS
            .iter()
            .map(|(name, _)| {
                by_name
                    .get(*name)
                    .copied()
                    .ok_or_else(|| serde::de::Error::missing_field(name))
            })
            .collect::<Result<Vec<u16>, D::Error>>()?;
        Ok(StatsRecord(Stats::from_fields(&values)))
    }
}

/// A pose whose `null` fields (non-finite values in the log) read as NaN.
fn pose_with_nulls<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    let pose = Option::<[Option<f64>; 3]>::deserialize(d)?;
    Ok(pose.map(|p| p.map(|v| v.unwrap_or(f64::NAN))))
}

fn finite(x: f32) -> Option<f32> {
    x.is_finite().then_some(x)
}

impl FrameRecord {
    /// The record of the extractor's last run on `frame`.
    pub fn from_run(index: usize, frame: &Frame, ex: &Extractor, trace: &Trace) -> Self {
        let beams = frame.beams();
        let valid_or_null = |values: &[f32]| -> Vec<Option<f32>> {
            values
                .iter()
                .zip(beams)
                .map(|(&v, b)| b.is_valid().then_some(v))
                .collect()
        };
        let f = ex.features();
        FrameRecord {
            frame: index,
            n: frame.len(),
            ranges: valid_or_null(frame.ranges()),
            smoothed: valid_or_null(ex.smoothed()),
            mahalanobis: trace.mahalanobis().iter().map(|&d| finite(d)).collect(),
            edges: f.edges().iter().collect::<Vec<u16>>(),
            segments: f.segments().iter().map(|s| [s.first, s.last]).collect(),
            lines: f
                .lines()
                .iter()
                .map(|l| LineRecord {
                    alpha: l.alpha,
                    r: l.r,
                    cov: l.cov.to_array(),
                    first: l.first,
                    last: l.last,
                    points: l.points,
                    chi2: l.chi2,
                    endpoints: l.endpoints,
                })
                .collect(),
            corners: f
                .corners()
                .iter()
                .map(|c| CornerRecord {
                    x: c.x,
                    y: c.y,
                    cov: c.cov.to_array(),
                    angle_deg: c.angle_deg,
                    well_conditioned: c.well_conditioned,
                    line_a: c.line_a,
                    line_b: c.line_b,
                })
                .collect(),
            stats: StatsRecord::from(f.stats()),
            pose: None,
        }
    }
}

/// Totals of an extraction run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Frames processed.
    pub frames: usize,
    /// Lines over all frames.
    pub lines: usize,
    /// Corners over all frames.
    pub corners: usize,
    /// Well-conditioned corners over all frames.
    pub well_conditioned: usize,
    /// Time spent in `Extractor::run` alone.
    pub pipeline: Duration,
    /// `true` if the reader closed the output early (e.g. `| head`).
    pub output_closed: bool,
}

/// Run the pipeline on every frame and write one JSON line per frame to `out`.
///
/// A closed pipe on the output ends the run early without an error
/// ([`Summary::output_closed`]); other write errors are errors.
pub fn extract_to<I, W>(frames: I, params: &Params, out: W) -> Result<Summary>
where
    I: IntoIterator<Item = Result<InputFrame>>,
    W: Write,
{
    extract_named(frames, params, out, "the output")
}

/// [`extract_to`], naming the output `name` in errors (e.g. the file).
pub fn extract_named<I, W>(frames: I, params: &Params, out: W, name: &str) -> Result<Summary>
where
    I: IntoIterator<Item = Result<InputFrame>>,
    W: Write,
{
    extract_observed(frames, params, out, name, false, &mut |_, _| {})
}

/// [`extract_named`], calling `each` with every frame and its features
/// once its record is written (the live view of `extract --realtime`);
/// `flush_each` flushes the output after every record (a paced replay's
/// reader gets each frame when it is due).
pub fn extract_observed<I, W>(
    frames: I,
    params: &Params,
    out: W,
    name: &str,
    flush_each: bool,
    each: &mut dyn FnMut(&InputFrame, &lms_core::Features),
) -> Result<Summary>
where
    I: IntoIterator<Item = Result<InputFrame>>,
    W: Write,
{
    let cannot = || format!("cannot write {name}");
    let params = params
        .validate()
        .map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
    let mut out = io::BufWriter::new(out);
    let mut ex = Extractor::new();
    let mut trace = Trace::new();
    let mut summary = Summary::default();
    let mut line = Vec::with_capacity(16 * 1024);
    for input in frames {
        let input = input?;
        let start = Instant::now();
        ex.run_traced(&input.frame, &params, &mut trace);
        summary.pipeline += start.elapsed();
        let mut record = FrameRecord::from_run(input.index, &input.frame, &ex, &trace);
        record.pose = input.pose;
        summary.frames += 1;
        summary.lines += record.lines.len();
        summary.corners += record.corners.len();
        summary.well_conditioned += record.corners.iter().filter(|c| c.well_conditioned).count();
        line.clear();
        serde_json::to_writer(&mut line, &record).context("cannot serialize a frame record")?;
        line.push(b'\n');
        let written = match flush_each {
            true => out.write_all(&line).and_then(|()| out.flush()),
            false => out.write_all(&line),
        };
        match written {
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => {
                summary.output_closed = true;
                return Ok(summary);
            }
            other => other.with_context(cannot)?,
        }
        each(&input, ex.features());
    }
    match out.flush() {
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => summary.output_closed = true,
        other => other.with_context(cannot)?,
    }
    Ok(summary)
}

/// Run the pipeline on every frame and write its scan, markers and
/// features as ROS 2 messages, with the frame's stamp, to `out` (an MCAP
/// file or a rosbag2 folder: `extract -o x.mcap`, `--format rosbag2`);
/// `out` is finished (summary, indexes, `metadata.yaml`) at the end.
pub fn extract_to_ros<I>(frames: I, params: &Params, mut out: RosOut) -> Result<Summary>
where
    I: IntoIterator<Item = Result<(InputFrame, Stamp)>>,
{
    let params = params
        .validate()
        .map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
    let mut ex = Extractor::new();
    let mut summary = Summary::default();
    for input in frames {
        let (input, stamp) = input?;
        let start = Instant::now();
        let features = ex.run(&input.frame, &params);
        summary.pipeline += start.elapsed();
        summary.frames += 1;
        summary.lines += features.lines().len();
        summary.corners += features.corners().len();
        summary.well_conditioned += features
            .corners()
            .iter()
            .filter(|c| c.well_conditioned)
            .count();
        out.write_frame(&stamp, &input.frame, features)?;
    }
    out.finish()?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::{Invalid, Variant};

    #[test]
    fn record_of_a_wall() {
        // A straight wall 2 m ahead, one no-echo beam.
        let g = Variant::Fov180Res100.geometry();
        let ranges: Vec<f32> = (0..181)
            .map(|j| {
                let c = libm_cos(g.bearing(j));
                if c > 0.2 {
                    2.0 / c
                } else {
                    0.0
                }
            })
            .collect();
        let mut frame = Frame::from_metres(g, &ranges).unwrap();
        frame.set_invalid(90, Invalid::NoEcho);
        let mut out = Vec::new();
        let s = extract_to(
            [Ok(InputFrame {
                index: 7,
                frame: frame.clone(),
                pose: None,
            })],
            &Params::default(),
            &mut out,
        )
        .unwrap();
        assert_eq!(s.frames, 1);
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text.lines().count(), 1);
        let rec: FrameRecord = serde_json::from_str(text.trim_end()).unwrap();
        assert_eq!(rec.frame, 7);
        assert_eq!(rec.n, 181);
        assert_eq!(rec.ranges[90], None);
        assert_eq!(rec.smoothed[90], None);
        assert_eq!(rec.mahalanobis.len(), 179);
        assert!(rec.mahalanobis[88..=90].iter().all(Option::is_none));
        assert_eq!(rec.lines.len(), 1, "{text}");
        assert!((rec.lines[0].r - 2.0).abs() < 1e-3);
        assert!(!text.contains("pose"));
        // Bit-exact round trip against a direct run.
        let mut ex = Extractor::new();
        let mut trace = Trace::new();
        ex.run_traced(&frame, &lms_core::ValidParams::DEFAULT, &mut trace);
        assert_eq!(rec, FrameRecord::from_run(7, &frame, &ex, &trace));
    }

    /// A NaN pose field is written `null` and read back.
    #[test]
    fn nan_pose_round_trips() {
        let frame = Frame::from_metres(Variant::Fov180Res100.geometry(), &[2.0; 181]).unwrap();
        let mut out = Vec::new();
        extract_to(
            [Ok(InputFrame {
                index: 0,
                frame,
                pose: Some([1.0, f64::NAN, f64::INFINITY]),
            })],
            &Params::default(),
            &mut out,
        )
        .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("\"pose\":[1.0,null,null]"), "{text}");
        let rec: FrameRecord = serde_json::from_str(text.trim_end()).unwrap();
        let pose = rec.pose.unwrap();
        assert_eq!(pose[0], 1.0);
        assert!(pose[1].is_nan() && pose[2].is_nan());
    }

    fn libm_cos(x: f32) -> f32 {
        x.cos()
    }
}
