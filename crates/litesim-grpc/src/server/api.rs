//! The API's calls: each `SimulatorSupport` method on the session it
//! names, with the streaming step and move calls.

use super::*;

#[derive(Serialize)]
pub(super) struct StreamOut {
    pub(super) seq: u64,
    pub(super) sim_time_ms: u64,
    pub(super) step_index: u64,
    pub(super) states: Vec<litesim_ssp::ReportedState>,
    #[serde(skip)]
    pub(super) rejected: Vec<pb::CommandError>,
}

pub(super) fn apply_move(s: &mut Session, m: &pb::MoveCommand) -> SspResult<()> {
    match &m.cmd {
        Some(pb::move_command::Cmd::Xy(r)) => s.set_xy_trajectory(&r.actor_id, cv::xy(r)),
        Some(pb::move_command::Cmd::Dynamic(r)) => {
            s.set_dynamic_move(&r.actor_id, cv::dynamic(r)?, r.valid_until_ms)
        }
        Some(pb::move_command::Cmd::External(r)) => {
            s.set_external_controller(&r.actor_id, cv::external(r))
        }
        None => Err(SspError::invalid(
            "move command is empty: give xy, dynamic or external",
        )),
    }
}

pub(super) type StepStreamOut =
    Pin<Box<dyn Stream<Item = Result<pb::StepResult, Status>> + Send + 'static>>;

#[tonic::async_trait]
impl SimulatorSupport for SspService {
    async fn init(
        &self,
        req: Request<pb::InitRequest>,
    ) -> Result<Response<pb::InitResponse>, Status> {
        // Init may read and parse a map file: on a blocking thread, so that
        // a slow or huge map never holds up other clients' calls, and with
        // a deadline.
        let svc = self.clone();
        let conn = conn_of(&req);
        let r = req.into_inner();
        let job = tokio::task::spawn_blocking(move || svc.init_session(r, conn));
        let resp = match tokio::time::timeout(INIT_TIMEOUT, job).await {
            Ok(Ok(res)) => res.map_err(cv::status)?,
            Ok(Err(e)) => return Err(Status::internal(format!("init failed: {e}"))),
            Err(_) => {
                return Err(Status::deadline_exceeded(format!(
                    "init took longer than {} s (loading its map)",
                    INIT_TIMEOUT.as_secs()
                )));
            }
        };
        Ok(Response::new(pb::InitResponse {
            session_id: resp.session_id,
            capabilities: Some(cv::capabilities_pb(&resp.capabilities)),
            diagnostics: Some(pb::Diagnostics {
                info: vec![],
                warning: resp.diagnostics,
            }),
        }))
    }

    async fn keep_alive(
        &self,
        req: Request<pb::KeepAliveRequest>,
    ) -> Result<Response<pb::KeepAliveResponse>, Status> {
        let id = req.into_inner().session_id;
        self.with(&id, "keep_alive", || Value::Null, false, |_| Ok(()))?;
        Ok(Response::new(pb::KeepAliveResponse {
            lease_ms: self
                .inner
                .cfg
                .idle_timeout
                .map_or(0, |d| d.as_millis() as u64),
        }))
    }

    async fn attach(
        &self,
        req: Request<pb::AttachRequest>,
    ) -> Result<Response<pb::AttachResponse>, Status> {
        let conn = conn_of(&req);
        let id = req.into_inner().session_id;
        let slot = lock(&self.inner.sessions).get(&id).cloned();
        let result = match slot {
            None => Err(SspError::not_found(self.gone(&id))),
            Some(slot) => {
                let mut o = lock(&slot.owner);
                match (*o, conn) {
                    (Owner::Conn(c), Some(me))
                        if c != me && lock(&self.inner.open_conns).contains(&c) =>
                    {
                        Err(SspError::precondition(format!(
                            "session '{id}' belongs to another open connection"
                        )))
                    }
                    _ => {
                        *o = conn.map_or(Owner::Local, Owner::Conn);
                        *lock(&slot.last_used) = Instant::now();
                        Ok(lock(&slot.session).sim_time_ms())
                    }
                }
            }
        };
        self.trace(&id, "attach", Value::Null, &result);
        let sim_time_ms = result.map_err(cv::status)?;
        Ok(Response::new(pb::AttachResponse { sim_time_ms }))
    }

