//! `litesim._native`: the Rust side of the Python package. The Python
//! modules (`litesim/__init__.py`, `gym.py`, `ray.py`) wrap it; users import
//! `litesim`, not this.
//!
//! The GIL is released while litesim runs; a Python SUT takes it back for
//! its own calls only, so other Python threads keep running.

use litesim_scenario::sut::{
    LightState, ObjectState, Observation, RoadPos, Sut, SutChoice, SutCommand, SutError,
    SutFactory, SutInfo,
};
use litesim_scenario::{DriveMode, LoadOptions, RunOptions};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};

create_exception!(
    _native,
    LitesimError,
    PyException,
    "Something litesim could not do (an unreadable test or map, a run that could not start); the message is litesim's."
);

fn lerr(e: impl std::fmt::Display) -> PyErr {
    LitesimError::new_err(e.to_string())
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

/// One object of the object list (map frame, SI units).
#[pyclass(name = "ObjectState", module = "litesim", frozen, get_all)]
#[derive(Clone)]
struct PyObjectState {
    id: String,
    kind: String,
    x: f64,
    y: f64,
    yaw: f64,
    speed: f64,
    vx: f64,
    vy: f64,
    acceleration: f64,
    length: f64,
    width: f64,
}

impl From<&ObjectState> for PyObjectState {
    fn from(o: &ObjectState) -> Self {
        PyObjectState {
            id: o.id.clone(),
            kind: o.kind.clone(),
            x: o.x,
            y: o.y,
            yaw: o.yaw,
            speed: o.speed,
            vx: o.vx,
            vy: o.vy,
            acceleration: o.acceleration,
            length: o.length,
            width: o.width,
        }
    }
}

#[pymethods]
impl PyObjectState {
    fn __repr__(&self) -> String {
        format!(
            "ObjectState(id={:?}, kind={:?}, x={:.3}, y={:.3}, yaw={:.4}, speed={:.3})",
            self.id, self.kind, self.x, self.y, self.yaw, self.speed
        )
    }
}

/// What the SUT sees at one step. Fields are converted when read, so a SUT
/// that looks at the ego only pays for the ego.
#[pyclass(name = "Observation", module = "litesim", frozen)]
struct PyObservation {
    obs: Observation,
}

#[pymethods]
impl PyObservation {
    /// Step index.
    #[getter]
    fn tick(&self) -> u64 {
        self.obs.tick
    }
    /// Simulation time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.obs.time
    }
    /// The ego (`sut.car`).
    #[getter]
    fn ego(&self) -> PyObjectState {
        (&self.obs.ego).into()
    }
    /// Every other actor.
    #[getter]
    fn objects(&self) -> Vec<PyObjectState> {
        self.obs.objects.iter().map(Into::into).collect()
    }
    /// Traffic light boxes: dicts with id, road, s, color.
    #[getter]
    fn lights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for l in &self.obs.lights {
            out.append(light_dict(py, l)?)?;
        }
        Ok(out)
    }
    /// The ego's road position (dict: road, lane, s, offset) or None.
    #[getter]
    fn road<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.obs.road.as_ref().map(|r| road_dict(py, r)).transpose()
    }
    /// Speed the scenario asks of the ego now (m/s).
    #[getter]
    fn requested_speed(&self) -> f64 {
        self.obs.requested_speed
    }
    /// Distance to the route's goal along the route (m).
    #[getter]
    fn distance_to_goal(&self) -> f64 {
        self.obs.distance_to_goal
    }
    /// The whole observation as JSON (the gRPC SUT service's fields).
    fn to_json(&self) -> String {
        serde_json::to_string(&self.obs).unwrap_or_default()
    }
    fn __repr__(&self) -> String {
        format!(
            "Observation(tick={}, time={:.3}, ego={}, objects={})",
            self.obs.tick,
            self.obs.time,
            self.obs.ego.id,
            self.obs.objects.len()
        )
    }
}

fn light_dict<'py>(py: Python<'py>, l: &LightState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("id", &l.id)?;
    d.set_item("road", &l.road)?;
    d.set_item("s", l.s)?;
    d.set_item("color", &l.color)?;
    Ok(d)
}

