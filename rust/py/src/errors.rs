//! Core errors and panics as the exception classes of `tetlap.errors`, worded in Python
//! terms; the long computations run on a worker thread so that Ctrl-C reaches them.

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyType};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc;
use std::time::Duration;
use tetlap::{Cancel, CoefficientProblem, Error, Feature};

/// The exception classes of `tetlap.errors`, imported once when `_core` is initialised.
struct Classes {
    shape: Py<PyType>,
    empty: Py<PyType>,
    index: Py<PyType>,
    non_finite: Py<PyType>,
    repeated: Py<PyType>,
    degenerate: Py<PyType>,
    option: Py<PyType>,
    internal: Py<PyType>,
    solve: Py<PyType>,
    coefficient: Py<PyType>,
}

static CLASSES: PyOnceLock<Classes> = PyOnceLock::new();

/// Imports `tetlap.errors` (called from the module's initialisation).
pub fn init(py: Python<'_>) -> PyResult<()> {
    let module = py.import("tetlap.errors")?;
    let class = |name: &str| -> PyResult<Py<PyType>> { Ok(module.getattr(name)?.cast_into::<PyType>()?.unbind()) };
    let classes = Classes {
        shape: class("ShapeError")?,
        empty: class("EmptyMeshError")?,
        index: class("IndexRangeError")?,
        non_finite: class("NonFiniteError")?,
        repeated: class("RepeatedVertexError")?,
        degenerate: class("DegenerateElementError")?,
        option: class("OptionError")?,
        internal: class("InternalError")?,
        solve: class("SolveError")?,
        coefficient: class("CoefficientError")?,
    };
    let _ = CLASSES.set(py, classes);
    Ok(())
}

fn classes(py: Python<'_>) -> &Classes {
    CLASSES.get(py).expect("tetlap.errors is imported when tetlap._core is initialised")
}

/// An instance of `class(message, **attributes)` as an error.
fn raise(py: Python<'_>, class: &Py<PyType>, message: String, attributes: &[(&str, i64)]) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let kwargs = PyDict::new(py);
        for (name, value) in attributes {
            kwargs.set_item(name, value)?;
        }
        Ok(PyErr::from_value(class.bind(py).call((message,), Some(&kwargs))?))
    };
    build().unwrap_or_else(|err| err)
}

/// `tetlap.errors.OptionError(message)`.
pub fn option_error(py: Python<'_>, message: String) -> PyErr {
    raise(py, &classes(py).option, message, &[])
}

/// `tetlap.errors.ShapeError(message)`.
pub fn shape_error(py: Python<'_>, message: String) -> PyErr {
    raise(py, &classes(py).shape, message, &[])
}

/// `tetlap.errors.SolveError(message)`.
pub fn solve_error(py: Python<'_>, message: String) -> PyErr {
    raise(py, &classes(py).solve, message, &[])
}

