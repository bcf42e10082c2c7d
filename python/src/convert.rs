//! Values shared by the classes: numpy structured arrays of features, the
//! JSON text of a frame record as Python objects, errors and warnings.

use std::ffi::CString;
use std::fmt;

use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyUserWarning,
    PyValueError,
};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyDict, PyList};
use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};

/// The type of one field of a structured array (little-endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `<f4`.
    F4,
    /// `<u2`.
    U2,
    /// `u1`.
    U1,
    /// `?` (one byte, 0 or 1).
    Bool,
}

impl Kind {
    const fn size(self) -> usize {
        match self {
            Kind::F4 => 4,
            Kind::U2 => 2,
            Kind::U1 | Kind::Bool => 1,
        }
    }

    const fn code(self) -> &'static str {
        match self {
            Kind::F4 => "<f4",
            Kind::U2 => "<u2",
            Kind::U1 => "u1",
            Kind::Bool => "?",
        }
    }
}

/// One value of a row.
#[derive(Clone, Copy, Debug)]
pub enum Cell {
    /// A real (written as `<f4`).
    F(f32),
    /// A whole number (`<u2`, or `u1` for a field of that kind).
    U(u16),
    /// A switch (`?`).
    B(bool),
}

/// The layout of a numpy structured array: named fields, each at its
/// natural alignment (as numpy's `align=True`), the item padded to the
/// largest field's alignment.
pub struct Layout {
    fields: &'static [(&'static str, Kind)],
    dtype: PyOnceLock<Py<PyAny>>,
}

/// A line: α, r, the covariance of (α, r), the beams, χ², the end points.
pub static LINES: Layout = Layout::new(&[
    ("alpha", Kind::F4),
    ("r", Kind::F4),
    ("cov_aa", Kind::F4),
    ("cov_ar", Kind::F4),
    ("cov_rr", Kind::F4),
    ("first", Kind::U2),
    ("last", Kind::U2),
    ("points", Kind::U2),
    ("chi2", Kind::F4),
    ("x0", Kind::F4),
    ("y0", Kind::F4),
    ("x1", Kind::F4),
    ("y1", Kind::F4),
]);

/// A corner: position, the covariance of (x, y), angle, the two lines.
pub static CORNERS: Layout = Layout::new(&[
    ("x", Kind::F4),
    ("y", Kind::F4),
    ("cov_xx", Kind::F4),
    ("cov_xy", Kind::F4),
    ("cov_yy", Kind::F4),
    ("angle_deg", Kind::F4),
    ("well_conditioned", Kind::Bool),
    ("line_a", Kind::U1),
    ("line_b", Kind::U1),
]);

/// A segment: its first and last beam (inclusive).
pub static SEGMENTS: Layout = Layout::new(&[("first", Kind::U2), ("last", Kind::U2)]);

impl Layout {
    const fn new(fields: &'static [(&'static str, Kind)]) -> Self {
        Layout {
            fields,
            dtype: PyOnceLock::new(),
        }
    }

    /// Byte offset of every field, and the item size.
    fn offsets(&self) -> (Vec<usize>, usize) {
        let mut offsets = Vec::with_capacity(self.fields.len());
        let (mut at, mut widest) = (0usize, 1usize);
        for (_, kind) in self.fields {
            let size = kind.size();
            at = at.next_multiple_of(size);
            offsets.push(at);
            at += size;
            widest = widest.max(size);
        }
        (offsets, at.next_multiple_of(widest))
    }

    /// The numpy dtype (built once).
    pub fn dtype<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let dtype = self.dtype.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
            let (offsets, itemsize) = self.offsets();
            let spec = PyDict::new(py);
            spec.set_item("names", self.fields.iter().map(|f| f.0).collect::<Vec<_>>())?;
            let formats: Vec<&str> = self.fields.iter().map(|f| f.1.code()).collect();
            spec.set_item("formats", formats)?;
            spec.set_item("offsets", offsets)?;
            spec.set_item("itemsize", itemsize)?;
            let numpy = py.import("numpy")?;
            Ok(numpy.getattr("dtype")?.call1((spec, true))?.unbind())
        })?;
        Ok(dtype.bind(py).clone())
    }

    /// The rows of `items` as the array's bytes (no GIL needed).
    pub fn pack<T, const N: usize>(&self, items: &[T], row: impl Fn(&T) -> [Cell; N]) -> Vec<u8> {
        debug_assert_eq!(N, self.fields.len());
        let (offsets, itemsize) = self.offsets();
        let mut bytes = vec![0u8; items.len() * itemsize];
        for (item, out) in items.iter().zip(bytes.chunks_exact_mut(itemsize)) {
            for ((cell, (_, kind)), &at) in row(item).iter().zip(self.fields).zip(&offsets) {
                let slot = &mut out[at..at + kind.size()];
                match (*cell, kind) {
                    (Cell::F(x), Kind::F4) => slot.copy_from_slice(&x.to_le_bytes()),
                    (Cell::U(n), Kind::U2) => slot.copy_from_slice(&n.to_le_bytes()),
                    (Cell::U(n), Kind::U1) => slot[0] = n.min(255) as u8,
                    (Cell::B(b), Kind::Bool) => slot[0] = u8::from(b),
                    (cell, kind) => unreachable!("{cell:?} in a {kind:?} field"),
                }
            }
        }
        bytes
    }

    /// A writable structured array of the packed rows `bytes`.
    pub fn array<'py>(&self, py: Python<'py>, bytes: &[u8]) -> PyResult<Bound<'py, PyAny>> {
        static FROMBUFFER: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
        let frombuffer = FROMBUFFER.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
            Ok(py.import("numpy")?.getattr("frombuffer")?.unbind())
        })?;
        let buffer = PyByteArray::new(py, bytes);
        frombuffer.bind(py).call1((buffer, self.dtype(py)?))
    }
}