fn road_dict<'py>(py: Python<'py>, r: &RoadPos) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("road", &r.road)?;
    d.set_item("lane", r.lane)?;
    d.set_item("s", r.s)?;
    d.set_item("offset", r.offset)?;
    Ok(d)
}

/// A command for `sut.car`: `Command.pedals(throttle, brake, steering)`,
/// `Command.accel(acceleration, curvature)` or
/// `Command.physical(drive_force_n, brake_force_n, steering_wheel_angle_rad)`.
#[pyclass(name = "Command", module = "litesim", frozen)]
#[derive(Clone)]
struct PyCommand {
    cmd: SutCommand,
}

#[pymethods]
impl PyCommand {
    /// Normalised pedals 0..1 and steering −1..1 (+ = left).
    #[staticmethod]
    #[pyo3(signature = (throttle=0.0, brake=0.0, steering=0.0))]
    fn pedals(throttle: f64, brake: f64, steering: f64) -> PyResult<Self> {
        checked(SutCommand::Pedals {
            throttle,
            brake,
            steering,
        })
    }
    /// Target acceleration (m/s²) and path curvature (1/m, + = left).
    #[staticmethod]
    #[pyo3(signature = (acceleration=0.0, curvature=0.0))]
    fn accel(acceleration: f64, curvature: f64) -> PyResult<Self> {
        checked(SutCommand::Accel {
            acceleration,
            curvature,
        })
    }
    /// Drive and brake force (N) and steering-wheel angle (rad).
    #[staticmethod]
    #[pyo3(signature = (drive_force_n=0.0, brake_force_n=0.0, steering_wheel_angle_rad=0.0))]
    fn physical(
        drive_force_n: f64,
        brake_force_n: f64,
        steering_wheel_angle_rad: f64,
    ) -> PyResult<Self> {
        checked(SutCommand::Physical {
            drive_force_n,
            brake_force_n,
            steering_wheel_angle_rad,
        })
    }
    fn __repr__(&self) -> String {
        format!(
            "Command({})",
            serde_json::to_string(&self.cmd).unwrap_or_default()
        )
    }
}

fn checked(cmd: SutCommand) -> PyResult<PyCommand> {
    cmd.validate().map_err(PyValueError::new_err)?;
    Ok(PyCommand { cmd })
}

/// What a Python SUT's `step` returned, as a command: a `Command`, or a
/// dict with throttle/brake/steering or acceleration/curvature keys.
fn command_of(v: &Bound<'_, PyAny>) -> Result<SutCommand, String> {
    if let Ok(c) = v.cast::<PyCommand>() {
        return Ok(c.get().cmd);
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let get = |k: &str| -> Result<Option<f64>, String> {
            match d.get_item(k).map_err(|e| e.to_string())? {
                None => Ok(None),
                Some(x) => x
                    .extract::<f64>()
                    .map(Some)
                    .map_err(|_| format!("step() returned a dict whose '{k}' is not a number")),
            }
        };
        let cmd = if get("acceleration")?.is_some() || get("curvature")?.is_some() {
            SutCommand::Accel {
                acceleration: get("acceleration")?.unwrap_or(0.0),
                curvature: get("curvature")?.unwrap_or(0.0),
            }
        } else {
            SutCommand::Pedals {
                throttle: get("throttle")?.unwrap_or(0.0),
                brake: get("brake")?.unwrap_or(0.0),
                steering: get("steering")?.unwrap_or(0.0),
            }
        };
        cmd.validate().map_err(|e| format!("step() returned {e}"))?;
        return Ok(cmd);
    }
    let t = v
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into());
    Err(format!(
        "step() returned a {t}; expected a litesim.Command or a dict of throttle/brake/steering or acceleration/curvature"
    ))
}

