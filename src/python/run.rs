//! How the Python module runs the library: with the GIL released and Ctrl-C honoured between
//! steps, its errors as Python exceptions, its output folders and provenance.

use std::cell::RefCell;
use std::path::PathBuf;

use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::IntoPyDict;

use crate::Error;
use crate::study::output::{Provenance, make_writable_dir};

create_exception!(
    helixbif,
    NumericalError,
    PyRuntimeError,
    "A numerical failure of a run (the command line's exit code 1): where and why, in `message` \
     (also `str(error)`), and the result found before it in `partial` (a result object with the \
     rows written so far, or None)."
);

thread_local! {
    /// The exception a signal handler raised during the run in progress on this thread (the
    /// study layer asks its check on the thread that runs the study; Python runs signal
    /// handlers on the main thread only, so only a run there is ever interrupted).
    static PENDING: RefCell<Option<PyErr>> = const { RefCell::new(None) };
}

/// The study layer's interrupt check ([`crate::study::interrupt::set_check`]): runs Python's
/// signal handlers, and keeps the exception one raised (`KeyboardInterrupt` for Ctrl-C) for
/// [`detached`] to raise when the run has ended. Once one was raised, every later check of the
/// run says stop.
pub(crate) fn interrupted() -> bool {
    if PENDING.with_borrow(Option::is_some) {
        return true;
    }
    match Python::attach(|py| py.check_signals().err()) {
        Some(e) => {
            PENDING.set(Some(e));
            true
        }
        None => false,
    }
}

/// Runs `f` with the GIL released; when a signal handler raised during it (Ctrl-C:
/// `KeyboardInterrupt`), that exception, whatever `f` returned.
pub(crate) fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    PENDING.set(None);
    let out = py.detach(f);
    match PENDING.take() {
        Some(raised) => Err(raised),
        None => Ok(out),
    }
}

/// A field named as the command line names it (`--t-end`, `--from/--to`) named as the Python
/// argument is (`t_end`, `start/stop`).
fn python_field(field: &str) -> String {
    match field {
        "--from/--to" => "start/stop".into(),
        // `with_` reads its overrides as `--set` does, and says so.
        "--set" => field.into(),
        f if f.starts_with("--") => f[2..].replace('-', "_"),
        f => f.into(),
    }
}

/// The library's error as a Python exception: bad input a `ValueError` with the command line's
/// one line (`invalid input: field: message`, options named as the Python arguments), a file
/// that cannot be read or written an `OSError`, anything else a [`NumericalError`] carrying
/// `partial`.
pub(crate) fn to_python(py: Python<'_>, error: Error, partial: Option<Py<PyAny>>) -> PyErr {
    match error {
        Error::Input { field, message } => PyValueError::new_err(
            Error::Input {
                field: python_field(&field),
                message,
            }
            .to_string(),
        ),
        e if e.is_input() => PyValueError::new_err(e.to_string()),
        e @ Error::Io { .. } => PyOSError::new_err(e.to_string()),
        e => numerical(py, e.to_string(), partial),
    }
}

/// A [`NumericalError`] with `message` and `partial` (None when absent).
pub(crate) fn numerical(py: Python<'_>, message: String, partial: Option<Py<PyAny>>) -> PyErr {
    let error = NumericalError::new_err(message.clone());
    let value = error.value(py);
    let partial = partial.unwrap_or_else(|| py.None());
    // Setting attributes of a fresh exception instance cannot fail.
    let _ = value.setattr("message", message);
    let _ = value.setattr("partial", partial);
    error
}

/// Bad input about `field` as a `ValueError` with the command line's wording.
pub(crate) fn bad_input(field: &str, message: impl Into<String>) -> PyErr {
    PyValueError::new_err(Error::input(field, message).to_string())
}

/// The output folder of a run: `out` made and checked writable (an unusable folder is bad
/// input naming `out`), or a fresh temporary folder (`tempfile.mkdtemp`, prefix
/// `helixbif-<command>-`), which is kept.
pub(crate) fn output_dir(py: Python<'_>, out: Option<PathBuf>, command: &str) -> PyResult<PathBuf> {
    let Some(out) = out else {
        let prefix = [("prefix", format!("helixbif-{command}-"))].into_py_dict(py)?;
        let made = py
            .import("tempfile")?
            .getattr("mkdtemp")?
            .call((), Some(&prefix))?;
        return made.extract();
    };
    make_writable_dir(&out).map_err(|e| {
        bad_input(
            "out",
            format!("cannot write results into {}: {e}", out.display()),
        )
    })?;
    Ok(out)
}

/// What `meta.json` records as the command line of a run from Python: the method and its
/// arguments.
pub(crate) fn provenance(method: &str, arguments: &[(&str, String)]) -> Provenance {
    let mut command_line = vec!["python".to_string(), format!("helixbif.Study.{method}")];
    command_line.extend(arguments.iter().map(|(k, v)| format!("{k}={v}")));
    Provenance { command_line }
}

/// The JSON of a result, as `--json` makes it (`serde_json::to_value`).
pub(crate) fn to_json(
    py: Python<'_>,
    value: &impl serde::Serialize,
) -> PyResult<serde_json::Value> {
    serde_json::to_value(value).map_err(|e| numerical(py, e.to_string(), None))
}
