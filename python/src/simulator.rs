//! `litesim.Simulator`: the Model SSP session, driven call by call.

use super::*;

pub(super) fn ssp_err(e: litesim_ssp::SspError) -> PyErr {
    LitesimError::new_err(e.to_string())
}

pub(super) fn finite_arg(name: &str, v: f64) -> PyResult<f64> {
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
pub(super) struct Simulator {
    pub(super) session: litesim_ssp::Session,
    pub(super) step_ms: u32,
}

#[pymethods]
impl Simulator {
    /// A session of `profile` (see `litesim profiles`) stepping `step_ms`
    /// (None: the profile's default), seeded, optionally on an OpenDRIVE map.
    #[new]
    #[pyo3(signature = (profile="dummy", step_ms=None, seed=0, map=None))]
    pub(super) fn new(
        profile: &str,
        step_ms: Option<u32>,
        seed: u64,
        map: Option<String>,
    ) -> PyResult<Self> {
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
    pub(super) fn step_ms(&self) -> u32 {
        self.step_ms
    }

    /// Creates an actor at (x, y) heading `yaw` (rad) moving at `speed`
    /// (m/s); `kind`: Vehicle, Pedestrian, …; `model`: a catalogue blueprint.
    /// Returns the description used (dict: model, length, width, height).
    #[pyo3(signature = (actor_id, x, y, yaw=0.0, speed=0.0, kind="Vehicle", model=None))]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn create_actor<'py>(
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
    pub(super) fn set_pedals(
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
    pub(super) fn set_pedals_many(
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
    pub(super) fn set_accel(
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
    pub(super) fn set_trajectory(
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
    pub(super) fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<f64> {
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
    pub(super) fn states<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
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
    pub(super) fn close(&mut self) -> PyResult<u64> {
        use litesim_ssp::Ssp;
        self.session
            .end_simulation("closed from Python")
            .map_err(ssp_err)
    }
}