fn info_dict<'py>(py: Python<'py>, info: &SutInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("test", &info.test)?;
    d.set_item("seed", info.seed)?;
    d.set_item("map_path", &info.map_path)?;
    d.set_item("step_ms", info.step_ms)?;
    d.set_item("ego_id", &info.ego_id)?;
    d.set_item("length", info.length)?;
    d.set_item("width", info.width)?;
    d.set_item("wheelbase", info.wheelbase)?;
    d.set_item("max_steer", info.max_steer)?;
    d.set_item("max_accel", info.max_accel)?;
    d.set_item("max_decel", info.max_decel)?;
    d.set_item("timeout_s", info.timeout_s)?;
    d.set_item("route", info.route.points.clone())?;
    d.set_item("route_speed", info.route.speed.clone())?;
    Ok(d)
}

/// A Python object with `step(observation)` (and optionally
/// `reset(info)`) as the SUT: called in-process, with the GIL taken only
/// for the call.
struct PySut {
    obj: Py<PyAny>,
    name: String,
}

impl Sut for PySut {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        Python::attach(|py| {
            let obj = self.obj.bind(py);
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
        Python::attach(|py| {
            let o = Py::new(py, PyObservation { obs: obs.clone() })
                .map_err(|e| SutError(traceback_text(py, &e)))?;
            let r = self
                .obj
                .bind(py)
                .call_method1("step", (o,))
                .map_err(|e| SutError(format!("step() raised:\n{}", traceback_text(py, &e))))?;
            command_of(&r).map_err(SutError)
        })
    }
}

struct PySutFactory {
    obj: Py<PyAny>,
    name: String,
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
            }) as Box<dyn Sut>)
        })
    }
}

