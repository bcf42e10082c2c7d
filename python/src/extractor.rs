//! `Extractor.run`: the core's pipeline on one scan, the GIL released while
//! it runs, its features as numpy arrays (`Features`).

use std::sync::Mutex;

use lms_core::{Extractor as CoreExtractor, Frame as CoreFrame, Stats, Trace};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Cell, CORNERS, LINES, SEGMENTS};
use crate::params::Params;
use crate::scan::{frame_of, variant_of, Frame};

/// The working memory of one extractor (about 40 KB, on the heap).
struct Work {
    ex: CoreExtractor,
    trace: Trace,
}

/// Runs the pipeline on scans, one at a time.
///
/// ``Extractor(params=None)``: with ``params`` (a ``Params``), or the
/// defaults. ``run`` releases the GIL while the pipeline runs, so that
/// other threads go on; an extractor may be shared by several threads, and
/// runs their calls one after the other (one extractor per thread runs
/// them side by side).
#[pyclass(frozen, module = "lms_features")]
pub struct Extractor {
    params: Params,
    work: Mutex<Box<Work>>,
}

/// What a run gives, before it becomes Python objects (built without the GIL).
struct Packed {
    lines: Vec<u8>,
    corners: Vec<u8>,
    segments: Vec<u8>,
    edges: Vec<u16>,
    stats: Stats,
    smoothed: Vec<f32>,
    mahalanobis: Vec<f32>,
}

impl Extractor {
    /// Run on `frame` and pack the results (no Python object touched).
    fn run_packed(&self, frame: &CoreFrame) -> Packed {
        let valid = self.params.valid();
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let Work { ex, trace } = &mut **guard;
        ex.run_traced(frame, &valid, trace);
        let f = ex.features();
        let lines = LINES.pack(f.lines(), |l| {
            let [[x0, y0], [x1, y1]] = l.endpoints;
            let [[aa, ar], [_, rr]] = l.cov.to_array();
            [
                Cell::F(l.alpha),
                Cell::F(l.r),
                Cell::F(aa),
                Cell::F(ar),
                Cell::F(rr),
                Cell::U(l.first),
                Cell::U(l.last),
                Cell::U(l.points),
                Cell::F(l.chi2),
                Cell::F(x0),
                Cell::F(y0),
                Cell::F(x1),
                Cell::F(y1),
            ]
        });
        let corners = CORNERS.pack(f.corners(), |c| {
            let [[xx, xy], [_, yy]] = c.cov.to_array();
            [
                Cell::F(c.x),
                Cell::F(c.y),
                Cell::F(xx),
                Cell::F(xy),
                Cell::F(yy),
                Cell::F(c.angle_deg),
                Cell::B(c.well_conditioned),
                Cell::U(c.line_a.into()),
                Cell::U(c.line_b.into()),
            ]
        });
        let segments = SEGMENTS.pack(f.segments(), |s| [Cell::U(s.first), Cell::U(s.last)]);
        let beams = frame.beams();
        let smoothed = ex.smoothed().iter().zip(beams);
        Packed {
            lines,
            corners,
            segments,
            edges: f.edges().iter().collect(),
            stats: *f.stats(),
            smoothed: smoothed
                .map(|(&r, b)| if b.is_valid() { r } else { f32::NAN })
                .collect(),
            mahalanobis: trace.mahalanobis().to_vec(),
        }
    }
}

#[pymethods]
impl Extractor {
    #[new]
    #[pyo3(signature = (params = None))]
    fn new(params: Option<Params>) -> Self {
        Extractor {
            params: params.unwrap_or_default(),
            work: Mutex::new(Box::new(Work {
                ex: CoreExtractor::new(),
                trace: Trace::new(),
            })),
        }
    }

    /// The parameters it runs with.
    #[getter]
    fn params(&self) -> Params {
        self.params.clone()
    }

