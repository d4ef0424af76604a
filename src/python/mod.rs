//! The Python module `helixbif._helixbif` (cargo feature `python`; `pyproject.toml` builds it
//! with maturin and the package `python/helixbif/` re-exports it): thin glue over the study
//! layer, as the command line is (docs/python.md).
//!
//! - [`study`]: the class `Study` (a validated study, `with_` overrides by the dotted keys and
//!   the code of `--set`) and its runs, each the command line's command with its options as
//!   arguments;
//! - [`results`]: what the runs return: the JSON of the command's `--json` (the same
//!   `serde_json::to_value` of the same result, so every number is the command line's) with the
//!   tables the run wrote as numpy arrays;
//! - [`convert`]: JSON, TOML and CSV to and from Python objects and numpy arrays;
//! - [`run`]: errors (bad input `ValueError`, numerical failure `NumericalError` with the partial
//!   result) and the runs with the GIL released, ended by Ctrl-C between steps
//!   ([`crate::study::interrupt`]).

mod convert;
mod results;
mod run;
mod runs;
mod study;

use pyo3::prelude::*;

/// The extension module: the classes, `fit_power_law` and `NumericalError`; the process is
/// configured as the command line configures it ([`crate::numerics::process::configure`], and
/// the copy of the RPY kernels capped by `HELIXBIF_KERNELS` and the interval of progress lines
/// set by `HELIXBIF_PROGRESS_SECONDS`, a `ValueError` on import where either holds no such
/// value) and the study layer's runs ask Python's signal handlers between steps.
#[pymodule]
#[pyo3(name = "_helixbif")]
fn helixbif_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::numerics::process::configure();
    crate::model::fluid::rpy::cap_from_environment()
        .map_err(|e| run::to_python(m.py(), e, None))?;
    crate::study::progress::interval_from_environment()
        .map_err(|e| run::to_python(m.py(), e, None))?;
    crate::study::interrupt::set_check(run::interrupted);
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("NumericalError", m.py().get_type::<run::NumericalError>())?;
    m.add_class::<study::Study>()?;
    m.add_class::<results::Located>()?;
    m.add_class::<results::Branch>()?;
    m.add_class::<results::Solution>()?;
    m.add_class::<results::Boundary>()?;
    m.add_class::<results::Simulation>()?;
    m.add_class::<results::Orbits>()?;
    m.add_class::<results::PowerLaw>()?;
    m.add_class::<results::StudyRun>()?;
    m.add_function(wrap_pyfunction!(results::fit_power_law, m)?)?;
    Ok(())
}
