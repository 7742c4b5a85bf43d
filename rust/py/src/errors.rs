//! Core errors and panics become the exception classes of `tetlap.errors`.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The `tetlap.errors` exception for a core error, with the offending element as attributes.
pub fn to_py(py: Python<'_>, e: tetlap::Error) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let class = py.import("tetlap.errors")?.getattr(e.kind())?;
        let kwargs = PyDict::new(py);
        use tetlap::Error::*;
        match &e {
            NonFiniteCoordinate { vertex, .. } | NonFiniteWeight { vertex, .. } => {
                kwargs.set_item("vertex", vertex)?
            }
            IndexOutOfRange { element, index, .. } => {
                kwargs.set_item("element", element)?;
                kwargs.set_item("index", index)?;
            }
            RepeatedVertex { element, vertex } => {
                kwargs.set_item("element", element)?;
                kwargs.set_item("vertex", vertex)?;
            }
            Degenerate { element } | NonFiniteResult { element } => {
                kwargs.set_item("element", element)?
            }
            _ => {}
        }
        Ok(PyErr::from_value(class.call((e.to_string(),), Some(&kwargs))?))
    };
    build().unwrap_or_else(|err| err)
}

/// Runs `f` without the GIL; a core error becomes its exception, a panic (an internal bug)
/// becomes `tetlap.errors.InternalError` instead of an uncatchable `PanicException`.
pub fn guarded<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> tetlap::Result<T> + Send,
) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py(py, e)),
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            let class = py.import("tetlap.errors")?.getattr("InternalError")?;
            Err(PyErr::from_value(class.call1((format!(
                "internal error in tetlap's core ({what}); please report it with the input"
            ),))?))
        }
    }
}