/// `sut=`: None (planned), a built-in name, `grpc://HOST:PORT`, or an
/// object with `step`.
fn sut_choice(sut: Option<&Bound<'_, PyAny>>) -> PyResult<SutChoice> {
    let Some(s) = sut else {
        return Ok(SutChoice::Planned);
    };
    if s.is_none() {
        return Ok(SutChoice::Planned);
    }
    if let Ok(name) = s.extract::<String>() {
        if let Some(c) = SutChoice::builtin(&name) {
            return Ok(c);
        }
        if name.starts_with("grpc://") {
            let f = litesim_grpc::sut::GrpcSutFactory::new(&name)
                .map_err(|e| PyValueError::new_err(format!("sut: {}", e.0)))?;
            return Ok(SutChoice::External(Arc::new(f)));
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
    Ok(SutChoice::External(Arc::new(PySutFactory {
        obj: s.clone().unbind(),
        name,
    })))
}

fn mode_of(mode: Option<&str>) -> PyResult<Option<DriveMode>> {
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

/// The outcome of one run (see `litesim.run`).
#[pyclass(name = "NativeRun", module = "litesim._native", frozen)]
struct NativeRun {
    #[pyo3(get)]
    passed: bool,
    #[pyo3(get)]
    failures: Vec<String>,
    /// The summary as JSON (parsed by the Python side).
    #[pyo3(get)]
    summary_json: String,
    log: Option<litesim_log::SimulationLog>,
}

#[pymethods]
impl NativeRun {
    /// The log in long form: one row per actor and tick, as a dict of
    /// column name → list (None when the run did not record).
    fn log_columns<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(log) = &self.log else {
            return Ok(None);
        };
        let n: usize = log.tracks.iter().map(|t| t.len()).sum();
        let mut tick = Vec::with_capacity(n);
        let mut time = Vec::with_capacity(n);
        let mut actor = Vec::with_capacity(n);
        let mut mode = Vec::with_capacity(n);
        let mut cols: Vec<(&str, Vec<f64>)> = [
            "x",
            "y",
            "yaw",
            "vx",
            "vy",
            "speed",
            "yaw_rate",
            "throttle",
            "brake",
            "steering",
            "acceleration",
            "lateral_acceleration",
        ]
        .iter()
        .map(|c| (*c, Vec::with_capacity(n)))
        .collect();
        for t in &log.tracks {
            for i in 0..t.len() {
                tick.push(t.tick[i]);
                time.push(t.tick[i] as f64 * log.dt);
                actor.push(t.id.as_str());
                mode.push(t.mode[i].as_str());
                let s = &t.state;
                let c = &t.control;
                let d = &t.derived;
                for (k, v) in [
                    s.x[i],
                    s.y[i],
                    s.yaw[i],
                    s.vx[i],
                    s.vy[i],
                    s.speed[i],
                    s.yaw_rate[i],
                    c.throttle[i],
                    c.brake[i],
                    c.steering[i],
                    d.longitudinal_acceleration[i],
                    d.lateral_acceleration[i],
                ]
                .into_iter()
                .enumerate()
                {
                    cols[k].1.push(v);
                }
            }
        }
        let out = PyDict::new(py);
        out.set_item("tick", tick)?;
        out.set_item("time", time)?;
        out.set_item("actor", actor)?;
        out.set_item("mode", mode)?;
        for (k, v) in cols {
            out.set_item(k, v)?;
        }
        Ok(Some(out))
    }
    /// The log as litesim's JSON (what `litesim run` writes as log.json).
    fn log_json(&self) -> PyResult<Option<String>> {
        self.log
            .as_ref()
            .map(|l| serde_json::to_string(l).map_err(lerr))
            .transpose()
    }
}

/// Runs one test (see `litesim.run` for the parameters).
#[pyfunction]
#[pyo3(signature = (test, seed=None, sut=None, mode=None, record=true, map=None, include=Vec::new(), sut_timeout=None))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    test: PathBuf,
    seed: Option<u64>,
    sut: Option<&Bound<'_, PyAny>>,
    mode: Option<&str>,
    record: bool,
    map: Option<PathBuf>,
    include: Vec<PathBuf>,
    sut_timeout: Option<f64>,
) -> PyResult<NativeRun> {
    let sut = sut_choice(sut)?;
    let mode = mode_of(mode)?;
    if let Some(t) = sut_timeout
        && !(t.is_finite() && t > 0.0)
    {
        return Err(PyValueError::new_err(format!(
            "sut_timeout: {t} is not a positive number of seconds"
        )));
    }
    let load = LoadOptions {
        include,
        map,
        ..LoadOptions::default()
    };
    let opts = RunOptions {
        seed,
        mode,
        record,
        sut,
        sut_timeout,
        calibration_near_test: true,
        ..RunOptions::default()
    };
    let r = py.detach(move || -> Result<litesim_scenario::RunResult, String> {
        let prep = litesim_scenario::prepare(&test, &load).map_err(|e| e.to_string())?;
        litesim_scenario::run(&prep, &mut litesim_scenario::in_process(), &opts)
            .map_err(|e| e.to_string())
    });
    let r = r.map_err(LitesimError::new_err)?;
    let mut log = r.log;
    if let Some(l) = &mut log {
        l.meta.insert("test".into(), r.summary.test.clone());
        l.meta.insert("seed".into(), r.summary.seed.to_string());
    }
    Ok(NativeRun {
        passed: r.summary.pass,
        failures: r.summary.failures.clone(),
        summary_json: serde_json::to_string(&r.summary).map_err(lerr)?,
        log,
    })
}

// ---------------------------------------------------------------- stepping (gym)

/// A run driven from outside, one step at a time: the run's thread hands
/// each observation out and waits for the command.
enum Event {
    Obs(Box<Observation>),
    Done(Result<Box<litesim_scenario::RunResult>, String>),
}

struct ChannelSut {
    to_env: mpsc::SyncSender<Event>,
    from_env: Arc<Mutex<mpsc::Receiver<SutCommand>>>,
}

impl Sut for ChannelSut {
    fn name(&self) -> String {
        "python:gym".into()
    }
    fn reset(&mut self, _info: &SutInfo) -> Result<(), SutError> {
        Ok(())
    }
    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        self.to_env
            .send(Event::Obs(Box::new(obs.clone())))
            .map_err(|_| SutError("the environment was closed".into()))?;
        let rx = self.from_env.lock().map_err(|_| SutError("lock".into()))?;
        rx.recv()
            .map_err(|_| SutError("the environment was closed".into()))
    }
}

struct ChannelFactory {
    to_env: mpsc::SyncSender<Event>,
    from_env: Arc<Mutex<mpsc::Receiver<SutCommand>>>,
}

