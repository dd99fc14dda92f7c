//! Runs from Python: `run` (the whole run, its SUT a Python object),
//! `SteppedRun` (the caller steps it: `ScenarioEnv`), `Episodes`, and
//! batch lines.

use super::*;

/// The outcome of one run (see `litesim.run`).
#[pyclass(name = "NativeRun", module = "litesim._native", frozen)]
pub(super) struct NativeRun {
    #[pyo3(get)]
    pub(super) passed: bool,
    /// `pass`, `fail`, `invalid` or `error`.
    #[pyo3(get)]
    pub(super) verdict: &'static str,
    #[pyo3(get)]
    pub(super) failures: Vec<String>,
    /// The summary as JSON (parsed by the Python side).
    #[pyo3(get)]
    pub(super) summary_json: String,
    pub(super) log: Option<litesim_log::SimulationLog>,
}

#[pymethods]
impl NativeRun {
    /// The log in long form: one row per actor and tick, as a dict of
    /// column name → list (None when the run did not record).
    pub(super) fn log_columns<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
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
    pub(super) fn log_json(&self) -> PyResult<Option<String>> {
        self.log
            .as_ref()
            .map(|l| serde_json::to_string(l).map_err(lerr))
            .transpose()
    }
}

/// A test read, checked and elaborated, its map loaded (`litesim.prepare`):
/// what every run of it shares, made once. Runs of a prepared test skip the
/// front end and the map (the batch's "prepared runs", for a caller that
/// runs the same test many times).
#[pyclass(name = "PreparedTest", module = "litesim._native", frozen)]
pub(super) struct PreparedTest {
    pub(super) prep: Arc<litesim_scenario::Prepared>,
}

#[pymethods]
impl PreparedTest {
    /// The test file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.prep.path.clone()
    }

    /// SHA-256 of the test's sources as read (the file and its imports).
    #[getter]
    fn source_hash(&self) -> String {
        self.prep.source_hash.clone()
    }
}

/// Reads, checks and elaborates `test` and loads its map (see
/// `litesim.prepare`).
#[pyfunction]
#[pyo3(signature = (test, map=None, include=Vec::new(), dialect=None, map_dir=None))]
pub(super) fn prepare(
    py: Python<'_>,
    test: PathBuf,
    map: Option<PathBuf>,
    include: Vec<PathBuf>,
    dialect: Option<&str>,
    map_dir: Option<PathBuf>,
) -> PyResult<PreparedTest> {
    let dialect = dialect
        .map(|d| d.parse::<litesim_osc::Dialect>())
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("dialect: {e}")))?;
    let load = LoadOptions {
        include,
        map,
        dialect,
        map_dir,
        ..LoadOptions::default()
    };
    let prep = py
        .detach(move || litesim_scenario::prepare(&test, &load).map_err(|e| e.chain()))
        .map_err(LitesimError::new_err)?;
    Ok(PreparedTest {
        prep: Arc::new(prep),
    })
}

