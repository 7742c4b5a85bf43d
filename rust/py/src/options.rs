//! Keyword options parsed once, at the boundary, from Python values straight into the
//! core's types; anything else is a `tetlap.errors.OptionError` naming the value.

use crate::errors::option_error;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyString};
use pyo3::Borrowed;
use tetlap::{Boundary, Degenerate, LaplacianKind, MassKind};

/// `repr(obj)` for messages.
fn repr(obj: Borrowed<'_, '_, PyAny>) -> String {
    obj.repr().map_or_else(|_| "<unprintable>".into(), |r| r.to_string())
}

/// The string `obj`, if it is one.
fn string(obj: Borrowed<'_, '_, PyAny>) -> Option<String> {
    obj.cast::<PyString>().ok().and_then(|s| s.to_str().ok().map(str::to_owned))
}

/// A Laplacian kind: `"primal"`, `"dual"` or a real `t` in `[0, 1]` (not a bool).
pub struct Kind(pub LaplacianKind);

impl<'a, 'py> FromPyObject<'a, 'py> for Kind {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let bad = || {
            option_error(py, format!("kind must be \"primal\", \"dual\" or a float t in [0, 1], got {}", repr(obj)))
        };
        if let Some(name) = string(obj) {
            return match name.as_str() {
                "primal" => Ok(Kind(LaplacianKind::Primal)),
                "dual" => Ok(Kind(LaplacianKind::Dual)),
                _ => Err(bad()),
            };
        }
        if obj.is_instance_of::<PyBool>() {
            return Err(bad());
        }
        let t: f64 = obj.extract().map_err(|_| bad())?;
        if !(0.0..=1.0).contains(&t) {
            return Err(option_error(py, format!("the affine parameter t must lie in [0, 1], got {}", repr(obj))));
        }
        Ok(Kind(LaplacianKind::Affine(t)))
    }
}

/// Parses one of a fixed set of names.
fn named<T: Copy>(obj: Borrowed<'_, '_, PyAny>, what: &str, choices: &[(&str, T)]) -> PyResult<T> {
    if let Some(name) = string(obj) {
        if let Some(&(_, value)) = choices.iter().find(|(n, _)| *n == name) {
            return Ok(value);
        }
    }
    let names: Vec<String> = choices.iter().map(|(n, _)| format!("\"{n}\"")).collect();
    let listed = match names.as_slice() {
        [init @ .., last] if !init.is_empty() => format!("{} or {last}", init.join(", ")),
        _ => names.join(""),
    };
    Err(option_error(obj.py(), format!("{what} must be {listed}, got {}", repr(obj))))
}

/// A mass kind: `"barycentric"`, `"circumcentric"` or `"fem"`.
pub struct MassArg(pub MassKind);

impl<'a, 'py> FromPyObject<'a, 'py> for MassArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let choices = [
            ("barycentric", MassKind::Barycentric),
            ("circumcentric", MassKind::Circumcentric),
            ("fem", MassKind::Fem),
        ];
        named(obj, "mass kind", &choices).map(MassArg)
    }
}

/// `degenerate="raise" | "skip"`.
pub struct DegenerateArg(pub Degenerate);

impl<'a, 'py> FromPyObject<'a, 'py> for DegenerateArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        named(obj, "degenerate", &[("raise", Degenerate::Raise), ("skip", Degenerate::Skip)]).map(DegenerateArg)
    }
}

impl Default for DegenerateArg {
    fn default() -> Self {
        DegenerateArg(Degenerate::Raise)
    }
}

/// `boundary="circumcentric" | "barycentric"`.
pub struct BoundaryArg(pub Boundary);

impl<'a, 'py> FromPyObject<'a, 'py> for BoundaryArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let choices = [("circumcentric", Boundary::Circumcentric), ("barycentric", Boundary::Barycentric)];
        named(obj, "boundary", &choices).map(BoundaryArg)
    }
}

impl Default for BoundaryArg {
    fn default() -> Self {
        BoundaryArg(Boundary::Circumcentric)
    }
}

/// `threads=None` (all cores) or an integer from 1 to `tetlap::max_threads()` (not a bool).
#[derive(Default)]
pub struct Threads(pub Option<usize>);

impl<'a, 'py> FromPyObject<'a, 'py> for Threads {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if obj.is_none() {
            return Ok(Threads(None));
        }
        let max = tetlap::max_threads();
        let bad = || {
            option_error(obj.py(), format!("threads must be None or an integer from 1 to {max}, got {}", repr(obj)))
        };
        if obj.is_instance_of::<PyBool>() {
            return Err(bad());
        }
        match obj.extract::<i64>() {
            Ok(k) if (1..=max as i64).contains(&k) => Ok(Threads(Some(k as usize))),
            _ => Err(bad()),
        }
    }
}
