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
use litesim_scenario::{DriveMode, LoadOptions, RunOptions, Stepped};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

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
/// `Command.accel(acceleration, curvature, reverse=False)` or
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
    /// Target acceleration (m/s², along the direction of travel) and the
    /// wheels' curvature (1/m, + = left); `reverse=True` drives backwards
    /// (the vehicle is braked to rest before the gear changes).
    #[staticmethod]
    #[pyo3(signature = (acceleration=0.0, curvature=0.0, reverse=false))]
    fn accel(acceleration: f64, curvature: f64, reverse: bool) -> PyResult<Self> {
        checked(SutCommand::Accel {
            acceleration,
            curvature,
            reverse,
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
        let reverse = match d.get_item("reverse").map_err(|e| e.to_string())? {
            None => None,
            Some(x) => Some(
                x.extract::<bool>()
                    .map_err(|_| "step() returned a dict whose 'reverse' is not a bool".to_string())?,
            ),
        };
        let cmd = if get("acceleration")?.is_some()
            || get("curvature")?.is_some()
            || reverse.is_some()
        {
            SutCommand::Accel {
                acceleration: get("acceleration")?.unwrap_or(0.0),
                curvature: get("curvature")?.unwrap_or(0.0),
                reverse: reverse.unwrap_or(false),
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
        if let Some(c) = litesim_grpc::sut::choice_by_name(&name)
            .map_err(|e| PyValueError::new_err(format!("sut: {}", e.0)))?
        {
            return Ok(c);
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
    /// `pass`, `fail`, `invalid` or `error`.
    #[pyo3(get)]
    verdict: &'static str,
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
#[pyo3(signature = (test, seed=None, sut=None, mode=None, record=true, map=None, include=Vec::new(), sut_timeout=None, dialect=None, map_dir=None, npc="driver"))]
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
    dialect: Option<&str>,
    map_dir: Option<PathBuf>,
    npc: &str,
) -> PyResult<NativeRun> {
    let npc = litesim_scenario::Npc::parse(npc).ok_or_else(|| {
        PyValueError::new_err(format!("npc: expected 'driver' or 'planned', got '{npc}'"))
    })?;
    let dialect = dialect
        .map(|d| d.parse::<litesim_osc::Dialect>())
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("dialect: {e}")))?;
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
        dialect,
        map_dir,
        ..LoadOptions::default()
    };
    let opts = RunOptions {
        seed,
        mode,
        record,
        sut,
        npc,
        sut_timeout,
        calibration_near_test: true,
        ..RunOptions::default()
    };
    let r = py.detach(move || -> Result<litesim_scenario::RunResult, String> {
        let prep = litesim_scenario::prepare(&test, &load).map_err(|e| e.chain())?;
        litesim_scenario::run(&prep, &mut litesim_scenario::in_process(), &opts)
            .map_err(|e| e.chain())
    });
    let r = r.map_err(LitesimError::new_err)?;
    let mut log = r.log;
    if let Some(l) = &mut log {
        l.meta.insert("test".into(), r.summary.test.clone());
        l.meta.insert("seed".into(), r.summary.seed.to_string());
    }
    Ok(NativeRun {
        passed: r.summary.pass,
        verdict: r.summary.verdict.name(),
        failures: r.summary.failures.clone(),
        summary_json: serde_json::to_string(&r.summary).map_err(lerr)?,
        log,
    })
}

// ---------------------------------------------------------------- stepping (gym)

/// A run driven from outside, one step at a time, on the caller's thread:
/// the run lives in this object ([`Stepped`]), so a step is a call, not a
/// hand-over between threads.
#[pyclass(name = "SteppedRun", module = "litesim._native")]
struct SteppedRun {
    run: Owned<Stepped>,
    /// An observation was handed out and waits for its command.
    waiting: bool,
    finished: bool,
}

#[pymethods]
impl SteppedRun {
    /// Starts `test` with `seed`; `next()` gives the first observation.
    #[new]
    #[pyo3(signature = (test, seed=None, mode=None))]
    fn new(test: PathBuf, seed: Option<u64>, mode: Option<&str>) -> PyResult<Self> {
        let mode = mode_of(mode)?;
        let prep = litesim_scenario::prepare(&test, &LoadOptions::default()).map_err(lerr)?;
        let opts = stepped_options(seed, mode);
        Ok(SteppedRun {
            run: Owned::new(Stepped::start(Arc::new(prep), &opts).map_err(lerr)?),
            waiting: false,
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
        if self.waiting {
            return Err(LitesimError::new_err(
                "send() the command for the last observation first",
            ));
        }
        let run = self.run.get();
        if let Some(o) = run.observation().map_err(lerr)? {
            self.waiting = true;
            let obs = PyObservation { obs: o.clone() };
            return Ok(("obs", Py::new(py, obs)?).into_pyobject(py)?.into_any());
        }
        self.finished = true;
        let r = run.finish().map_err(lerr)?;
        Ok((
            "done",
            r.summary.pass,
            r.summary.failures.clone(),
            serde_json::to_string(&r.summary).map_err(lerr)?,
        )
            .into_pyobject(py)?
            .into_any())
    }

    /// Sends the command for the observation just received (the step runs).
    fn send(&mut self, command: &Bound<'_, PyAny>) -> PyResult<()> {
        let cmd = command_of(command).map_err(PyValueError::new_err)?;
        if self.finished {
            return Err(LitesimError::new_err("the run is over"));
        }
        if !self.waiting {
            return Err(LitesimError::new_err(
                "next() gives the observation to answer first",
            ));
        }
        self.waiting = false;
        self.run.get().step(cmd).map_err(lerr)?;
        Ok(())
    }

    /// Stops the run.
    fn close(&mut self) {
        self.finished = true;
    }
}

/// A value only ever used through `&mut self` (a pyclass's state): the
/// Mutex makes the class `Sync` as pyo3 asks, and `get_mut` reaches the
/// value without locking (the borrow proves no one else holds it).
struct Owned<T>(Mutex<T>);

impl<T> Owned<T> {
    fn new(v: T) -> Self {
        Owned(Mutex::new(v))
    }
    fn get(&mut self) -> &mut T {
        self.0
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// A stepped run's options: the caller is the SUT and may think as long
/// as it likes; nothing is recorded.
fn stepped_options(seed: Option<u64>, mode: Option<DriveMode>) -> RunOptions {
    RunOptions {
        seed,
        mode,
        record: false,
        sut: SutChoice::External(Arc::new(Outside)),
        sut_timeout: Some(1e9),
        ..RunOptions::default()
    }
}

/// The name a stepped run's SUT has in summaries (the run never calls
/// it: the caller gives each command).
struct Outside;

impl SutFactory for Outside {
    fn name(&self) -> String {
        "python:gym".into()
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        Err(SutError("a stepped run's SUT is its caller".into()))
    }
}

/// The gymnasium environment's engine: a test prepared once (parsed,
/// elaborated, its map loaded), then episodes of it, each a [`Stepped`]
/// run. Observations are encoded here, straight into a numpy array (the
/// layout `litesim.gym` documents), and the reward computed: an
/// environment step is one call.
#[pyclass(name = "Episodes", module = "litesim._native")]
struct Episodes {
    prep: Arc<litesim_scenario::Prepared>,
    mode: Option<DriveMode>,
    max_objects: usize,
    run: Option<Owned<Stepped>>,
    /// The last observation's (time, encoded rows).
    last: Option<(f64, Vec<f32>)>,
}

/// Python's `BIG`: observation entries are clipped to ±BIG.
const BIG: f32 = 1e6;

/// The observation as (1 + max_objects) rows of 6, row-major.
fn encode(o: &Observation, max_objects: usize) -> Vec<f32> {
    let rows = 1 + max_objects;
    let mut out = vec![0.0f32; rows * 6];
    let e = &o.ego;
    let goal = if o.distance_to_goal.is_finite() {
        o.distance_to_goal.min(1000.0)
    } else {
        1000.0
    };
    let offset = o.road.as_ref().map_or(0.0, |r| r.offset);
    let row0 = [e.speed, o.requested_speed, goal, offset, e.length, e.width];
    for (k, v) in row0.into_iter().enumerate() {
        out[k] = v as f32;
    }
    let (c, s) = (e.yaw.cos(), e.yaw.sin());
    // Nearest first; a stable sort keeps equal distances in the
    // observation's order.
    let mut near: Vec<(f64, &ObjectState)> = o
        .objects
        .iter()
        .map(|a| ((a.x - e.x).powi(2) + (a.y - e.y).powi(2), a))
        .collect();
    near.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (i, (_, a)) in near.iter().take(max_objects).enumerate() {
        let (dx, dy) = (a.x - e.x, a.y - e.y);
        let d = a.yaw - e.yaw;
        let dyaw = d.sin().atan2(d.cos());
        let row = [
            1.0,
            dx * c + dy * s,
            -dx * s + dy * c,
            dyaw,
            a.speed,
            a.length,
        ];
        for (k, v) in row.into_iter().enumerate() {
            out[(1 + i) * 6 + k] = v as f32;
        }
    }
    for v in &mut out {
        *v = if v.is_nan() { *v } else { v.clamp(-BIG, BIG) };
    }
    out
}

/// Encoded rows as a (rows, 6) float32 array.
fn array<'py>(py: Python<'py>, rows: &[f32]) -> PyResult<Bound<'py, PyAny>> {
    use numpy::PyArrayMethods;
    let a = numpy::PyArray1::from_slice(py, rows);
    Ok(a.reshape([rows.len() / 6, 6])?.into_any())
}

#[pymethods]
impl Episodes {
    /// Prepares `test` once for all its episodes.
    #[new]
    #[pyo3(signature = (test, mode=None, max_objects=8))]
    fn new(test: PathBuf, mode: Option<&str>, max_objects: usize) -> PyResult<Self> {
        let mode = mode_of(mode)?;
        let prep = litesim_scenario::prepare(&test, &LoadOptions::default()).map_err(lerr)?;
        Ok(Episodes {
            prep: Arc::new(prep),
            mode,
            max_objects,
            run: None,
            last: None,
        })
    }

    /// A new episode with `seed`: its first observation and time.
    fn reset<'py>(&mut self, py: Python<'py>, seed: u64) -> PyResult<(Bound<'py, PyAny>, f64)> {
        let opts = stepped_options(Some(seed), self.mode);
        let mut run = Stepped::start(Arc::clone(&self.prep), &opts).map_err(lerr)?;
        let Some(o) = run.observation().map_err(lerr)? else {
            let why = run
                .finish()
                .map(|r| {
                    let mut why = r.summary.failures;
                    why.extend(r.summary.invalid);
                    format!("{}: {}", r.summary.verdict.name(), why.join("; "))
                })
                .unwrap_or_else(|e| e.to_string());
            return Err(LitesimError::new_err(format!(
                "the run ended before its first step: {why}"
            )));
        };
        let (t, rows) = (o.time, encode(o, self.max_objects));
        let a = array(py, &rows)?;
        self.last = Some((t, rows));
        self.run = Some(Owned::new(run));
        Ok((a, t))
    }

    /// One step with pedals (throttle 0..1, brake 0..1, steering -1..1,
    /// already clipped): (observation, reward, terminated, info), info
    /// `{"time": t}` or at the end `{"passed": …, "failures": […]}`.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        throttle: f64,
        brake: f64,
        steering: f64,
    ) -> PyResult<(Bound<'py, PyAny>, f64, bool, Bound<'py, PyDict>)> {
        let max_objects = self.max_objects;
        let (Some(run), Some((t0, _))) = (self.run.as_mut(), self.last.as_ref()) else {
            return Err(PyRuntimeError::new_err("call reset() before step()"));
        };
        let (t0, run) = (*t0, run.get());
        let cmd = SutCommand::Pedals {
            throttle,
            brake,
            steering,
        };
        run.step(cmd).map_err(lerr)?;
        let info = PyDict::new(py);
        if let Some(o) = run.observation().map_err(lerr)? {
            let dt = (o.time - t0).max(0.0);
            let over = (o.ego.speed - o.requested_speed.max(0.0)).max(0.0);
            let reward = (o.ego.speed - 2.0 * over) * dt;
            let (t, rows) = (o.time, encode(o, max_objects));
            let a = array(py, &rows)?;
            info.set_item("time", t)?;
            self.last = Some((t, rows));
            return Ok((a, reward, false, info));
        }
        let r = run.finish().map_err(lerr)?;
        self.run = None;
        let (_, rows) = self.last.take().unwrap_or_default();
        let a = array(py, &rows)?;
        info.set_item("passed", r.summary.pass)?;
        info.set_item("failures", r.summary.failures.clone())?;
        info.set_item("verdict", r.summary.verdict.name())?;
        info.set_item("invalid", r.summary.invalid.clone())?;
        let reward = if r.summary.pass { 0.0 } else { -100.0 };
        Ok((a, reward, true, info))
    }

    /// Ends the episode under way, if any.
    fn close(&mut self) {
        self.run = None;
        self.last = None;
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
/// without a line run here. Returns (runs, passed, failed, the most severe
/// verdict).
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
) -> PyResult<(u64, u64, u64, &'static str)> {
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
        npc: litesim_scenario::Npc::default(),
        sut_timeout: None,
        save_failed: false,
        save_failed_mcap: false,
        precomputed,
    };
    let report = py
        .detach(|| litesim_scenario::batch::run_batch(&spec, &|_, _| {}))
        .map_err(lerr)?;
    Ok((
        report.total,
        report.passed,
        report.failed,
        report.verdict.name(),
    ))
}

// ---------------------------------------------------------------- the SSP API in-process

fn ssp_err(e: litesim_ssp::SspError) -> PyErr {
    LitesimError::new_err(e.to_string())
}

fn finite_arg(name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(PyValueError::new_err(format!(
            "{name}: {v} is not a finite number"
        )))
    }
}

/// The simulator-support API in this process (the same `Session` the
/// gRPC server runs): create actors, command them, step, read states. For
/// people who write their own orchestrator. Batch paths take and give
/// numpy arrays.
#[pyclass(name = "Simulator", module = "litesim")]
struct Simulator {
    session: litesim_ssp::Session,
    step_ms: u32,
}

#[pymethods]
impl Simulator {
    /// A session of `profile` (see `litesim profiles`) stepping `step_ms`
    /// (None: the profile's default), seeded, optionally on an OpenDRIVE map.
    #[new]
    #[pyo3(signature = (profile="dummy", step_ms=None, seed=0, map=None))]
    fn new(profile: &str, step_ms: Option<u32>, seed: u64, map: Option<String>) -> PyResult<Self> {
        use litesim_ssp::Ssp;
        let mut session =
            litesim_ssp::Session::new("dummy", "dummy", litesim_ssp::SessionLimits::default());
        let init = session
            .init(litesim_ssp::InitRequest {
                client_name: "litesim-python".into(),
                step_size_ms: step_ms.unwrap_or(0),
                profile: profile.to_string(),
                seed,
                map,
                ..litesim_ssp::InitRequest::default()
            })
            .map_err(ssp_err)?;
        session.start_simulation(0).map_err(ssp_err)?;
        session.wait_start_simulation(1000).map_err(ssp_err)?;
        let step_ms = step_ms.unwrap_or(init.capabilities.step_size_ms);
        Ok(Simulator { session, step_ms })
    }

    /// The step (ms).
    #[getter]
    fn step_ms(&self) -> u32 {
        self.step_ms
    }

    /// Creates an actor at (x, y) heading `yaw` (rad) moving at `speed`
    /// (m/s); `kind`: Vehicle, Pedestrian, …; `model`: a catalogue blueprint.
    /// Returns the description used (dict: model, length, width, height).
    #[pyo3(signature = (actor_id, x, y, yaw=0.0, speed=0.0, kind="Vehicle", model=None))]
    #[allow(clippy::too_many_arguments)]
    fn create_actor<'py>(
        &mut self,
        py: Python<'py>,
        actor_id: &str,
        x: f64,
        y: f64,
        yaw: f64,
        speed: f64,
        kind: &str,
        model: Option<String>,
    ) -> PyResult<Bound<'py, PyDict>> {
        use litesim_ssp::Ssp;
        let (x, y, yaw, speed) = (
            finite_arg("x", x)?,
            finite_arg("y", y)?,
            finite_arg("yaw", yaw)?,
            finite_arg("speed", speed)?,
        );
        let category = match kind.to_ascii_lowercase().as_str() {
            "pedestrian" | "person" => litesim_ssp::ActorCategory::Pedestrian,
            _ => litesim_ssp::ActorCategory::default(),
        };
        let d = self
            .session
            .create_actor(litesim_ssp::CreateActor {
                actor_id: actor_id.into(),
                spec: litesim_ssp::ActorSpec {
                    actor_type: kind.into(),
                    category,
                    model_id: model.unwrap_or_default(),
                    ..litesim_ssp::ActorSpec::default()
                },
                position: litesim_ssp::Coord6::xy_yaw(x, y, yaw),
                speed: litesim_ssp::Coord6 {
                    x: Some(speed * litesim_core::math::cos(yaw)),
                    y: Some(speed * litesim_core::math::sin(yaw)),
                    ..litesim_ssp::Coord6::default()
                },
                ..litesim_ssp::CreateActor::default()
            })
            .map_err(ssp_err)?;
        let out = PyDict::new(py);
        out.set_item("model", d.model_id)?;
        out.set_item("length", d.length)?;
        out.set_item("width", d.width)?;
        out.set_item("height", d.height)?;
        Ok(out)
    }

    /// Pedals 0..1 and steering −1..1 for one actor, until replaced.
    fn set_pedals(
        &mut self,
        actor_id: &str,
        throttle: f64,
        brake: f64,
        steering: f64,
    ) -> PyResult<()> {
        use litesim_ssp::Ssp;
        self.session
            .set_dynamic_move(
                actor_id,
                litesim_ssp::DynamicMove::Normalized {
                    throttle,
                    brake,
                    steering,
                },
                0,
            )
            .map_err(ssp_err)
    }

    /// Pedals for many actors at once (numpy arrays, one entry per id).
    fn set_pedals_many(
        &mut self,
        actor_ids: Vec<String>,
        throttle: numpy::PyReadonlyArray1<'_, f64>,
        brake: numpy::PyReadonlyArray1<'_, f64>,
        steering: numpy::PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        let (t, b, s) = (
            throttle.as_slice()?,
            brake.as_slice()?,
            steering.as_slice()?,
        );
        if t.len() != actor_ids.len() || b.len() != actor_ids.len() || s.len() != actor_ids.len() {
            return Err(PyValueError::new_err(format!(
                "throttle/brake/steering: {} / {} / {} values for {} actor_ids",
                t.len(),
                b.len(),
                s.len(),
                actor_ids.len()
            )));
        }
        for (i, id) in actor_ids.iter().enumerate() {
            self.set_pedals(id, t[i], b[i], s[i])?;
        }
        Ok(())
    }

    /// Target acceleration (m/s²) and road-wheel angle (rad), until replaced.
    fn set_accel(
        &mut self,
        actor_id: &str,
        acceleration: f64,
        steering_angle: f64,
    ) -> PyResult<()> {
        use litesim_ssp::Ssp;
        self.session
            .set_dynamic_move(
                actor_id,
                litesim_ssp::DynamicMove::Direct {
                    acceleration,
                    steering_angle_rad: steering_angle,
                },
                0,
            )
            .map_err(ssp_err)
    }

    /// A kinematic move through (x, y) points timed `t` (s, increasing; numpy arrays).
    fn set_trajectory(
        &mut self,
        actor_id: &str,
        t: numpy::PyReadonlyArray1<'_, f64>,
        x: numpy::PyReadonlyArray1<'_, f64>,
        y: numpy::PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        use litesim_ssp::Ssp;
        let (t, x, y) = (t.as_slice()?, x.as_slice()?, y.as_slice()?);
        if t.len() != x.len() || t.len() != y.len() || t.len() < 2 {
            return Err(PyValueError::new_err(format!(
                "t/x/y: {} / {} / {} values; expected the same number, at least 2",
                t.len(),
                x.len(),
                y.len()
            )));
        }
        let mut times = Vec::with_capacity(t.len());
        for (i, v) in t.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) || (i > 0 && *v <= t[i - 1]) {
                return Err(PyValueError::new_err(format!(
                    "t[{i}] = {v}: times must be finite, ≥ 0 and increasing"
                )));
            }
            times.push((v * 1000.0).round() as u64);
        }
        let points = x
            .iter()
            .zip(y)
            .map(|(x, y)| litesim_ssp::Coord6 {
                x: Some(*x),
                y: Some(*y),
                ..litesim_ssp::Coord6::default()
            })
            .collect();
        self.session
            .set_xy_trajectory(
                actor_id,
                litesim_ssp::XyTrajectory {
                    start_time_ms: times[0],
                    end_time_ms: times[times.len() - 1],
                    points,
                    point_times_ms: times,
                    ..litesim_ssp::XyTrajectory::default()
                },
            )
            .map_err(ssp_err)
    }

    /// Steps `n` times; returns the simulation time (s).
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<f64> {
        use litesim_ssp::Ssp;
        let session = &mut self.session;
        py.detach(|| -> Result<f64, litesim_ssp::SspError> {
            let mut ms = 0;
            for _ in 0..n {
                session.start_step(None)?;
                ms = session.wait_step(0)?.sim_time_ms;
            }
            Ok(ms as f64 / 1000.0)
        })
        .map_err(ssp_err)
    }

    /// Every actor's state, in creation order: a dict of numpy arrays (x, y,
    /// yaw, speed, vx, vy, yaw_rate) and the list of ids.
    fn states<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        use litesim_ssp::Ssp;
        let st = self
            .session
            .get_actors_states(&litesim_ssp::ActorFilter::default())
            .map_err(ssp_err)?;
        let out = PyDict::new(py);
        let col =
            |f: &dyn Fn(&litesim_ssp::ReportedState) -> f64| st.iter().map(f).collect::<Vec<f64>>();
        out.set_item(
            "id",
            st.iter()
                .map(|s| s.actor_id.to_string())
                .collect::<Vec<_>>(),
        )?;
        for (k, v) in [
            ("x", col(&|s| s.pose.position.x)),
            ("y", col(&|s| s.pose.position.y)),
            ("yaw", col(&|s| s.pose.yaw)),
            ("speed", col(&|s| s.speed)),
            ("vx", col(&|s| s.velocity.x)),
            ("vy", col(&|s| s.velocity.y)),
            ("yaw_rate", col(&|s| s.yaw_rate)),
        ] {
            out.set_item(k, numpy::PyArray1::from_vec(py, v))?;
        }
        Ok(out)
    }

    /// Ends the simulation; returns the steps run.
    fn close(&mut self) -> PyResult<u64> {
        use litesim_ssp::Ssp;
        self.session
            .end_simulation("closed from Python")
            .map_err(ssp_err)
    }
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
    m.add_class::<Episodes>()?;
    m.add_class::<Simulator>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(run_lines, m)?)?;
    m.add_function(wrap_pyfunction!(write_batch, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