impl SutFactory for ChannelFactory {
    fn name(&self) -> String {
        "python:gym".into()
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        Ok(Box::new(ChannelSut {
            to_env: self.to_env.clone(),
            from_env: Arc::clone(&self.from_env),
        }))
    }
}

/// One run stepped by the caller (the gymnasium env's engine).
#[pyclass(name = "SteppedRun", module = "litesim._native")]
struct SteppedRun {
    // A Mutex only to make the pyclass Sync (one caller at a time anyway).
    events: Mutex<mpsc::Receiver<Event>>,
    commands: Option<mpsc::SyncSender<SutCommand>>,
    thread: Option<std::thread::JoinHandle<()>>,
    finished: bool,
}

#[pymethods]
impl SteppedRun {
    /// Starts `test` with `seed`; `first()` gives the first observation.
    #[new]
    #[pyo3(signature = (test, seed=None, mode=None))]
    fn new(test: PathBuf, seed: Option<u64>, mode: Option<&str>) -> PyResult<Self> {
        let mode = mode_of(mode)?;
        let prep = litesim_scenario::prepare(&test, &LoadOptions::default()).map_err(lerr)?;
        let (to_env, events) = mpsc::sync_channel(1);
        let (commands, from_env) = mpsc::sync_channel(1);
        let factory = ChannelFactory {
            to_env: to_env.clone(),
            from_env: Arc::new(Mutex::new(from_env)),
        };
        let opts = RunOptions {
            seed,
            mode,
            record: false,
            sut: SutChoice::External(Arc::new(factory)),
            // The agent may think as long as it likes.
            sut_timeout: Some(1e9),
            ..RunOptions::default()
        };
        let thread = std::thread::spawn(move || {
            let r = litesim_scenario::run(&prep, &mut litesim_scenario::in_process(), &opts)
                .map(Box::new)
                .map_err(|e| e.to_string());
            let _ = to_env.send(Event::Done(r));
        });
        Ok(SteppedRun {
            events: Mutex::new(events),
            commands: Some(commands),
            thread: Some(thread),
            finished: false,
        })
    }

    /// The next event: `("obs", Observation)` or `("done", passed,
    /// failures, summary_json)`.
    fn next<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        if self.finished {
            return Err(LitesimError::new_err(
                "the run is over; reset the environment",
            ));
        }
        let events = &self.events;
        let ev = py.detach(|| match events.lock() {
            Ok(rx) => rx.recv().map_err(|_| ()),
            Err(_) => Err(()),
        });
        match ev {
            Ok(Event::Obs(o)) => Ok(("obs", Py::new(py, PyObservation { obs: *o })?)
                .into_pyobject(py)?
                .into_any()),
            Ok(Event::Done(r)) => {
                self.finished = true;
                if let Some(t) = self.thread.take() {
                    let _ = t.join();
                }
                match r {
                    Ok(r) => Ok((
                        "done",
                        r.summary.pass,
                        r.summary.failures.clone(),
                        serde_json::to_string(&r.summary).map_err(lerr)?,
                    )
                        .into_pyobject(py)?
                        .into_any()),
                    Err(e) => Err(LitesimError::new_err(e)),
                }
            }
            Err(_) => Err(LitesimError::new_err("the run stopped unexpectedly")),
        }
    }

    /// Sends the command for the observation just received.
    fn send(&mut self, command: &Bound<'_, PyAny>) -> PyResult<()> {
        let cmd = command_of(command).map_err(PyValueError::new_err)?;
        match &self.commands {
            Some(c) => c
                .send(cmd)
                .map_err(|_| LitesimError::new_err("the run is over")),
            None => Err(LitesimError::new_err("the run is closed")),
        }
    }

    /// Stops the run (its thread ends at its next step).
    fn close(&mut self, py: Python<'_>) {
        self.commands = None;
        if let Some(t) = self.thread.take() {
            // Drain until the run ends: it fails its next step at once.
            let events = &self.events;
            py.detach(|| {
                drain(events);
                let _ = t.join();
            });
        }
        self.finished = true;
    }
}

