//! `Params`: the pipeline's parameters, every one by the name of its field
//! (`lms_core::params::FIELDS`, the one table of names, units and
//! meanings), set through `Params::set` as `--set NAME=VALUE` sets them and
//! checked by `Params::validate`.

use std::path::{Path, PathBuf};

use host_bridge::options::{ParamArgs, Setting, UnitArg};
use lms_core::params::{self as core_params, Value, FIELDS, PRESETS};
use lms_core::{Params as CoreParams, ValidParams};
use pyo3::exceptions::{PyAttributeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};

use crate::convert::{host_error, warn};

/// Parameters of the pipeline: a preset and any parameter by name.
///
/// ``Params(preset="default", **settings)``: the preset's values
/// (``"default"``, ``"v3.2"``, ``"v3.1"``, ``"v3.0"``, ``"v2"`` or ``"paper"``, as ``host-bridge --preset``),
/// then each setting, by the parameter's name (``PARAMETERS`` lists every
/// one with its unit and meaning). A value is a number (``float("inf")``
/// where the parameter allows it), a whole number, a bool, or text as
/// ``--set NAME=VALUE`` takes it. Every parameter reads as an attribute
/// (``p.sigma``); reals read as the shortest decimal of their ``float32``.
/// Immutable and hashable: ``replace(**settings)`` gives a changed copy.
///
/// Raises ``ValueError`` naming the parameter for an unknown name, a value
/// of the wrong kind or out of range, and for an unknown preset.
#[pyclass(frozen, eq, hash, from_py_object, module = "lms_features")]
#[derive(Clone, Debug)]
pub struct Params {
    valid: ValidParams,
}

impl PartialEq for Params {
    /// Equal when every field has the same bits.
    fn eq(&self, other: &Self) -> bool {
        self.bits() == other.bits()
    }
}

impl std::hash::Hash for Params {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.bits().hash(state);
    }
}

impl Default for Params {
    /// The defaults (preset `default`).
    fn default() -> Self {
        Params {
            valid: ValidParams::DEFAULT,
        }
    }
}

impl Params {
    /// Validated parameters.
    pub fn from_core(params: CoreParams) -> PyResult<Self> {
        let valid = params
            .validate()
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Params { valid })
    }

    /// The validated parameters the pipeline runs with.
    pub fn valid(&self) -> ValidParams {
        self.valid
    }

    /// Every field's value as comparable bits.
    fn bits(&self) -> Vec<u32> {
        FIELDS
            .iter()
            .map(|f| match (f.get)(&self.valid) {
                Value::Real(x) => x.to_bits(),
                Value::Count(n) => n.into(),
                Value::Flag(b) => b.into(),
            })
            .collect()
    }
}

/// The parameter's name as the table spells it, or a `ValueError` naming it.
fn field_name(name: &str) -> PyResult<&'static str> {
    if let Some(f) = core_params::field(name) {
        return Ok(f.name);
    }
    let hint = core_params::field(&name.replace('-', "_"))
        .map(|f| format!("; did you mean {}?", f.name))
        .unwrap_or_default();
    Err(PyValueError::new_err(format!(
        "no parameter `{name}`{hint} (lms_features.PARAMETERS lists every one)"
    )))
}

/// A setting's Python value as the text `Params::set` reads (`--set`'s).
fn value_text(name: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(b.is_true().to_string());
    }
    if let Ok(s) = value.cast::<PyString>() {
        return s.extract::<String>();
    }
    if value.is_instance_of::<PyInt>() || value.hasattr("__index__")? {
        return value.call_method0("__index__")?.str()?.extract::<String>();
    }
    if value.is_instance_of::<PyFloat>() || value.hasattr("__float__")? {
        // The shortest decimal of the double: `sigma=0.01` reads as
        // `--set sigma=0.01` does (the decimal rounded once, to f32).
        let x: f64 = value.extract()?;
        return Ok(x.to_string());
    }
    Err(PyTypeError::new_err(format!(
        "{name}: a number, a bool or text, not {}",
        value.get_type().name()?
    )))
}

/// `params` with each setting of `settings` applied (not validated).
fn apply(mut params: CoreParams, settings: Option<&Bound<'_, PyDict>>) -> PyResult<CoreParams> {
    for (key, value) in settings.into_iter().flatten() {
        let key: String = key.extract()?;
        let name = field_name(&key)?;
        let text = value_text(name, &value)?;
        params
            .set(name, &text)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
    }
    Ok(params)
}

/// The preset named `name`, or a `ValueError` listing them.
fn preset(name: &str) -> PyResult<CoreParams> {
    core_params::preset(name).map(|p| p.params).ok_or_else(|| {
        let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
        PyValueError::new_err(format!(
            "no preset `{name}`: give one of {}",
            names.join(", ")
        ))
    })
}

/// A parameter's value as a Python object: reals as the shortest decimal
/// of the `f32` (what `--set` and `host-bridge params` print).
fn value_object<'py>(py: Python<'py>, value: Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Real(x) => PyFloat::new(py, f64_as_printed(x)).into_any(),
        Value::Count(n) => n.into_pyobject(py)?.into_any(),
        Value::Flag(b) => PyBool::new(py, b).to_owned().into_any(),
    })
}

