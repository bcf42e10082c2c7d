//! One scan: `Frame` (a scan of a file, from `read_log`) and the ranges a
//! caller gives `Extractor.run` (a numpy array or a list) as a core frame,
//! with errors that name the beam.

use lms_core::{Beam, FovRes, Frame as CoreFrame, Variant};
use numpy::{PyArray1, PyReadonlyArray1, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

/// One scan of a log or a capture, as ``read_log`` yields it.
///
/// ``ranges`` are metres (``float32``) with ``+inf`` where the beam has no
/// range (an LMS error code or a zero reading; ``invalid`` says which). A
/// log's fill values stay as recorded, for ``max_range`` to catch.
/// ``Extractor.run(frame)`` runs the scan as it was read.
#[pyclass(frozen, module = "lms_features")]
pub struct Frame {
    pub index: usize,
    pub frame: CoreFrame,
    pub variant: Variant,
    pub pose: Option<[f64; 3]>,
    pub line: Option<usize>,
    pub time_us: Option<u64>,
}

/// The LMS variant of a field of view and resolution, or a `ValueError`.
pub fn variant_of(resolution_deg: f64, fov_deg: f64) -> PyResult<Variant> {
    let centideg = (resolution_deg * 100.0).round();
    let exact = (resolution_deg * 100.0 - centideg).abs() < 1e-6 && fov_deg.fract() == 0.0;
    let found = (exact && (1.0..=100.0).contains(&centideg) && (1.0..=180.0).contains(&fov_deg))
        .then(|| {
            Variant::from_fov_res(FovRes {
                fov_deg: fov_deg as u16,
                res_centideg: centideg as u16,
            })
        })
        .flatten();
    found.ok_or_else(|| {
        PyValueError::new_err(format!(
            "no LMS 2xx scan has a {fov_deg}° field at {resolution_deg}°: give fov_deg=180 with \
             resolution_deg=1 or 0.5, or fov_deg=100 with resolution_deg=1, 0.5 or 0.25"
        ))
    })
}

/// The beam counts a scan of `variant` may have: the sensor's, and for a
/// 180° field one fewer (CARMEN logs drop the last beam).
fn check_len(variant: Variant, n: usize) -> PyResult<()> {
    let full = variant.beams();
    let carmen = variant.fov_deg() == 180 && n + 1 == full;
    if n == full || carmen {
        return Ok(());
    }
    let also = if variant.fov_deg() == 180 {
        format!(" (or {}, as CARMEN logs record it)", full - 1)
    } else {
        String::new()
    };
    Err(PyValueError::new_err(format!(
        "ranges has {n} values: a {}°/{}° scan has {full}{also}",
        variant.fov_deg(),
        f64::from(variant.resolution_centideg()) / 100.0
    )))
}

/// Set beam `j` of `frame` from `x` metres: `0` and `+inf` make the beam
/// invalid (no range, no return); NaN and negative values are errors.
fn set_beam(frame: &mut CoreFrame, j: usize, x: f64) -> PyResult<()> {
    if x.is_nan() {
        return Err(PyValueError::new_err(format!(
            "ranges[{j}] is NaN: give +inf (no return) or 0 for a beam without a range"
        )));
    }
    if x < 0.0 {
        return Err(PyValueError::new_err(format!(
            "ranges[{j}] is {x}: ranges are metres, not negative \
             (+inf or 0 for a beam without a range)"
        )));
    }
    frame.set_metres(j, x as f32);
    Ok(())
}

/// A core frame of `variant` from `ranges`: a one-dimensional numpy array
/// of `float32` or `float64` (read in place, any strides), or a list or
/// tuple of numbers.
pub fn frame_of(ranges: &Bound<'_, PyAny>, variant: Variant) -> PyResult<CoreFrame> {
    if let Ok(array) = ranges.cast::<PyUntypedArray>() {
        return frame_of_array(array, variant);
    }
    if ranges.is_instance_of::<PyList>() || ranges.is_instance_of::<PyTuple>() {
        let n = ranges.len()?;
        check_len(variant, n)?;
        let mut frame = CoreFrame::new(variant.geometry(), n)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        for (j, item) in ranges.try_iter()?.enumerate() {
            let item = item?;
            let x: f64 = item.extract().map_err(|_| {
                let kind = item
                    .get_type()
                    .name()
                    .map_or_else(|_| "?".to_string(), |n| n.to_string());
                PyTypeError::new_err(format!("ranges[{j}] is a {kind}, not a number of metres"))
            })?;
            set_beam(&mut frame, j, x)?;
        }
        return Ok(frame);
    }
    Err(PyTypeError::new_err(format!(
        "ranges must be a numpy array (float32 or float64) or a list of numbers, not {}",
        ranges.get_type().name()?
    )))
}

fn frame_of_array(array: &Bound<'_, PyUntypedArray>, variant: Variant) -> PyResult<CoreFrame> {
    if array.ndim() != 1 {
        let shape: Vec<String> = array.shape().iter().map(usize::to_string).collect();
        return Err(PyValueError::new_err(format!(
            "ranges must be one-dimensional, not of shape ({})",
            shape.join(", ")
        )));
    }
    let n = array.len();
    check_len(variant, n)?;
    let mut frame =
        CoreFrame::new(variant.geometry(), n).map_err(|e| PyValueError::new_err(e.to_string()))?;
    if let Ok(a) = array.extract::<PyReadonlyArray1<'_, f32>>() {
        for (j, &x) in a.as_array().iter().enumerate() {
            set_beam(&mut frame, j, f64::from(x))?;
        }
    } else if let Ok(a) = array.extract::<PyReadonlyArray1<'_, f64>>() {
        for (j, &x) in a.as_array().iter().enumerate() {
            set_beam(&mut frame, j, x)?;
        }
    } else {
        return Err(PyTypeError::new_err(format!(
            "ranges must be float32 or float64, not {}",
            array.dtype().str()?
        )));
    }
    Ok(frame)
}