    async fn set_pacing(
        &self,
        req: Request<pb::SetPacingRequest>,
    ) -> Result<Response<pb::SetPacingResponse>, Status> {
        let r = req.into_inner();
        let realtime = r.realtime;
        let (sim_ms, step_ms) = self.with(
            &r.session_id,
            "set_pacing",
            || json!({ "realtime": realtime }),
            false,
            |s| Ok((s.sim_time_ms(), s.step_ms())),
        )?;
        if let Ok(slot) = self.slot(&r.session_id) {
            *lock(&slot.pacing) = realtime.then(|| (Instant::now(), sim_ms));
        }
        Ok(Response::new(pb::SetPacingResponse {
            step_ms: step_ms as u32,
        }))
    }

    async fn shutdown(
        &self,
        req: Request<pb::ShutdownRequest>,
    ) -> Result<Response<pb::ShutdownResponse>, Status> {
        let id = req.into_inner().session_id;
        let removed = lock(&self.inner.sessions).remove(&id);
        let result = match removed {
            Some(_) => {
                self.bury(
                    id.clone(),
                    Ended::Shutdown(self.server_time(Instant::now())),
                );
                Ok(Value::Null)
            }
            None => Err(SspError::not_found(self.gone(&id))),
        };
        self.trace(&id, "shutdown", Value::Null, &result);
        result.map_err(cv::status)?;
        Ok(Response::new(pb::ShutdownResponse {}))
    }

    async fn launch_simulator(
        &self,
        req: Request<pb::LaunchSimulatorRequest>,
    ) -> Result<Response<pb::LaunchSimulatorResponse>, Status> {
        let r = req.into_inner();
        let c = self.with(
            &r.session_id,
            "launch_simulator",
            || json!(r.connection_string),
            false,
            |s| s.launch_simulator(&r.connection_string),
        )?;
        Ok(Response::new(pb::LaunchSimulatorResponse {
            connection_string: c,
            diagnostics: None,
        }))
    }

    async fn terminate_simulator(
        &self,
        req: Request<pb::TerminateSimulatorRequest>,
    ) -> Result<Response<pb::TerminateSimulatorResponse>, Status> {
        let r = req.into_inner();
        self.with(
            &r.session_id,
            "terminate_simulator",
            || Value::Null,
            false,
            |s| s.terminate_simulator(),
        )?;
        Ok(Response::new(pb::TerminateSimulatorResponse {
            diagnostics: None,
        }))
    }

    async fn start_simulation(
        &self,
        req: Request<pb::StartSimulationRequest>,
    ) -> Result<Response<pb::StartSimulationResponse>, Status> {
        let r = req.into_inner();
        self.with(
            &r.session_id,
            "start_simulation",
            || json!({"start_time_ms": r.start_time_ms}),
            false,
            |s| s.start_simulation(r.start_time_ms),
        )?;
        Ok(Response::new(pb::StartSimulationResponse {
            diagnostics: None,
        }))
    }

    async fn wait_start_simulation(
        &self,
        req: Request<pb::WaitStartSimulationRequest>,
    ) -> Result<Response<pb::WaitStartSimulationResponse>, Status> {
        let r = req.into_inner();
        let t = self.with(
            &r.session_id,
            "wait_start_simulation",
            || json!({"max_wait_ms": r.max_wait_ms}),
            false,
            |s| s.wait_start_simulation(r.max_wait_ms),
        )?;
        Ok(Response::new(pb::WaitStartSimulationResponse {
            sim_time_ms: t,
            diagnostics: None,
        }))
    }

    async fn end_simulation(
        &self,
        req: Request<pb::EndSimulationRequest>,
    ) -> Result<Response<pb::EndSimulationResponse>, Status> {
        let r = req.into_inner();
        let n = self.with(
            &r.session_id,
            "end_simulation",
            || json!({"reason": r.reason}),
            false,
            |s| s.end_simulation(&r.reason),
        )?;
        Ok(Response::new(pb::EndSimulationResponse {
            steps_executed: n,
            diagnostics: None,
        }))
    }