/// The exception for a core error: the class, a message in Python terms and the offending
/// element, vertex or index as attributes.
pub fn to_py(py: Python<'_>, e: Error) -> PyErr {
    let c = classes(py);
    let i = |x: usize| x as i64;
    match e {
        Error::Shape { what } => raise(py, &c.shape, what, &[]),
        Error::EmptyMesh { .. } => raise(py, &c.empty, e.to_string(), &[]),
        Error::TooManyVertices { .. } | Error::TooManyElements { .. } => {
            raise(py, &c.index, e.to_string(), &[])
        }
        Error::NonFiniteCoordinate { vertex, .. } | Error::NonFiniteWeight { vertex, .. } => {
            raise(py, &c.non_finite, e.to_string(), &[("vertex", i(vertex))])
        }
        Error::IndexOutOfRange { element, index, .. } => {
            raise(py, &c.index, e.to_string(), &[("element", i(element)), ("index", index)])
        }
        Error::VertexList { vertex, .. } => {
            raise(py, &c.index, e.to_string(), &[("vertex", vertex as i64)])
        }
        Error::RepeatedVertex { element, vertex } => raise(
            py,
            &c.repeated,
            e.to_string(),
            &[("element", i(element)), ("vertex", vertex as i64)],
        ),
        Error::Degenerate { element } => raise(
            py,
            &c.degenerate,
            format!(
                "element {element} is degenerate (zero volume for a tet, zero area for a \
                 triangle); pass degenerate=\"skip\" to give such elements zero contribution"
            ),
            &[("element", i(element))],
        ),
        Error::NonFiniteResult { element } => raise(
            py,
            &c.degenerate,
            format!(
                "element {element}: its values leave the float64 range (normal magnitudes \
                 2.2e-308 to 1.8e308: a volume beyond it, or the weights or masses of a needle or \
                 a flat tet beyond it) or, immersed in R^d, cannot be computed to the documented \
                 accuracy; pass degenerate=\"skip\" to drop it"
            ),
            &[("element", i(element))],
        ),
        Error::Overflow { element } => raise(
            py,
            &c.non_finite,
            format!(
                "element {element}: the products of its values with the given cotangents (such \
                 as the energy's f) leave the float64 range; scale them down"
            ),
            &[("element", i(element))],
        ),
        Error::SumOverflow { vertex } => raise(
            py,
            &c.non_finite,
            format!(
                "the values at vertex {vertex} sum beyond the float64 range (coordinates too large \
                 for double precision; scale the mesh down)"
            ),
            &[("vertex", i(vertex))],
        ),
        Error::AffineParameter { t } => {
            raise(py, &c.option, format!("the affine parameter t must lie in [0, 1], got {t}"), &[])
        }
        Error::Threads { threads, max } => raise(
            py,
            &c.option,
            format!("threads must be None or an integer from 1 to {max}, got {threads}"),
            &[],
        ),
        Error::ThreadsVariable { value, max } => raise(
            py,
            &c.option,
            format!(
                "the environment variable RAYON_NUM_THREADS is {value:?}: with threads=None it sets \
                 the thread count and must be 0 (all cores) or an integer from 1 to {max} \
                 (tetlap.MAX_THREADS); fix or unset it, or pass threads="
            ),
            &[],
        ),
        Error::ThreadPool { reason } => {
            raise(py, &c.option, format!("could not start the worker threads: {reason}"), &[])
        }
        Error::Unsupported { option, element } => {
            let option = match option {
                Feature::VertexWeights => "`weights`",
                Feature::BarycentricBoundary => "boundary_centres=\"barycentric\"",
            };
            raise(py, &c.option, format!("{option} applies to tet meshes only, not {element} meshes"), &[])
        }
        Error::NonFiniteCotangent { index, .. } => {
            raise(py, &c.non_finite, e.to_string(), &[("index", i(index))])
        }
        Error::NotDifferentiable { what } => {
            let what = what.replace("Boundary::Barycentric", "boundary_centres=\"barycentric\"");
            let what = what.replace("Boundary::Circumcentric", "boundary_centres=\"circumcentric\"");
            raise(py, &c.option, format!("derivatives of {what} are not available"), &[])
        }
        Error::Cancelled => PyKeyboardInterrupt::new_err("cancelled"),
        Error::NotPositiveDefinite { row } => raise(
            py,
            &c.solve,
            format!("the matrix is not positive definite: the Cholesky pivot of its row {row} is not positive"),
            &[("index", i(row))],
        ),
        Error::Singular { row } => raise(
            py,
            &c.solve,
            format!("the LDL^T factorization met a zero pivot at row {row}: the matrix is singular there"),
            &[("index", i(row))],
        ),
        Error::OutOfMemory { .. } => raise(py, &c.solve, e.to_string(), &[]),
        Error::Coefficient { element, kind, density, problem } => {
            let name = if density { "density" } else { "coefficient" };
            coefficient_error(py, element, (name, kind, "element"), density, problem)
        }
        Error::CoefficientUnsupported { what } => {
            raise(py, &c.option, format!("{what} does not take a coefficient or a density"), &[])
        }
    }
}

