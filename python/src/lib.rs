//! `litesim._native`: the Rust side of the Python package. The Python
//! modules (`litesim/__init__.py`, `gym.py`, `ray.py`) wrap it; users import
//! `litesim`, not this.
//!
//! The GIL is released while litesim runs, but for `litesim.run` with a
//! Python SUT, which keeps it between the SUT's calls (those hand it to
//! other Python threads at Python's switch interval, as any Python code
//! does); a Python SUT in a batch takes it back for its own calls only.

use litesim_scenario::sut::{
    LightState, ObjectState, Observation, RoadPos, Sut, SutChoice, SutCommand, SutError,
    SutFactory, SutInfo,
};
use litesim_scenario::{DriveMode, LoadOptions, RunOptions, Stepped};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// litesim's allocations go to mimalloc, as in the CLI: with the C
/// runtime's malloc a `litesim.run` spent about a fifth of its time in
/// malloc and free (perf, BENCHMARKS.md). Python's own objects keep
/// Python's allocator; nothing allocated on one side is freed on the other.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod runs;
mod simulator;
mod sut;
mod values;
use runs::*;
use simulator::*;
use sut::*;
use values::*;

create_exception!(
    _native,
    LitesimError,
    PyException,
    "Something litesim could not do (an unreadable test or map, a run that could not start); the message is litesim's."
);

fn lerr(e: impl std::error::Error) -> PyErr {
    LitesimError::new_err(litesim_scenario::error::chain_of(&e))
}

/// The traceback of a Python exception, as Python prints it.
fn traceback_text(py: Python<'_>, e: &PyErr) -> String {
    let formatted = (|| -> PyResult<String> {
        let tb = py.import("traceback")?;
        let lines = tb.call_method1(
            "format_exception",
            (e.get_type(py), e.value(py), e.traceback(py)),
        )?;
        let parts: Vec<String> = lines.extract()?;
        Ok(parts.concat())
    })();
    formatted.unwrap_or_else(|_| e.to_string())
}

// ---------------------------------------------------------------- SUT seam

/// The `litesim._native` module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LitesimError", m.py().get_type::<LitesimError>())?;
    m.add_class::<PyObjectState>()?;
    m.add_class::<PyObservation>()?;
    m.add_class::<PyCommand>()?;
    m.add_class::<NativeRun>()?;
    m.add_class::<SteppedRun>()?;
    m.add_class::<Episodes>()?;
    m.add_class::<Simulator>()?;
    m.add_class::<PreparedTest>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(prepare, m)?)?;
    m.add_function(wrap_pyfunction!(run_lines, m)?)?;
    m.add_function(wrap_pyfunction!(write_batch, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