    /// Features of one scan.
    ///
    /// ``ranges``: metres, a one-dimensional numpy array of ``float32`` or
    /// ``float64`` (read in place) or a list of numbers, one per beam from
    /// the right (−fov/2) counter-clockwise; ``0`` or ``+inf`` for a beam
    /// without a range. ``resolution_deg`` and ``fov_deg`` name the LMS
    /// variant: 180° at 1° or 0.5°, 100° at 1°, 0.5° or 0.25° (a 180° scan
    /// may lack its last beam, as in CARMEN logs). ``ranges`` may also be a
    /// ``Frame`` of ``read_log``, run as read (the other arguments are then
    /// ignored).
    ///
    /// Raises ``ValueError`` for NaN or a negative range (naming the beam),
    /// a length that does not fit the variant, or a variant the LMS does not
    /// have; ``TypeError`` for another dtype or a value that is not a number.
    #[pyo3(signature = (ranges, resolution_deg = 0.5, fov_deg = 180.0))]
    fn run(
        &self,
        py: Python<'_>,
        ranges: &Bound<'_, PyAny>,
        resolution_deg: f64,
        fov_deg: f64,
    ) -> PyResult<Features> {
        let frame = match ranges.cast::<Frame>() {
            Ok(f) => f.get().frame.clone(),
            Err(_) => frame_of(ranges, variant_of(resolution_deg, fov_deg)?)?,
        };
        let packed = py.detach(|| self.run_packed(&frame));
        Features::new(py, packed)
    }

    fn __repr__(&self) -> String {
        format!("Extractor(params={})", self.params.__repr__())
    }
}

/// The features of one scan, as ``Extractor.run`` gives them.
///
/// ``lines``, ``corners`` and ``segments`` are numpy structured arrays
/// (``LINE_DTYPE``, ``CORNER_DTYPE``, ``SEGMENT_DTYPE``) in scan order;
/// reals are the pipeline's ``float32`` values.
#[pyclass(frozen, module = "lms_features")]
pub struct Features {
    /// Accepted lines (``LINE_DTYPE``): ``x·cos(alpha) + y·sin(alpha) = r``.
    #[pyo3(get)]
    lines: Py<PyAny>,
    /// Corners between consecutive lines (``CORNER_DTYPE``).
    #[pyo3(get)]
    corners: Py<PyAny>,
    /// Segments (``SEGMENT_DTYPE``): runs of beams ``first..=last``.
    #[pyo3(get)]
    segments: Py<PyAny>,
    /// Edge points (beam indices, ``uint16``), ascending.
    #[pyo3(get)]
    edges: Py<PyArray1<u16>>,
    /// What the run dropped or rejected: ``{name: count}`` in ``STATS`` order.
    #[pyo3(get)]
    stats: Py<PyDict>,
    /// Smoothed ranges after the last pass (m, ``float32``), NaN where the beam has no range.
    #[pyo3(get)]
    smoothed: Py<PyArray1<f32>>,
    /// ``D`` of the last pass per window of beams ``i..=i+2`` (``n − 2`` values), ``+inf`` where invalid.
    #[pyo3(get)]
    mahalanobis: Py<PyArray1<f32>>,
}

impl Features {
    fn new(py: Python<'_>, p: Packed) -> PyResult<Features> {
        let stats = PyDict::new(py);
        for (name, read) in Stats::FIELDS {
            stats.set_item(name, read(&p.stats))?;
        }
        Ok(Features {
            lines: LINES.array(py, &p.lines)?.unbind(),
            corners: CORNERS.array(py, &p.corners)?.unbind(),
            segments: SEGMENTS.array(py, &p.segments)?.unbind(),
            edges: PyArray1::from_vec(py, p.edges).unbind(),
            stats: stats.unbind(),
            smoothed: PyArray1::from_vec(py, p.smoothed).unbind(),
            mahalanobis: PyArray1::from_vec(py, p.mahalanobis).unbind(),
        })
    }
}

#[pymethods]
impl Features {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let len = |o: &Py<PyAny>| o.bind(py).len();
        Ok(format!(
            "Features(lines={}, corners={}, segments={}, edges={})",
            len(&self.lines)?,
            len(&self.corners)?,
            len(&self.segments)?,
            self.edges.bind(py).len()?
        ))
    }
}