/// Builds Python objects from JSON text as `json.loads` does: objects are
/// dicts in the text's key order, arrays lists, a number without a fraction
/// or exponent an int, any other a float (the nearest double, as
/// `serde_json` with `float_roundtrip` and Python's `float` both parse).
pub struct ToPy<'py>(pub Python<'py>);

/// A Python error while building the objects, carried through serde.
#[derive(Debug)]
pub struct BuildError(String);

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

fn built<'py, E: de::Error, F: Into<PyErr>>(
    r: Result<Bound<'py, PyAny>, F>,
) -> Result<Bound<'py, PyAny>, E> {
    r.map_err(|e| E::custom(BuildError(e.into().to_string())))
}

impl<'de, 'py> DeserializeSeed<'de> for ToPy<'py> {
    type Value = Bound<'py, PyAny>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, 'py> Visitor<'de> for ToPy<'py> {
    type Value = Bound<'py, PyAny>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any JSON value")
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Self::Value, E> {
        built(v.into_pyobject(self.0).map(|b| b.to_owned().into_any()))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        built(v.into_pyobject(self.0).map(Bound::into_any))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        built(v.into_pyobject(self.0).map(Bound::into_any))
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
        built(v.into_pyobject(self.0).map(Bound::into_any))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        built(v.into_pyobject(self.0).map(Bound::into_any))
    }

    fn visit_unit<E: de::Error>(self) -> Result<Self::Value, E> {
        Ok(self.0.None().into_bound(self.0))
    }

    fn visit_none<E: de::Error>(self) -> Result<Self::Value, E> {
        self.visit_unit()
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let list = PyList::empty(self.0);
        while let Some(item) = seq.next_element_seed(ToPy(self.0))? {
            list.append(item)
                .map_err(|e| de::Error::custom(e.to_string()))?;
        }
        Ok(list.into_any())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let dict = PyDict::new(self.0);
        while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
            let value = map.next_value_seed(ToPy(self.0))?;
            dict.set_item(key.as_ref(), value)
                .map_err(|e| de::Error::custom(e.to_string()))?;
        }
        Ok(dict.into_any())
    }
}

/// JSON text as Python objects ([`ToPy`]).
pub fn json_to_py<'py>(py: Python<'py>, text: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    let mut d = serde_json::Deserializer::from_slice(text);
    ToPy(py)
        .deserialize(&mut d)
        .map_err(|e| PyValueError::new_err(format!("cannot read a frame record: {e}")))
}

/// An error of the host library as a Python exception: a file that cannot
/// be opened or read is an `OSError` (`FileNotFoundError`, …), anything else
/// (a malformed log, parameters) a `ValueError`; the message is the whole
/// chain, as `host-bridge` prints it.
pub fn host_error(e: anyhow::Error) -> PyErr {
    let message = format!("{e:#}");
    let io = e.chain().find_map(|c| c.downcast_ref::<std::io::Error>());
    match io.map(std::io::Error::kind) {
        Some(std::io::ErrorKind::NotFound) => PyFileNotFoundError::new_err(message),
        Some(std::io::ErrorKind::PermissionDenied) => PyPermissionError::new_err(message),
        Some(std::io::ErrorKind::IsADirectory) => PyIsADirectoryError::new_err(message),
        Some(_) => PyOSError::new_err(message),
        None if message.contains(" is a directory") => PyIsADirectoryError::new_err(message),
        None => PyValueError::new_err(message),
    }
}

/// A `UserWarning` through Python's `warnings` (shown once per place by
/// default; `warnings.filterwarnings` controls it).
pub fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)
}