/// Receives until the run's end (its SUT fails its next step once the
/// command channel is gone, so the run ends promptly).
fn drain(events: &Mutex<mpsc::Receiver<Event>>) {
    if let Ok(rx) = events.lock() {
        while let Ok(ev) = rx.recv() {
            if matches!(ev, Event::Done(_)) {
                break;
            }
        }
    }
}

impl Drop for SteppedRun {
    fn drop(&mut self) {
        self.commands = None;
        if let Some(t) = self.thread.take() {
            drain(&self.events);
            let _ = t.join();
        }
    }
}

// ---------------------------------------------------------------- batch pieces (Ray)

/// Runs `(test, seed)` jobs and returns each run's result line (the JSON
/// `litesim batch` writes), in job order. Used by `litesim.ray` tasks.
/// Tests are read and named as given (relative to the working folder).
#[pyfunction]
#[pyo3(signature = (jobs, sut=None, mode=None))]
fn run_lines(
    py: Python<'_>,
    jobs: Vec<(String, u64)>,
    sut: Option<&Bound<'_, PyAny>>,
    mode: Option<&str>,
) -> PyResult<Vec<String>> {
    let sut = sut_choice(sut)?;
    let mode = mode_of(mode)?;
    py.detach(move || {
        let mut preps: std::collections::BTreeMap<
            String,
            Result<litesim_scenario::Prepared, String>,
        > = std::collections::BTreeMap::new();
        let base = RunOptions {
            mode,
            sut,
            ..RunOptions::default()
        };
        let mut out = Vec::with_capacity(jobs.len());
        for (test, seed) in &jobs {
            let prep = preps.entry(test.clone()).or_insert_with(|| {
                litesim_scenario::prepare(std::path::Path::new(test), &LoadOptions::default())
                    .map_err(|e| e.chain())
            });
            let line = litesim_scenario::batch::run_line(test, prep, *seed, &base);
            out.push(serde_json::to_string(&line).map_err(lerr)?);
        }
        Ok(out)
    })
}

/// Writes a batch folder exactly as `litesim batch` would (manifest,
/// results.jsonl, results.csv, coverage.json — same sort, same bytes) from
/// result lines computed elsewhere (`run_lines` on Ray workers); jobs
/// without a line run here. Returns (runs, passed, failed).
#[pyfunction]
#[pyo3(signature = (tests, seed_from, seed_to, out, lines, sut=None, mode=None, force_new=false))]
#[allow(clippy::too_many_arguments)]
fn write_batch(
    py: Python<'_>,
    tests: Vec<PathBuf>,
    seed_from: u64,
    seed_to: u64,
    out: PathBuf,
    lines: Vec<String>,
    sut: Option<&Bound<'_, PyAny>>,
    mode: Option<&str>,
    force_new: bool,
) -> PyResult<(u64, u64, u64)> {
    let sut = sut_choice(sut)?;
    let mode = mode_of(mode)?;
    let mut precomputed = std::collections::BTreeMap::new();
    for (i, l) in lines.iter().enumerate() {
        let line: litesim_scenario::batch::RunLine = serde_json::from_str(l)
            .map_err(|e| PyValueError::new_err(format!("lines[{i}]: not a result line: {e}")))?;
        precomputed.insert((line.test.clone(), line.seed), line);
    }
    let spec = litesim_scenario::batch::BatchSpec {
        tests,
        seed_from,
        seed_to,
        shard: (0, 1),
        threads: Some(1),
        out,
        resume: false,
        force_new,
        mode,
        load: LoadOptions::default(),
        calibration_dir: None,
        sut,
        sut_timeout: None,
        save_failed: false,
        save_failed_mcap: false,
        precomputed,
    };
    let report = py
        .detach(|| litesim_scenario::batch::run_batch(&spec, &|_, _| {}))
        .map_err(lerr)?;
    Ok((report.total, report.passed, report.failed))
}

/// The `litesim._native` module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LitesimError", m.py().get_type::<LitesimError>())?;
    m.add_class::<PyObjectState>()?;
    m.add_class::<PyObservation>()?;
    m.add_class::<PyCommand>()?;
    m.add_class::<NativeRun>()?;
    m.add_class::<SteppedRun>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(run_lines, m)?)?;
    m.add_function(wrap_pyfunction!(write_batch, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