/// The double nearest the shortest decimal of `x` (as `json.loads` reads
/// the number `host-bridge` prints for it).
pub fn f64_as_printed(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// The unit argument of the functions that read logs.
pub fn unit_arg(unit: &str) -> PyResult<UnitArg> {
    match unit {
        "auto" => Ok(UnitArg::Auto),
        "cm" => Ok(UnitArg::Cm),
        "mm" => Ok(UnitArg::Mm),
        other => Err(PyValueError::new_err(format!(
            "unit `{other}`: give \"auto\", \"cm\" or \"mm\""
        ))),
    }
}

/// The parameters `host-bridge extract PATH --preset P --set …` uses: the
/// data's σ and max_range under the preset (or the defaults), then the
/// settings. A warning for fill values caught by max_range goes through
/// Python's `warnings`.
pub fn for_log(
    py: Python<'_>,
    path: &Path,
    unit: UnitArg,
    preset_name: Option<&str>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<Params> {
    if let Some(name) = preset_name {
        preset(name)?;
    }
    let mut set = Vec::new();
    for (key, value) in settings.into_iter().flatten() {
        let name = field_name(&key.extract::<String>()?)?;
        let text = value_text(name, &value)?;
        let mut check = CoreParams::DEFAULT;
        check
            .set(name, &text)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        set.push(Setting { name, value: text });
    }
    let args = ParamArgs {
        preset: preset_name.map(str::to_string),
        set,
        ..ParamArgs::default()
    };
    let found = host_bridge::defaults::for_log(path, unit, &args).map_err(host_error)?;
    let params = match found {
        Some((params, warning)) => {
            if let Some(w) = warning {
                warn(py, w.strip_prefix("warning: ").unwrap_or(&w))?;
            }
            params
        }
        None => args.to_params().map_err(host_error)?,
    };
    Params::from_core(params)
}

#[pymethods]
impl Params {
    #[new]
    #[pyo3(signature = (preset = "default", **settings))]
    fn new(preset: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Params::from_core(apply(self::preset(preset)?, settings)?)
    }

    /// The parameters ``host-bridge extract PATH`` uses for the log at
    /// ``path``: σ and max_range from its data (its unit and quantisation
    /// step, under ``preset`` too), then ``settings``, as ``--preset`` and
    /// ``--set`` give them. A capture's parameters are the preset's.
    /// ``unit`` is the unit of the log's error codes: ``"auto"``, ``"cm"``
    /// or ``"mm"`` (``--unit``).
    #[staticmethod]
    #[pyo3(signature = (path, preset = None, unit = "auto", **settings))]
    fn for_log(
        py: Python<'_>,
        path: PathBuf,
        preset: Option<&str>,
        unit: &str,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Params> {
        for_log(py, &path, unit_arg(unit)?, preset, settings)
    }

    /// A copy with ``settings`` applied (checked as by the constructor).
    #[pyo3(signature = (**settings))]
    fn replace(&self, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Params> {
        Params::from_core(apply(*self.valid, settings)?)
    }

    /// Every parameter by name, in ``PARAMETERS`` order.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for f in FIELDS {
            d.set_item(f.name, value_object(py, (f.get)(&self.valid))?)?;
        }
        Ok(d)
    }

    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        match self.valid.get().get(name) {
            Some(v) => value_object(py, v),
            None => Err(PyAttributeError::new_err(format!(
                "Params has no parameter `{name}` (lms_features.PARAMETERS lists every one)"
            ))),
        }
    }

    fn __setattr__(&self, name: &str, _value: &Bound<'_, PyAny>) -> PyResult<()> {
        Err(PyAttributeError::new_err(format!(
            "Params are immutable: use params.replace({name}=...)"
        )))
    }

    fn __dir__(&self) -> Vec<&'static str> {
        let methods = ["for_log", "replace", "to_dict"];
        methods
            .into_iter()
            .chain(FIELDS.iter().map(|f| f.name))
            .collect()
    }

    /// ``Params(...)``: the nearest preset and the parameters that differ from it.
    pub fn __repr__(&self) -> String {
        let differ = |base: &CoreParams| -> Vec<&'static core_params::Field> {
            let changed = |f: &&core_params::Field| (f.get)(&self.valid) != (f.get)(base);
            FIELDS.iter().filter(changed).collect()
        };
        let nearest = PRESETS
            .iter()
            .min_by_key(|p| differ(&p.params).len())
            .unwrap_or(&PRESETS[0]);
        let mut args: Vec<String> = Vec::new();
        if nearest.name != "default" {
            args.push(format!("preset='{}'", nearest.name));
        }
        for f in differ(&nearest.params) {
            let text = match (f.get)(&self.valid) {
                Value::Real(x) if x.is_infinite() => format!("float('{x}')"),
                Value::Real(x) => format!("{:?}", f64_as_printed(x)),
                Value::Count(n) => n.to_string(),
                Value::Flag(b) => if b { "True" } else { "False" }.to_string(),
            };
            args.push(format!("{}={text}", f.name));
        }
        format!("Params({})", args.join(", "))
    }

    /// Pickled as the constructor's call with every parameter.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (&'static str,))> {
        let py = slf.py();
        let state = slf.get().to_dict(py)?;
        let rebuild = py
            .import("functools")?
            .getattr("partial")?
            .call((slf.get_type(),), Some(&state))?;
        Ok((rebuild, ("default",)))
    }
}