/// The exception for a refused coefficient or density value: `NonFiniteError` or
/// `CoefficientError`, naming the value's place `element` (`None`: the one tensor of every
/// element) in the words of `(name, noun, attribute)`: the array's name, what one value
/// belongs to ("tet", "vertex") and the exception's attribute holding its index.
pub fn coefficient_error(
    py: Python<'_>,
    element: Option<usize>,
    (name, kind, attribute): (&str, &str, &'static str),
    density: bool,
    problem: CoefficientProblem,
) -> PyErr {
    let c = classes(py);
    let which = match element {
        Some(t) => format!("{name}[{t}] ({kind} {t})"),
        None => format!("the {name} (one tensor for every {kind})"),
    };
    let attributes: Vec<(&str, i64)> = element.map(|t| (attribute, t as i64)).into_iter().collect();
    match problem {
        CoefficientProblem::NonFinite { entry, value } => {
            let at = match (entry, element) {
                (None, _) => String::new(),
                (Some((row, col)), Some(t)) => format!(" at {name}[{t}, {row}, {col}]"),
                (Some((row, col)), None) => format!(" at [{row}, {col}]"),
            };
            raise(py, &c.non_finite, format!("{which} is not finite: {}{at}", float(value)), &attributes)
        }
        CoefficientProblem::NotPositive { value } => raise(
            py,
            &c.coefficient,
            format!("{which} is {}: a {} must be positive", float(value), if density { "density" } else { "scalar coefficient" }),
            &attributes,
        ),
        CoefficientProblem::NotSymmetric { row, col, asymmetry } => raise(
            py,
            &c.coefficient,
            format!(
                "{which} is not symmetric: its entries [{row}, {col}] and [{col}, {row}] differ by {} of its largest \
                 entry (up to {} is taken as rounding); a tensor symmetric to its own precision can be passed as \
                 (K + K.swapaxes(-1, -2)) / 2",
                sci(asymmetry),
                sci(tetlap::element::metric::SYMMETRY_RTOL)
            ),
            &attributes,
        ),
        CoefficientProblem::NotPositiveDefinite { smallest, largest } => raise(
            py,
            &c.coefficient,
            format!(
                "{which} is not positive definite: its smallest eigenvalue is {} (its largest {}); a conductivity \
                 tensor must be symmetric positive definite",
                sci(smallest),
                sci(largest)
            ),
            &attributes,
        ),
    }
}

/// `x` as Python's `repr` writes it (`nan`, `inf`, `-3.0`, `1e-300`).
fn float(x: f64) -> String {
    match x {
        _ if x.is_nan() => "nan".into(),
        f64::INFINITY => "inf".into(),
        f64::NEG_INFINITY => "-inf".into(),
        _ => format!("{x:?}"),
    }
}

/// `x` in scientific notation as Python writes it, six significant digits (`-1.00000e+00`).
fn sci(x: f64) -> String {
    let s = format!("{x:.5e}");
    match s.split_once('e') {
        Some((mantissa, exponent)) => {
            let e: i32 = exponent.parse().unwrap_or(0);
            format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
        }
        None => s,
    }
}

/// How often a waiting call looks for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);

/// Runs `f` on a worker thread without the GIL, while this thread answers signals: on
/// Ctrl-C (or any exception raised by a signal handler) `cancel` is set, the worker stops
/// at its next poll and that exception is raised. A core error becomes its exception; a
/// panic (an internal bug) becomes `tetlap.errors.InternalError` instead of an uncatchable
/// `PanicException`.
pub fn guarded<T: Send>(
    py: Python<'_>,
    cancel: &Cancel,
    f: impl FnOnce() -> tetlap::Result<T> + Send,
) -> PyResult<T> {
    let outcome = std::thread::scope(|scope| {
        let (done, finished) = mpsc::channel();
        scope.spawn(move || {
            let _ = done.send(caught(f));
        });
        let mut interrupted = None;
        let mut finished = Some(finished);
        loop {
            // the receiver moves into the GIL-free wait and back (it is not Sync)
            let receiver = finished.take().expect("put back after every wait");
            let (received, receiver) = py.detach(move || (receiver.recv_timeout(POLL), receiver));
            finished = Some(receiver);
            match received {
                Ok(outcome) => return interrupted.map_or(Ok(outcome), Err),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let (None, Err(e)) = (&interrupted, py.check_signals()) {
                        cancel.cancel();
                        interrupted = Some(e);
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    unreachable!("the worker always sends its outcome")
                }
            }
        }
    })?;
    match outcome {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py(py, e)),
        Err(panic) => Err(raise(
            py,
            &classes(py).internal,
            format!("internal error in tetlap's core ({panic}); please report it with the input"),
            &[],
        )),
    }
}

/// [`guarded`] for `f(&opts)` in the options' thread pool (so that what `f` validates
/// before the core's own `install` runs on those threads too), cancelled through the
/// options' own flag.
pub fn compute<T: Send>(
    py: Python<'_>,
    mut opts: tetlap::Options,
    f: impl FnOnce(&tetlap::Options) -> tetlap::Result<T> + Send,
) -> PyResult<T> {
    let cancel = opts.cancel.get_or_insert_with(Cancel::new).clone();
    guarded(py, &cancel, move || opts.install(|| f(&opts)))
}

/// `f()`, or the message of the panic it raised.
fn caught<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into())
    })
}

#[cfg(test)]
mod tests {
    use super::caught;

    #[test]
    fn panics_become_their_message_and_values_pass_through() {
        let quiet = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        assert_eq!(caught(|| -> i32 { panic!("boom {}", 7) }), Err("boom 7".to_string()));
        assert_eq!(caught(|| -> i32 { panic!("static") }), Err("static".to_string()));
        std::panic::set_hook(quiet);
        assert_eq!(caught(|| 3), Ok(3));
        let err: tetlap::Result<()> = Err(tetlap::Error::Cancelled);
        assert_eq!(caught(move || err), Ok(Err(tetlap::Error::Cancelled)));
    }
}