/// Runs one test (see `litesim.run` for the parameters): `test` is a path
/// (prepared for this run) or a [`PreparedTest`] (then the load options
/// must be left unset: they were the preparation's).
#[pyfunction]
#[pyo3(signature = (test, seed=None, sut=None, mode=None, record=true, map=None, include=Vec::new(), sut_timeout=None, dialect=None, map_dir=None, npc="driver"))]
#[allow(clippy::too_many_arguments)]
pub(super) fn run(
    py: Python<'_>,
    test: &Bound<'_, PyAny>,
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
    let prepared = match test.cast::<PreparedTest>() {
        Ok(p) => {
            let set = [
                ("map", map.is_some()),
                ("include", !include.is_empty()),
                ("dialect", dialect.is_some()),
                ("map_dir", map_dir.is_some()),
            ];
            if let Some((name, _)) = set.iter().find(|(_, on)| *on) {
                return Err(PyValueError::new_err(format!(
                    "{name}: a prepared test was read with its own load options; \
                     give {name} to litesim.prepare instead"
                )));
            }
            Some(Arc::clone(&p.get().prep))
        }
        Err(_) => None,
    };
    let (sut, python_sut) = python_sut_choice(sut)?;
    let mode = mode_of(mode)?;
    if let Some(t) = sut_timeout
        && !(t.is_finite() && t > 0.0)
    {
        return Err(PyValueError::new_err(format!(
            "sut_timeout: {t} is not a positive number of seconds"
        )));
    }
    let prep = match prepared {
        Some(p) => p,
        None => {
            let path: PathBuf = test.extract()?;
            prepare(py, path, map, include, dialect, map_dir)?.prep
        }
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
    let go = move || -> Result<litesim_scenario::RunResult, String> {
        litesim_scenario::run(&prep, &mut litesim_scenario::in_process(), &opts)
            .map_err(|e| e.chain())
    };
    // A Python SUT is called every step: the run keeps the interpreter
    // rather than giving it up and taking it back around each call (an
    // eighth of what a call cost). Other Python threads still run: the
    // SUT's own code hands the interpreter over at Python's switch
    // interval, as any Python code does. The run is on this thread alone
    // (the in-process simulator starts none), so nothing waits for the
    // interpreter it holds. Any other run gives it up throughout.
    let r = if python_sut { go() } else { py.detach(go) };
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
pub(super) struct SteppedRun {
    pub(super) run: Owned<Stepped>,
    /// An observation was handed out and waits for its command.
    pub(super) waiting: bool,
    pub(super) finished: bool,
}

#[pymethods]
impl SteppedRun {
    /// Starts `test` with `seed`; `next()` gives the first observation.
    #[new]
    #[pyo3(signature = (test, seed=None, mode=None))]
    pub(super) fn new(test: PathBuf, seed: Option<u64>, mode: Option<&str>) -> PyResult<Self> {
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
    pub(super) fn next<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
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
            let obs = PyObservation { obs: Arc::clone(o) };
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
    pub(super) fn send(&mut self, command: &Bound<'_, PyAny>) -> PyResult<()> {
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
    pub(super) fn close(&mut self) {
        self.finished = true;
    }
}

/// A value only ever used through `&mut self` (a pyclass's state): the
/// Mutex makes the class `Sync` as pyo3 asks, and `get_mut` reaches the
/// value without locking (the borrow proves no one else holds it).
pub(super) struct Owned<T>(Mutex<T>);

impl<T> Owned<T> {
    pub(super) fn new(v: T) -> Self {
        Owned(Mutex::new(v))
    }
    pub(super) fn get(&mut self) -> &mut T {
        self.0
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// A stepped run's options: the caller is the SUT and may think as long
/// as it likes; nothing is recorded.
pub(super) fn stepped_options(seed: Option<u64>, mode: Option<DriveMode>) -> RunOptions {
    RunOptions {
        seed,
        mode,
        record: false,
        sut: SutChoice::External(Arc::new(Outside)),
        sut_timeout: Some(1e9),
        ..RunOptions::default()
    }
}

/// The gymnasium environment's engine: a test prepared once (parsed,
/// elaborated, its map loaded), then episodes of it, each a [`Stepped`]
/// run. Observations are encoded here, straight into a numpy array (the
/// layout `litesim.gym` documents), and the reward computed: an
/// environment step is one call.
#[pyclass(name = "Episodes", module = "litesim._native")]
pub(super) struct Episodes {
    pub(super) prep: Arc<litesim_scenario::Prepared>,
    pub(super) mode: Option<DriveMode>,
    pub(super) max_objects: usize,
    pub(super) run: Option<Owned<Stepped>>,
    /// The last observation's (time, encoded rows).
    pub(super) last: Option<(f64, Vec<f32>)>,
}

/// Python's `BIG`: observation entries are clipped to ±BIG.
pub(super) const BIG: f32 = 1e6;

/// The observation as (1 + max_objects) rows of 6, row-major.
pub(super) fn encode(o: &Observation, max_objects: usize) -> Vec<f32> {
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
pub(super) fn array<'py>(py: Python<'py>, rows: &[f32]) -> PyResult<Bound<'py, PyAny>> {
    use numpy::PyArrayMethods;
    let a = numpy::PyArray1::from_slice(py, rows);
    Ok(a.reshape([rows.len() / 6, 6])?.into_any())
}

#[pymethods]
impl Episodes {
    /// Prepares `test` once for all its episodes.
    #[new]
    #[pyo3(signature = (test, mode=None, max_objects=8))]
    pub(super) fn new(test: PathBuf, mode: Option<&str>, max_objects: usize) -> PyResult<Self> {
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
    pub(super) fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: u64,
    ) -> PyResult<(Bound<'py, PyAny>, f64)> {
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
    pub(super) fn step<'py>(
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
    pub(super) fn close(&mut self) {
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
pub(super) fn run_lines(
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
pub(super) fn write_batch(
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
        step_ms: None,
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
