//! `read_log` and `extract_log`: the scans of a file as `host-bridge`
//! reads them (`host_bridge::input`: CARMEN logs, gzip or plain, and
//! captures of `host-bridge scan`), and each frame's record as `host-bridge
//! extract` writes it (`host_bridge::extract::FrameRecord`), both read in a
//! thread of their own ([`Stream`]).

use std::path::PathBuf;

use host_bridge::extract::FrameRecord;
use host_bridge::input::InputScan;
use lms_core::{Extractor as CoreExtractor, Trace};
use pyo3::prelude::*;

use crate::convert::json_to_py;
use crate::params::{self, Params};
use crate::scan::Frame;
use crate::stream::Stream;

/// A scan as a `Frame` (its variant from its beam count, as the CARMEN
/// reader and the capture decoder chose its geometry).
fn frame_of(scan: InputScan) -> anyhow::Result<Frame> {
    let n = scan.frame.len();
    let variant = lms_core::carmen::variant_for_beams(n)
        .ok_or_else(|| anyhow::anyhow!("scan {}: {n} beams", scan.index))?;
    Ok(Frame {
        index: scan.index,
        frame: scan.frame,
        variant,
        pose: scan.pose,
        line: scan.line,
        time_us: scan.time_us,
    })
}

/// The scans of a CARMEN log (gzip or plain) or a capture of
/// ``host-bridge scan``, one ``Frame`` at a time (see ``read_log``). Read
/// ahead in a thread of its own; usable from any thread.
#[pyclass(frozen, module = "lms_features")]
pub struct LogReader {
    scans: Stream<Frame>,
}

#[pymethods]
impl LogReader {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<Frame>> {
        self.scans.next(py)
    }

    /// The file and what it is, e.g. ``"…/csail.log.gz (CARMEN log, cm ranges …)"``.
    #[getter]
    fn source(&self) -> &str {
        self.scans.source()
    }

    fn __repr__(&self) -> String {
        format!("<LogReader {}>", self.scans.source())
    }
}

/// Read the scans of ``path``: a CARMEN log (gzip or plain) or a capture
/// recorded by ``host-bridge scan``, streamed, as ``host-bridge`` reads it.
///
/// ``unit`` is the unit of a log's LMS error codes: ``"auto"`` (decided
/// from the log), ``"cm"`` or ``"mm"`` (``--unit``). Yields a ``Frame`` per
/// scan. Raises ``FileNotFoundError``/``OSError`` for a file that cannot
/// be read, ``ValueError`` for a damaged scan (after the scans before it)
/// or a file without scans; a file cut short ends with a ``UserWarning``.
#[pyfunction]
#[pyo3(signature = (path, unit = "auto"))]
pub fn read_log(path: PathBuf, unit: &str) -> PyResult<LogReader> {
    Ok(LogReader {
        scans: Stream::open(path, params::unit_arg(unit)?, frame_of)?,
    })
}

/// Each frame's record, as ``host-bridge extract`` writes it (see
/// ``extract_log``). Extracted ahead in a thread of its own; usable from
/// any thread.
#[pyclass(frozen, module = "lms_features")]
pub struct LogExtraction {
    records: Stream<Vec<u8>>,
    params: Params,
}

#[pymethods]
impl LogExtraction {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        match self.records.next(py)? {
            Some(json) => json_to_py(py, &json).map(Some),
            None => Ok(None),
        }
    }

    /// The parameters the frames are extracted with.
    #[getter]
    fn params(&self) -> Params {
        self.params.clone()
    }

    /// The file and what it is, e.g. ``"…/csail.log.gz (CARMEN log, cm ranges …)"``.
    #[getter]
    fn source(&self) -> &str {
        self.records.source()
    }

    fn __repr__(&self) -> String {
        format!("<LogExtraction {}>", self.records.source())
    }
}

/// Extract the features of every scan of ``path`` (a CARMEN log or a
/// capture, as ``read_log`` reads it) and yield, per frame, a dict with
/// exactly the keys and values of the JSON object that ``host-bridge
/// extract PATH`` writes for it: ``frame``, ``n``, ``ranges``,
/// ``smoothed``, ``mahalanobis``, ``edges``, ``segments``, ``lines``,
/// ``corners``, ``stats`` and (for a log) ``pose``; ``None`` where the JSON
/// has ``null``. A real is the ``float32`` value as ``extract`` prints it
/// (its shortest decimal), read as a Python float, as ``json.loads`` reads
/// it: ``numpy.float32(value)`` is the pipeline's value exactly.
///
/// ``params=None``: the parameters ``extract`` takes for the file (a log's
/// σ and max_range from its data, ``Params.for_log``); a ``Params`` is used
/// as it is. The iterator's ``params`` tells which. ``unit`` as for
/// ``read_log``. The pipeline runs in a thread of its own, a few frames
/// ahead, without the GIL.
#[pyfunction]
#[pyo3(signature = (path, params = None, unit = "auto"))]
pub fn extract_log(
    py: Python<'_>,
    path: PathBuf,
    params: Option<Params>,
    unit: &str,
) -> PyResult<LogExtraction> {
    let unit = params::unit_arg(unit)?;
    let params = match params {
        Some(p) => p,
        None => params::for_log(py, &path, unit, None, None)?,
    };
    let valid = params.valid();
    let mut ex = Box::new(CoreExtractor::new());
    let mut trace = Box::new(Trace::new());
    // As `host_bridge::extract::extract_named` builds each line.
    let record = move |scan: InputScan| -> anyhow::Result<Vec<u8>> {
        ex.run_traced(&scan.frame, &valid, &mut trace);
        let mut record = FrameRecord::from_run(scan.index, &scan.frame, &ex, &trace);
        record.pose = scan.pose;
        Ok(serde_json::to_vec(&record)?)
    };
    Ok(LogExtraction {
        records: Stream::open(path, unit, record)?,
        params,
    })
}