    async fn start_step(
        &self,
        req: Request<pb::StartStepRequest>,
    ) -> Result<Response<pb::StartStepResponse>, Status> {
        let r = req.into_inner();
        let t = (r.requested_sim_time_ms != 0).then_some(r.requested_sim_time_ms);
        let i = self.with(
            &r.session_id,
            "start_step",
            || json!({"requested_sim_time_ms": t}),
            true,
            |s| s.start_step(t),
        )?;
        Ok(Response::new(pb::StartStepResponse { step_index: i }))
    }

    async fn wait_step(
        &self,
        req: Request<pb::WaitStepRequest>,
    ) -> Result<Response<pb::WaitStepResponse>, Status> {
        let r = req.into_inner();
        let info = self.with(
            &r.session_id,
            "wait_step",
            || json!({"max_wait_ms": r.max_wait_ms}),
            true,
            |s| s.wait_step(r.max_wait_ms),
        )?;
        Ok(Response::new(pb::WaitStepResponse {
            sim_time_ms: info.sim_time_ms,
            step_index: info.step_index,
            diagnostics: None,
        }))
    }

    async fn step(
        &self,
        req: Request<pb::StepRequest>,
    ) -> Result<Response<pb::StepResponse>, Status> {
        let r = req.into_inner();
        let t = (r.requested_sim_time_ms != 0).then_some(r.requested_sim_time_ms);
        let filter = r.state_filter;
        let (info, states) = self.with(
            &r.session_id,
            "step",
            || json!({"requested_sim_time_ms": t}),
            true,
            |s| {
                let f = cv::filter(filter)?;
                s.step(t, &f)
            },
        )?;
        self.pace(&r.session_id, info.sim_time_ms).await;
        Ok(Response::new(step_pb(&info, &states)))
    }

    async fn step_many(
        &self,
        req: Request<pb::StepManyRequest>,
    ) -> Result<Response<pb::StepManyResponse>, Status> {
        let r = req.into_inner();
        let filter = r.state_filter;
        let steps = r.steps;
        let out = self.with(
            &r.session_id,
            "step_many",
            || json!({ "steps": steps }),
            true,
            |s| {
                let f = cv::filter(filter)?;
                s.step_many(steps, &f)
            },
        )?;
        if let Some((info, _)) = out.last() {
            self.pace(&r.session_id, info.sim_time_ms).await;
        }
        Ok(Response::new(pb::StepManyResponse {
            steps: out
                .iter()
                .map(|(info, states)| step_pb(info, states))
                .collect(),
        }))
    }

    type StepStreamStream = StepStreamOut;

    async fn step_stream(
        &self,
        req: Request<Streaming<pb::StepCommand>>,
    ) -> Result<Response<Self::StepStreamStream>, Status> {
        let mut input = req.into_inner();
        let svc = self.clone();
        let (tx, rx) = tokio::sync::mpsc::channel::<Result<pb::StepResult, Status>>(4);
        tokio::spawn(async move {
            let mut session_id = String::new();
            while let Some(msg) = input.next().await {
                let cmd = match msg {
                    Ok(c) => c,
                    Err(e) => {
                        // A message over the size limit is answered like a
                        // unary one (RESOURCE_EXHAUSTED, gRPC's code for
                        // it; tonic reports OUT_OF_RANGE); other errors
                        // mean the client went away.
                        if matches!(
                            e.code(),
                            tonic::Code::OutOfRange | tonic::Code::ResourceExhausted
                        ) {
                            let _ = tx
                                .send(Err(Status::resource_exhausted(e.message().to_string())))
                                .await;
                        }
                        break;
                    }
                };
                if session_id.is_empty() {
                    let slot = match svc.slot(&cmd.session_id) {
                        Ok(s) => s,
                        Err(e) => {
                            let _ = tx.send(Err(cv::status(e))).await;
                            return;
                        }
                    };
                    if slot.streaming.swap(true, Ordering::SeqCst) {
                        let e =
                            SspError::precondition("this session already has an open StepStream");
                        let _ = tx.send(Err(cv::status(e))).await;
                        return;
                    }
                    session_id = cmd.session_id.clone();
                }
                let out = svc.stream_step(&session_id, cmd);
                let fatal = out.is_err();
                if tx.send(out).await.is_err() || fatal {
                    break;
                }
            }
            // The stream owned the session: it ends with the stream.
            if !session_id.is_empty() && lock(&svc.inner.sessions).remove(&session_id).is_some() {
                let t = svc.server_time(Instant::now());
                svc.bury(session_id, Ended::Shutdown(t));
            }
        });
        Ok(Response::new(Box::pin(
            tokio_stream::wrappers::ReceiverStream::new(rx),
        )))
    }

