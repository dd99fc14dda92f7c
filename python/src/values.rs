//! What crosses between Python and the run: `ObjectState`,
//! `Observation`, `Command`, and the dicts of lights, roads and run info.

use super::*;

/// One object of the object list (map frame, SI units).
#[pyclass(name = "ObjectState", module = "litesim", frozen, get_all)]
#[derive(Clone)]
pub(super) struct PyObjectState {
    pub(super) id: String,
    pub(super) kind: String,
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) yaw: f64,
    pub(super) speed: f64,
    pub(super) vx: f64,
    pub(super) vy: f64,
    pub(super) acceleration: f64,
    pub(super) length: f64,
    pub(super) width: f64,
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
    pub(super) fn __repr__(&self) -> String {
        format!(
            "ObjectState(id={:?}, kind={:?}, x={:.3}, y={:.3}, yaw={:.4}, speed={:.3})",
            self.id, self.kind, self.x, self.y, self.yaw, self.speed
        )
    }
}

/// What the SUT sees at one step. Fields are converted when read, so a SUT
/// that looks at the ego only pays for the ego.
#[pyclass(name = "Observation", module = "litesim", frozen)]
pub(super) struct PyObservation {
    /// The run's own observation of that step, shared: the run changes its
    /// copy-on-write, so this one never changes (and a SUT that does not
    /// keep it costs no copy).
    pub(super) obs: Arc<Observation>,
}

#[pymethods]
impl PyObservation {
    /// Step index.
    #[getter]
    pub(super) fn tick(&self) -> u64 {
        self.obs.tick
    }
    /// Simulation time (s).
    #[getter]
    pub(super) fn time(&self) -> f64 {
        self.obs.time
    }
    /// The ego (`sut.car`).
    #[getter]
    pub(super) fn ego(&self) -> PyObjectState {
        (&self.obs.ego).into()
    }
    /// Every other actor.
    #[getter]
    pub(super) fn objects(&self) -> Vec<PyObjectState> {
        self.obs.objects.iter().map(Into::into).collect()
    }
    /// Traffic light boxes: dicts with id, road, s, color.
    #[getter]
    pub(super) fn lights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for l in &self.obs.lights {
            out.append(light_dict(py, l)?)?;
        }
        Ok(out)
    }
    /// The ego's road position (dict: road, lane, s, offset) or None.
    #[getter]
    pub(super) fn road<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.obs.road.as_ref().map(|r| road_dict(py, r)).transpose()
    }
    /// Speed the scenario asks of the ego now (m/s).
    #[getter]
    pub(super) fn requested_speed(&self) -> f64 {
        self.obs.requested_speed
    }
    /// Distance to the route's goal along the route (m).
    #[getter]
    pub(super) fn distance_to_goal(&self) -> f64 {
        self.obs.distance_to_goal
    }
    /// The whole observation as JSON (the gRPC SUT service's fields).
    pub(super) fn to_json(&self) -> String {
        serde_json::to_string(&self.obs).unwrap_or_default()
    }
    pub(super) fn __repr__(&self) -> String {
        format!(
            "Observation(tick={}, time={:.3}, ego={}, objects={})",
            self.obs.tick,
            self.obs.time,
            self.obs.ego.id,
            self.obs.objects.len()
        )
    }
}

pub(super) fn light_dict<'py>(py: Python<'py>, l: &LightState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("id", &l.id)?;
    d.set_item("road", &l.road)?;
    d.set_item("s", l.s)?;
    d.set_item("color", &l.color)?;
    Ok(d)
}

pub(super) fn road_dict<'py>(py: Python<'py>, r: &RoadPos) -> PyResult<Bound<'py, PyDict>> {
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
pub(super) struct PyCommand {
    pub(super) cmd: SutCommand,
}

#[pymethods]
impl PyCommand {
    /// Normalised pedals 0..1 and steering −1..1 (+ = left).
    #[staticmethod]
    #[pyo3(signature = (throttle=0.0, brake=0.0, steering=0.0))]
    pub(super) fn pedals(throttle: f64, brake: f64, steering: f64) -> PyResult<Self> {
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
    pub(super) fn accel(acceleration: f64, curvature: f64, reverse: bool) -> PyResult<Self> {
        checked(SutCommand::Accel {
            acceleration,
            curvature,
            reverse,
        })
    }
    /// Drive and brake force (N) and steering-wheel angle (rad).
    #[staticmethod]
    #[pyo3(signature = (drive_force_n=0.0, brake_force_n=0.0, steering_wheel_angle_rad=0.0))]
    pub(super) fn physical(
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
    pub(super) fn __repr__(&self) -> String {
        format!(
            "Command({})",
            serde_json::to_string(&self.cmd).unwrap_or_default()
        )
    }
}

pub(super) fn checked(cmd: SutCommand) -> PyResult<PyCommand> {
    cmd.validate()
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(PyCommand { cmd })
}

/// What a Python SUT's `step` returned, as a command: a `Command`, or a
/// dict with throttle/brake/steering or acceleration/curvature keys.
pub(super) fn command_of(v: &Bound<'_, PyAny>) -> Result<SutCommand, String> {
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
        let reverse =
            match d.get_item("reverse").map_err(|e| e.to_string())? {
                None => None,
                Some(x) => Some(x.extract::<bool>().map_err(|_| {
                    "step() returned a dict whose 'reverse' is not a bool".to_string()
                })?),
            };
        let cmd =
            if get("acceleration")?.is_some() || get("curvature")?.is_some() || reverse.is_some() {
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

pub(super) fn info_dict<'py>(py: Python<'py>, info: &SutInfo) -> PyResult<Bound<'py, PyDict>> {
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
