//! `lms_features._native`: the Python extension module of `lms-core`, which
//! the package `lms_features` re-exports (python/pysrc/lms_features/__init__.py).
//!
//! * [`params`] — `Params`: the pipeline's parameters by the names of
//!   `lms_core::params::FIELDS`, the presets of `--preset`.
//! * [`scan`] — `Frame` (one scan of a file) and turning a numpy array or a
//!   list of ranges into a core `Frame`, with the errors that name a beam.
//! * [`extractor`] — `Extractor.run` and its `Features` (numpy structured
//!   arrays), the GIL released while the pipeline runs.
//! * [`logs`] — `read_log` and `extract_log`, through `host_bridge::input`
//!   and `host_bridge::extract`, so that a file reads as `host-bridge
//!   extract` reads it and a frame's dict is its JSON object.
//! * [`stream`] — a file's scans read in a thread of their own, so that the
//!   iterators work from any thread and wait without the GIL.
//! * [`convert`] — the values shared by the others: structured arrays, JSON
//!   text to Python objects, errors and warnings.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

mod convert;
mod extractor;
mod logs;
mod params;
mod scan;
mod stream;

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<params::Params>()?;
    m.add_class::<scan::Frame>()?;
    m.add_class::<extractor::Extractor>()?;
    m.add_class::<extractor::Features>()?;
    m.add_class::<logs::LogReader>()?;
    m.add_class::<logs::LogExtraction>()?;
    m.add_function(wrap_pyfunction!(logs::read_log, m)?)?;
    m.add_function(wrap_pyfunction!(logs::extract_log, m)?)?;
    m.add("PARAMETERS", parameters(py)?)?;
    m.add("PRESETS", presets(py)?)?;
    m.add("STATS", stats(py)?)?;
    m.add("LINE_DTYPE", convert::LINES.dtype(py)?)?;
    m.add("CORNER_DTYPE", convert::CORNERS.dtype(py)?)?;
    m.add("SEGMENT_DTYPE", convert::SEGMENTS.dtype(py)?)?;
    Ok(())
}

/// `(name, unit, meaning)` of every parameter, in `FIELDS` order.
fn parameters(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
    let rows = lms_core::params::FIELDS
        .iter()
        .map(|f| (f.name, f.unit, f.meaning));
    PyTuple::new(py, rows)
}

/// Preset name → its one-line summary.
fn presets(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for p in &lms_core::params::PRESETS {
        d.set_item(p.name, p.summary)?;
    }
    Ok(d)
}

/// `(name, meaning)` of every counter of a frame's stats.
fn stats(py: Python<'_>) -> PyResult<Bound<'_, PyTuple>> {
    PyTuple::new(py, lms_core::Stats::MEANINGS)
}
