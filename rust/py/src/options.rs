//! Keyword options parsed once, at the boundary, from Python values straight into the
//! core's types; anything else is a `tetlap.errors.OptionError` naming the value. Ranges
//! (the thread count, the affine parameter) are checked by the core, once.

use crate::errors::option_error;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyString, PyTuple};
use pyo3::Borrowed;
use tetlap::{Boundary, Cancel, Degenerate, LaplacianKind, MassKind, Options};

/// `repr(obj)` for messages.
fn repr(obj: Borrowed<'_, '_, PyAny>) -> String {
    obj.repr().map_or_else(|_| "<unprintable>".into(), |r| r.to_string())
}

/// The string `obj`, if it is one.
fn string(obj: Borrowed<'_, '_, PyAny>) -> Option<String> {
    obj.cast::<PyString>().ok().and_then(|s| s.to_str().ok().map(str::to_owned))
}

/// A Laplacian kind: `"primal"`, `"dual"` or a real `t` (not a bool; the core checks that
/// it lies in `[0, 1]`).
pub struct Kind(pub LaplacianKind);

impl<'a, 'py> FromPyObject<'a, 'py> for Kind {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let bad = || {
            // the value's role, not a keyword: callers name it kind=, laplacian=, ...
            let message = format!("Laplacian kind must be \"primal\", \"dual\" or a float t in [0, 1], got {}", repr(obj));
            option_error(obj.py(), message)
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
        obj.extract::<f64>().map(|t| Kind(LaplacianKind::Affine(t))).map_err(|_| bad())
    }
}

/// One of a fixed set of names.
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

/// A mass kind: `"barycentric"`, `"circumcentric"`, `"mixed"` or `"fem"`.
pub struct MassArg(pub MassKind);

impl<'a, 'py> FromPyObject<'a, 'py> for MassArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let choices = [
            ("barycentric", MassKind::Barycentric),
            ("circumcentric", MassKind::Circumcentric),
            ("mixed", MassKind::Mixed),
            ("fem", MassKind::Fem),
        ];
        named(obj, "mass kind", &choices).map(MassArg)
    }
}

/// The options of every call, as the Python layer hands them over: a dict with any of
/// `"boundary"` (`"circumcentric" | "barycentric"`), `"degenerate"` (`"raise" | "skip"`)
/// and `"threads"` (None or a positive integer); `None` or a missing key is the default.
/// The one place where the core's [`Options`] are built (each with a fresh cancel flag).
#[derive(Default)]
pub struct OptionsArg(pub Options);

impl OptionsArg {
    /// The core's options of a call: those given, or the defaults.
    pub fn options(given: Option<OptionsArg>) -> Options {
        given.unwrap_or_default().0
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for OptionsArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let mut opts = Options { cancel: Some(Cancel::new()), ..Options::default() };
        if obj.is_none() {
            return Ok(OptionsArg(opts));
        }
        let dict = obj.cast::<PyDict>().map_err(|_| option_error(obj.py(), "internal: options must be a dict".into()))?;
        for (key, value) in dict.iter() {
            let value = value.as_borrowed();
            match string(key.as_borrowed()).as_deref() {
                Some("boundary") => {
                    let choices = [("circumcentric", Boundary::Circumcentric), ("barycentric", Boundary::Barycentric)];
                    opts.boundary = named(value, "boundary_centres", &choices)?;
                }
                Some("degenerate") => {
                    opts.degenerate = named(value, "degenerate", &[("raise", Degenerate::Raise), ("skip", Degenerate::Skip)])?;
                }
                Some("threads") => opts.threads = threads(value)?,
                _ => return Err(option_error(obj.py(), format!("internal: unknown option {}", repr(key.as_borrowed())))),
            }
        }
        Ok(OptionsArg(opts))
    }
}

/// `None` (all cores) or a non-negative integer, not a bool (the core checks the range).
fn threads(obj: Borrowed<'_, '_, PyAny>) -> PyResult<Option<usize>> {
    if obj.is_none() {
        return Ok(None);
    }
    let bad = || {
        let max = tetlap::max_threads();
        option_error(obj.py(), format!("threads must be None or an integer from 1 to {max}, got {}", repr(obj)))
    };
    if obj.is_instance_of::<PyBool>() {
        return Err(bad());
    }
    obj.extract::<u64>().map(|k| Some(usize::try_from(k).unwrap_or(usize::MAX))).map_err(|_| bad())
}

/// What to compute in one pass of [`tetlap`]'s one-shot API, as a tuple:
/// `("laplacian", kind)`, `("mass", kind)`, `("operators", kind, mass_kind)`,
/// `("operators_skipping", kind, mass_kind)`, `("contributions", kind)`,
/// `("element_laplacians", kind)`, `("triplets", kind)` or `("edge_weights", kind)`.
pub enum Request {
    Laplacian(LaplacianKind),
    Mass(MassKind),
    Operators(LaplacianKind, MassKind),
    OperatorsSkipping(LaplacianKind, MassKind),
    Contributions(LaplacianKind),
    ElementLaplacians(LaplacianKind),
    Triplets(LaplacianKind),
    EdgeWeights(LaplacianKind),
}

impl<'a, 'py> FromPyObject<'a, 'py> for Request {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let bad = || option_error(obj.py(), format!("internal: not a request: {}", repr(obj)));
        let t = obj.cast::<PyTuple>().map_err(|_| bad())?;
        let name = t.get_item(0).ok().and_then(|n| string(n.as_borrowed())).ok_or_else(bad)?;
        let kind = || -> PyResult<LaplacianKind> { Ok(t.get_item(1)?.extract::<Kind>()?.0) };
        Ok(match (name.as_str(), t.len()) {
            ("laplacian", 2) => Request::Laplacian(kind()?),
            ("mass", 2) => Request::Mass(t.get_item(1)?.extract::<MassArg>()?.0),
            ("operators", 3) => Request::Operators(kind()?, t.get_item(2)?.extract::<MassArg>()?.0),
            ("operators_skipping", 3) => Request::OperatorsSkipping(kind()?, t.get_item(2)?.extract::<MassArg>()?.0),
            ("contributions", 2) => Request::Contributions(kind()?),
            ("element_laplacians", 2) => Request::ElementLaplacians(kind()?),
            ("triplets", 2) => Request::Triplets(kind()?),
            ("edge_weights", 2) => Request::EdgeWeights(kind()?),
            _ => return Err(bad()),
        })
    }
}