    async fn get_actors_states(
        &self,
        req: Request<pb::GetActorsStatesRequest>,
    ) -> Result<Response<pb::GetActorsStatesResponse>, Status> {
        let r = req.into_inner();
        let filter = r.filter;
        let (t, states) = self.with(
            &r.session_id,
            "get_actors_states",
            || json!({}),
            false,
            |s| {
                let f = cv::filter(filter)?;
                let states = s.get_actors_states(&f)?;
                Ok((s.sim_time_ms(), StatesOut(states)))
            },
        )?;
        Ok(Response::new(pb::GetActorsStatesResponse {
            sim_time_ms: t,
            states: states.0.iter().map(cv::state_pb).collect(),
        }))
    }

    async fn create_actor(
        &self,
        req: Request<pb::CreateActorRequest>,
    ) -> Result<Response<pb::CreateActorResponse>, Status> {
        let r = req.into_inner();
        let build = |r: &pb::CreateActorRequest| -> SspResult<litesim_ssp::CreateActor> {
            Ok(litesim_ssp::CreateActor {
                actor_id: r.actor_id.clone(),
                spec: cv::spec(r.description.clone())?,
                position: cv::coord(r.position),
                speed: cv::coord(r.speed),
                acceleration: cv::coord(r.acceleration),
                initial_mode: cv::move_mode(r.initial_mode, "initial_mode")?,
            })
        };
        let parsed = build(&r);
        let args = || serde_json::to_value(parsed.as_ref().ok()).unwrap_or(Value::Null);
        let a = self.with(&r.session_id, "create_actor", args, false, |s| {
            s.create_actor(parsed.clone()?)
        })?;
        Ok(Response::new(pb::CreateActorResponse {
            actual_description: Some(cv::actual_pb(&a)),
            diagnostics: None,
        }))
    }

    async fn set_actor_params(
        &self,
        req: Request<pb::SetActorParamsRequest>,
    ) -> Result<Response<pb::SetActorParamsResponse>, Status> {
        let r = req.into_inner();
        let args = || json!({"actor_id": r.actor_id, "params": r.params});
        self.with(&r.session_id, "set_actor_params", args, false, |s| {
            let controls = r.controls.clone().map(cv::controls).transpose()?;
            s.set_actor_params(&r.actor_id, r.params.clone(), controls)
        })?;
        Ok(Response::new(pb::SetActorParamsResponse {
            diagnostics: None,
        }))
    }

    async fn destroy_actor(
        &self,
        req: Request<pb::DestroyActorRequest>,
    ) -> Result<Response<pb::DestroyActorResponse>, Status> {
        let r = req.into_inner();
        self.with(
            &r.session_id,
            "destroy_actor",
            || json!({"actor_id": r.actor_id}),
            false,
            |s| s.destroy_actor(&r.actor_id),
        )?;
        Ok(Response::new(pb::DestroyActorResponse {}))
    }

    async fn set_xy_trajectory(
        &self,
        req: Request<pb::SetXyTrajectoryRequest>,
    ) -> Result<Response<pb::MoveResponse>, Status> {
        let r = req.into_inner();
        let t = cv::xy(&r);
        let args = || json!({"actor_id": r.actor_id, "trajectory": t});
        self.with(&r.session_id, "set_xy_trajectory", args, false, |s| {
            s.set_xy_trajectory(&r.actor_id, t.clone())
        })?;
        Ok(Response::new(pb::MoveResponse { diagnostics: None }))
    }

    async fn set_dynamic_move(
        &self,
        req: Request<pb::SetDynamicMoveRequest>,
    ) -> Result<Response<pb::MoveResponse>, Status> {
        let r = req.into_inner();
        let cmd = cv::dynamic(&r);
        let args = || json!({"actor_id": r.actor_id, "command": cmd.as_ref().ok(), "valid_until_ms": r.valid_until_ms});
        self.with(&r.session_id, "set_dynamic_move", args, false, |s| {
            s.set_dynamic_move(&r.actor_id, cmd.clone()?, r.valid_until_ms)
        })?;
        Ok(Response::new(pb::MoveResponse { diagnostics: None }))
    }

