//! A Python object as the system under test, and `sut=` choices.

use super::*;

/// A Python object with `step(observation)` (and optionally
/// `reset(info)`) as the SUT: called in-process, with the GIL taken only
/// for the call.
pub(super) struct PySut {
    pub(super) obj: Py<PyAny>,
    pub(super) name: String,
    /// `obj.step`, bound once a run (at `reset`): a run calls it every
    /// step, and looking the method up made a new bound method each time.
    pub(super) step_fn: Option<Py<PyAny>>,
}

impl Sut for PySut {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        Python::attach(|py| {
            let obj = self.obj.bind(py);
            self.step_fn = Some(
                obj.getattr(pyo3::intern!(py, "step"))
                    .map_err(|e| SutError(traceback_text(py, &e)))?
                    .unbind(),
            );
            if !obj.hasattr("reset").unwrap_or(false) {
                return Ok(());
            }
            let d = info_dict(py, info).map_err(|e| SutError(traceback_text(py, &e)))?;
            obj.call_method1("reset", (d,))
                .map(|_| ())
                .map_err(|e| SutError(format!("reset() raised:\n{}", traceback_text(py, &e))))
        })
    }
    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        self.step_shared(&Arc::new(obs.clone()))
    }
    fn step_shared(&mut self, obs: &Arc<Observation>) -> Result<SutCommand, SutError> {
        // Attaching is a counter's increment where the caller kept the
        // interpreter for the run (`litesim.run`), a full attach otherwise.
        Python::attach(|py| {
            let o = Py::new(
                py,
                PyObservation {
                    obs: Arc::clone(obs),
                },
            )
            .map_err(|e| SutError(traceback_text(py, &e)))?;
            let r = match &self.step_fn {
                Some(f) => f.bind(py).call1((o,)),
                None => self
                    .obj
                    .bind(py)
                    .call_method1(pyo3::intern!(py, "step"), (o,)),
            };
            let r =
                r.map_err(|e| SutError(format!("step() raised:\n{}", traceback_text(py, &e))))?;
            command_of(&r).map_err(SutError)
        })
    }
}

pub(super) struct PySutFactory {
    pub(super) obj: Py<PyAny>,
    pub(super) name: String,
}

impl SutFactory for PySutFactory {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        Python::attach(|py| {
            Ok(Box::new(PySut {
                obj: self.obj.clone_ref(py),
                name: self.name.clone(),
                step_fn: None,
            }) as Box<dyn Sut>)
        })
    }
}

/// `sut=`: None (planned), a built-in name, `grpc://HOST:PORT`, or an
/// object with `step`.
pub(super) fn sut_choice(sut: Option<&Bound<'_, PyAny>>) -> PyResult<SutChoice> {
    python_sut_choice(sut).map(|(c, _)| c)
}

/// [`sut_choice`], and whether the SUT is a Python object (whose every
/// step needs the interpreter).
pub(super) fn python_sut_choice(sut: Option<&Bound<'_, PyAny>>) -> PyResult<(SutChoice, bool)> {
    let Some(s) = sut else {
        return Ok((SutChoice::Planned, false));
    };
    if s.is_none() {
        return Ok((SutChoice::Planned, false));
    }
    if let Ok(name) = s.extract::<String>() {
        if let Some(c) = litesim_grpc::sut::choice_by_name(&name)
            .map_err(|e| PyValueError::new_err(format!("sut: {}", e.0)))?
        {
            return Ok((c, false));
        }
        return Err(PyValueError::new_err(format!(
            "sut: unknown system under test '{name}'; valid: {}, grpc://HOST:PORT, or an object with step(observation)",
            litesim_scenario::sut::BUILTIN.join(", ")
        )));
    }
    if !s.hasattr("step")? {
        let t = s.get_type().name()?.to_string();
        return Err(PyTypeError::new_err(format!(
            "sut: a {t} has no step(observation) method; give a name ('acc'), grpc://HOST:PORT or an object with step()"
        )));
    }
    let name = format!("python:{}", s.get_type().name()?);
    let factory = PySutFactory {
        obj: s.clone().unbind(),
        name,
    };
    Ok((SutChoice::External(Arc::new(factory)), true))
}

pub(super) fn mode_of(mode: Option<&str>) -> PyResult<Option<DriveMode>> {
    match mode {
        None => Ok(None),
        Some("kinematic") => Ok(Some(DriveMode::Kinematic)),
        Some("dynamic") => Ok(Some(DriveMode::Dynamic)),
        Some(m) => Err(PyValueError::new_err(format!(
            "mode: '{m}' is not a drive mode; expected 'kinematic' or 'dynamic' (or None: the test's)"
        ))),
    }
}

// ---------------------------------------------------------------- run

/// The name a stepped run's SUT has in summaries (the run never calls
/// it: the caller gives each command).
pub(super) struct Outside;

impl SutFactory for Outside {
    fn name(&self) -> String {
        "python:gym".into()
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        Err(SutError("a stepped run's SUT is its caller".into()))
    }
}