#[pymethods]
impl Frame {
    /// Index of the scan in its file (``FLASER`` lines or capture records), from 0.
    #[getter]
    fn index(&self) -> usize {
        self.index
    }

    /// Number of beams.
    #[getter]
    fn n(&self) -> usize {
        self.frame.len()
    }

    fn __len__(&self) -> usize {
        self.frame.len()
    }

    /// Ranges (m, ``float32``), ``+inf`` where the beam has no range.
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        let ranges = self.frame.ranges().iter().zip(self.frame.beams());
        let values = ranges.map(|(&r, b)| if b.is_valid() { r } else { f32::INFINITY });
        PyArray1::from_vec(py, values.collect())
    }

    /// ``True`` where the beam has a range.
    #[getter]
    fn valid<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let valid = self.frame.beams().iter().map(|b| b.is_valid());
        PyArray1::from_vec(py, valid.collect())
    }

    /// Why each beam without a range has none: ``{beam: reason}``.
    #[getter]
    fn invalid<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (j, b) in self.frame.beams().iter().enumerate() {
            if let Beam::Invalid(why) = b {
                d.set_item(j, why.to_string())?;
            }
        }
        Ok(d)
    }

    /// Bearing of every beam (rad, ``float32``): 0 straight ahead, counter-clockwise.
    #[getter]
    fn bearings<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        let g = self.frame.geometry();
        PyArray1::from_vec(py, (0..self.frame.len()).map(|j| g.bearing(j)).collect())
    }

    /// Angle between beams (degrees): 1, 0.5 or 0.25.
    #[getter]
    fn resolution_deg(&self) -> f64 {
        f64::from(self.variant.resolution_centideg()) / 100.0
    }

    /// Field of view (degrees): 180 or 100.
    #[getter]
    fn fov_deg(&self) -> u16 {
        self.variant.fov_deg()
    }

    /// Laser pose ``(x, y, θ)`` of a log's line (m, m, rad); ``None`` for a capture.
    #[getter]
    fn pose(&self) -> Option<(f64, f64, f64)> {
        self.pose.map(|[x, y, t]| (x, y, t))
    }

    /// Line of the log (from 1); ``None`` for a capture.
    #[getter]
    fn line(&self) -> Option<usize> {
        self.line
    }

    /// Time of a capture's record (µs from its start); ``None`` for a log.
    #[getter]
    fn time_us(&self) -> Option<u64> {
        self.time_us
    }

    fn __repr__(&self) -> String {
        format!(
            "Frame(index={}, n={}, {}°/{}°, {} valid)",
            self.index,
            self.frame.len(),
            self.variant.fov_deg(),
            self.resolution_deg(),
            self.frame.valid_count()
        )
    }
}