    async fn set_external_controller(
        &self,
        req: Request<pb::SetExternalControllerRequest>,
    ) -> Result<Response<pb::MoveResponse>, Status> {
        let r = req.into_inner();
        let ext = cv::external(&r);
        let args = || json!({"actor_id": r.actor_id, "controller": ext});
        self.with(&r.session_id, "set_external_controller", args, false, |s| {
            s.set_external_controller(&r.actor_id, ext.clone())
        })?;
        Ok(Response::new(pb::MoveResponse { diagnostics: None }))
    }

    async fn set_weather(
        &self,
        req: Request<pb::SetWeatherRequest>,
    ) -> Result<Response<pb::SetWeatherResponse>, Status> {
        let r = req.into_inner();
        let w = cv::weather(r.weather);
        let applied = self.with(
            &r.session_id,
            "set_weather",
            || json!(w),
            false,
            |s| s.set_weather(w.clone()),
        )?;
        Ok(Response::new(pb::SetWeatherResponse {
            applied: Some(cv::weather_pb(&applied)),
        }))
    }

    async fn set_time_of_day(
        &self,
        req: Request<pb::SetTimeOfDayRequest>,
    ) -> Result<Response<pb::SetTimeOfDayResponse>, Status> {
        let r = req.into_inner();
        let tod = litesim_ssp::TimeOfDay {
            seconds_since_midnight: r.seconds_since_midnight,
            day_of_year: r.day_of_year,
            advance_with_sim: r.advance_with_sim,
        };
        self.with(
            &r.session_id,
            "set_time_of_day",
            || json!(tod),
            false,
            |s| s.set_time_of_day(tod),
        )?;
        Ok(Response::new(pb::SetTimeOfDayResponse {}))
    }

    async fn sim_command(
        &self,
        req: Request<pb::SimCommandRequest>,
    ) -> Result<Response<pb::SimCommandResponse>, Status> {
        let r = req.into_inner();
        let out = self.with(
            &r.session_id,
            "sim_command",
            || json!({"command": r.command, "args": r.args}),
            false,
            |s| s.sim_command(&r.command, &r.args),
        )?;
        Ok(Response::new(pb::SimCommandResponse {
            output: out,
            diagnostics: None,
        }))
    }

    async fn list_traffic_lights(
        &self,
        req: Request<pb::ListTrafficLightsRequest>,
    ) -> Result<Response<pb::ListTrafficLightsResponse>, Status> {
        let r = req.into_inner();
        let l = self.with(
            &r.session_id,
            "list_traffic_lights",
            || Value::Null,
            false,
            |s| s.list_traffic_lights(),
        )?;
        Ok(Response::new(pb::ListTrafficLightsResponse {
            boxes: l.boxes.iter().map(cv::light_box_pb).collect(),
            logical: l.logical.iter().map(cv::logical_pb).collect(),
        }))
    }

    async fn set_traffic_light_state(
        &self,
        req: Request<pb::SetTrafficLightStateRequest>,
    ) -> Result<Response<pb::SetTrafficLightStateResponse>, Status> {
        let r = req.into_inner();
        let parsed = cv::light_request(&r);
        let args = || serde_json::to_value(parsed.as_ref().ok()).unwrap_or(Value::Null);
        let affected = self.with(&r.session_id, "set_traffic_light_state", args, false, |s| {
            let (t, st) = parsed.clone()?;
            s.set_traffic_light_state(t, st)
        })?;
        Ok(Response::new(pb::SetTrafficLightStateResponse {
            affected: affected.iter().map(cv::light_box_pb).collect(),
        }))
    }
}

/// States serialised as a count in traces (a full state dump per step would
/// dwarf the run itself).
pub(super) struct StatesOut(Vec<litesim_ssp::ReportedState>);

impl Serialize for StatesOut {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.len().serialize(s)
    }
}

/// One step's reply on the wire.
pub(super) fn step_pb(
    info: &litesim_ssp::StepInfo,
    states: &[litesim_ssp::ReportedState],
) -> pb::StepResponse {
    pb::StepResponse {
        sim_time_ms: info.sim_time_ms,
        step_index: info.step_index,
        states: states.iter().map(cv::state_pb).collect(),
    }
}
