//! A blocking gRPC client that implements [`Ssp`], so code written against
//! the trait drives a remote server exactly as it drives an in-process
//! [`litesim_ssp::Session`].
//!
//! The client owns a single-threaded tokio runtime; do not call it from
//! inside another tokio runtime's worker thread (use `spawn_blocking`).

use crate::convert as cv;
use crate::pb;
use crate::pb::simulator_support_client::SimulatorSupportClient;
use litesim_ssp::*;
use std::collections::BTreeMap;
use tonic::transport::Channel;

/// Adds `authorization: Bearer <token>` to every call when the client
/// has a token.
#[derive(Clone, Debug, Default)]
pub struct Bearer(Option<tonic::metadata::MetadataValue<tonic::metadata::Ascii>>);

impl Bearer {
    /// For `token` (none: no header).
    pub fn new(token: Option<&str>) -> SspResult<Self> {
        match token {
            Some(t) => Ok(Bearer(Some(format!("Bearer {t}").parse().map_err(
                |_| SspError::invalid("the token must be printable ASCII without line breaks"),
            )?))),
            None => Ok(Bearer(None)),
        }
    }
}

impl tonic::service::Interceptor for Bearer {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(v) = &self.0 {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}

/// The generated client as a [`RemoteSsp`] holds it.
pub type RawClient =
    SimulatorSupportClient<tonic::service::interceptor::InterceptedService<Channel, Bearer>>;

/// The SSP API over gRPC.
pub struct RemoteSsp {
    rt: tokio::runtime::Runtime,
    client: RawClient,
    session_id: String,
    /// `shutdown` was sent.
    closed: bool,
}

impl Drop for RemoteSsp {
    /// A client that goes away frees its session at once instead of
    /// holding a slot until the server's idle reaper runs.
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

impl std::fmt::Debug for RemoteSsp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteSsp")
            .field("session_id", &self.session_id)
            .finish()
    }
}

impl RemoteSsp {
    /// Connects to `addr` (`http://127.0.0.1:50051` or `127.0.0.1:50051`).
    pub fn connect(addr: &str) -> SspResult<Self> {
        Self::connect_with_token(addr, None)
    }

    /// [`RemoteSsp::connect`] to a server that wants a token
    /// (`litesim serve --auth-token-file`): every call carries it.
    pub fn connect_with_token(addr: &str, token: Option<&str>) -> SspResult<Self> {
        Self::connect_with(addr, token, None)
    }

    /// [`RemoteSsp::connect_with_token`], over TLS when `ca_pem` is given:
    /// the server's certificate must chain to this CA (PEM) and name the
    /// address's host.
    pub fn connect_with(addr: &str, token: Option<&str>, ca_pem: Option<&[u8]>) -> SspResult<Self> {
        let bearer = Bearer::new(token)?;
        let uri = match (addr.split_once("://"), ca_pem) {
            (Some(_), _) => addr.to_string(),
            (None, Some(_)) => format!("https://{addr}"),
            (None, None) => format!("http://{addr}"),
        };
        let tls = ca_pem.map(|ca| {
            tonic::transport::ClientTlsConfig::new()
                .ca_certificate(tonic::transport::Certificate::from_pem(ca))
        });
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| {
                SspError::new(ErrorCode::Internal, format!("cannot start a runtime: {e}"))
            })?;
        let channel = rt.block_on(async {
            let mut ep = Channel::from_shared(uri.clone())
                .map_err(|e| SspError::invalid(format!("bad address '{addr}': {e}")))?;
            if let Some(t) = tls {
                ep = ep
                    .tls_config(t)
                    .map_err(|e| SspError::invalid(format!("TLS for '{addr}': {e}")))?;
            }
            ep.tcp_nodelay(true).connect().await.map_err(|e| {
                SspError::new(
                    ErrorCode::Unavailable,
                    format!("cannot connect to {uri}: {e}"),
                )
            })
        })?;
        let client = SimulatorSupportClient::with_interceptor(channel, bearer)
            .max_decoding_message_size(usize::MAX)
            .max_encoding_message_size(usize::MAX);
        Ok(Self {
            rt,
            client,
            session_id: String::new(),
            closed: false,
        })
    }

    /// The session id given by the server at `init`.
    pub fn session_id(&self) -> &str {
        &self.session_id
    }

    /// The raw tonic client, e.g. to open a `StepStream`.
    pub fn raw(&mut self) -> (&tokio::runtime::Runtime, &mut RawClient) {
        (&self.rt, &mut self.client)
    }

    /// Renews the session's lease without doing anything else; returns the
    /// lease (a session unused that long is ended by the server).
    pub fn keep_alive(&mut self) -> SspResult<std::time::Duration> {
        let req = pb::KeepAliveRequest {
            session_id: self.session_id.clone(),
        };
        let r = self
            .rt
            .block_on(self.client.keep_alive(req))
            .map_err(crate::convert::error)?;
        Ok(std::time::Duration::from_millis(r.into_inner().lease_ms))
    }

    /// Takes back session `id` after a reconnect (it was detached when
    /// its connection closed; the server keeps it for its grace period,
    /// 30 s by default); this client then drives it. Returns its
    /// simulated time (ms).
    pub fn attach(&mut self, id: &str) -> SspResult<u64> {
        let req = pb::AttachRequest {
            session_id: id.to_string(),
        };
        let r = self
            .rt
            .block_on(self.client.attach(req))
            .map_err(crate::convert::error)?;
        self.session_id = id.to_string();
        self.closed = false;
        Ok(r.into_inner().sim_time_ms)
    }

    /// Asks the server to pace this session's steps to the wall clock
    /// (`realtime`) or to step as fast as possible; returns the step (ms).
    pub fn set_pacing(&mut self, realtime: bool) -> SspResult<u32> {
        let req = pb::SetPacingRequest {
            session_id: self.session_id.clone(),
            realtime,
        };
        let r = self
            .rt
            .block_on(self.client.set_pacing(req))
            .map_err(crate::convert::error)?;
        Ok(r.into_inner().step_ms)
    }

    /// Ends the session on the server (also done when the client is dropped).
    pub fn shutdown(&mut self) -> SspResult<()> {
        if self.session_id.is_empty() || self.closed {
            return Ok(());
        }
        self.closed = true;
        let req = pb::ShutdownRequest {
            session_id: self.session_id.clone(),
        };
        let c = &mut self.client;
        self.rt.block_on(c.shutdown(req)).map_err(cv::error)?;
        Ok(())
    }

    fn sid(&self) -> String {
        self.session_id.clone()
    }
}

macro_rules! call {
    ($self:ident, $method:ident, $req:expr) => {{
        let req = $req;
        let c = &mut $self.client;
        $self
            .rt
            .block_on(c.$method(req))
            .map(|r| r.into_inner())
            .map_err(cv::error)
    }};
}

impl Ssp for RemoteSsp {
    fn init(&mut self, req: InitRequest) -> SspResult<InitResponse> {
        let map = req.map.map(|m| {
            if m.trim_start().starts_with('<') {
                pb::init_request::Map::MapXodr(m)
            } else {
                pb::init_request::Map::MapPath(m)
            }
        });
        let r = call!(
            self,
            init,
            pb::InitRequest {
                client_name: req.client_name,
                step_size_ms: req.step_size_ms,
                map,
                profile: req.profile,
                seed: req.seed,
                options: req.options,
                model: req.model,
                traffic_lights: req.traffic_lights.iter().map(cv::light_box_pb).collect(),
                logical_lights: req.logical_lights.iter().map(cv::logical_pb).collect(),
            }
        )?;
        self.session_id = r.session_id.clone();
        self.closed = false;
        Ok(InitResponse {
            session_id: r.session_id,
            capabilities: cv::capabilities(r.capabilities.unwrap_or_default())?,
            diagnostics: r.diagnostics.map(|d| d.warning).unwrap_or_default(),
        })
    }

    fn launch_simulator(&mut self, connection_string: &str) -> SspResult<String> {
        let req = pb::LaunchSimulatorRequest {
            session_id: self.sid(),
            connection_string: connection_string.into(),
        };
        Ok(call!(self, launch_simulator, req)?.connection_string)
    }

    fn terminate_simulator(&mut self) -> SspResult<()> {
        let req = pb::TerminateSimulatorRequest {
            session_id: self.sid(),
        };
        call!(self, terminate_simulator, req).map(|_| ())
    }

    fn start_simulation(&mut self, start_time_ms: u64) -> SspResult<()> {
        let req = pb::StartSimulationRequest {
            session_id: self.sid(),
            connection_string: String::new(),
            start_time_ms,
        };
        call!(self, start_simulation, req).map(|_| ())
    }

    fn wait_start_simulation(&mut self, max_wait_ms: u32) -> SspResult<u64> {
        let req = pb::WaitStartSimulationRequest {
            session_id: self.sid(),
            max_wait_ms,
        };
        Ok(call!(self, wait_start_simulation, req)?.sim_time_ms)
    }

    fn end_simulation(&mut self, reason: &str) -> SspResult<u64> {
        let req = pb::EndSimulationRequest {
            session_id: self.sid(),
            reason: reason.into(),
        };
        Ok(call!(self, end_simulation, req)?.steps_executed)
    }

    fn start_step(&mut self, requested_sim_time_ms: Option<u64>) -> SspResult<u64> {
        let req = pb::StartStepRequest {
            session_id: self.sid(),
            requested_sim_time_ms: requested_sim_time_ms.unwrap_or(0),
        };
        Ok(call!(self, start_step, req)?.step_index)
    }

    fn wait_step(&mut self, max_wait_ms: u32) -> SspResult<StepInfo> {
        let req = pb::WaitStepRequest {
            session_id: self.sid(),
            max_wait_ms,
        };
        let r = call!(self, wait_step, req)?;
        Ok(StepInfo {
            sim_time_ms: r.sim_time_ms,
            step_index: r.step_index,
        })
    }

    fn get_actors_states(&mut self, filter: &ActorFilter) -> SspResult<Vec<ReportedState>> {
        let req = pb::GetActorsStatesRequest {
            session_id: self.sid(),
            filter: Some(cv::filter_pb(filter)),
        };
        call!(self, get_actors_states, req)?
            .states
            .into_iter()
            .map(cv::state)
            .collect()
    }

    fn create_actor(&mut self, req: CreateActor) -> SspResult<ActualDescription> {
        let r = pb::CreateActorRequest {
            session_id: self.sid(),
            actor_id: req.actor_id,
            description: Some(cv::spec_pb(&req.spec)),
            position: Some(cv::coord_pb(&req.position)),
            speed: Some(cv::coord_pb(&req.speed)),
            acceleration: Some(cv::coord_pb(&req.acceleration)),
            initial_mode: cv::move_mode_pb(req.initial_mode),
        };
        cv::actual(
            call!(self, create_actor, r)?
                .actual_description
                .unwrap_or_default(),
        )
    }

    fn destroy_actor(&mut self, actor_id: &str) -> SspResult<()> {
        let req = pb::DestroyActorRequest {
            session_id: self.sid(),
            actor_id: actor_id.into(),
        };
        call!(self, destroy_actor, req).map(|_| ())
    }

    fn set_actor_params(
        &mut self,
        actor_id: &str,
        params: BTreeMap<String, String>,
        controls: Option<ActorControls>,
    ) -> SspResult<()> {
        let req = pb::SetActorParamsRequest {
            session_id: self.sid(),
            actor_id: actor_id.into(),
            params,
            controls: controls.as_ref().map(cv::controls_pb),
        };
        call!(self, set_actor_params, req).map(|_| ())
    }

    fn set_weather(&mut self, weather: Weather) -> SspResult<Weather> {
        let req = pb::SetWeatherRequest {
            session_id: self.sid(),
            weather: Some(cv::weather_pb(&weather)),
        };
        Ok(cv::weather(call!(self, set_weather, req)?.applied))
    }

    fn set_time_of_day(&mut self, tod: TimeOfDay) -> SspResult<()> {
        let req = pb::SetTimeOfDayRequest {
            session_id: self.sid(),
            seconds_since_midnight: tod.seconds_since_midnight,
            day_of_year: tod.day_of_year,
            advance_with_sim: tod.advance_with_sim,
        };
        call!(self, set_time_of_day, req).map(|_| ())
    }

    fn sim_command(&mut self, command: &str, args: &[String]) -> SspResult<String> {
        let req = pb::SimCommandRequest {
            session_id: self.sid(),
            command: command.into(),
            args: args.to_vec(),
        };
        Ok(call!(self, sim_command, req)?.output)
    }

    fn set_xy_trajectory(&mut self, actor_id: &str, traj: XyTrajectory) -> SspResult<()> {
        let req = cv::xy_pb(&self.sid(), actor_id, &traj);
        call!(self, set_xy_trajectory, req).map(|_| ())
    }

    fn set_dynamic_move(
        &mut self,
        actor_id: &str,
        cmd: DynamicMove,
        valid_until_ms: u64,
    ) -> SspResult<()> {
        let req = cv::dynamic_pb(&self.sid(), actor_id, &cmd, valid_until_ms);
        call!(self, set_dynamic_move, req).map(|_| ())
    }

    fn set_external_controller(&mut self, actor_id: &str, ext: ExternalMove) -> SspResult<()> {
        let req = pb::SetExternalControllerRequest {
            session_id: self.sid(),
            actor_id: actor_id.into(),
            controller: ext.controller,
            params: ext.params,
            desired_speed: ext.desired_speed,
        };
        call!(self, set_external_controller, req).map(|_| ())
    }

    fn list_traffic_lights(&mut self) -> SspResult<TrafficLights> {
        let req = pb::ListTrafficLightsRequest {
            session_id: self.sid(),
        };
        let r = call!(self, list_traffic_lights, req)?;
        Ok(TrafficLights {
            boxes: r
                .boxes
                .into_iter()
                .map(cv::light_box)
                .collect::<SspResult<_>>()?,
            logical: r.logical.into_iter().map(cv::logical).collect(),
        })
    }

    fn set_traffic_light_state(
        &mut self,
        target: LightTarget,
        states: Vec<BulbState>,
    ) -> SspResult<Vec<TrafficLightBox>> {
        let req = cv::light_request_pb(&self.sid(), &target, &states);
        call!(self, set_traffic_light_state, req)?
            .affected
            .into_iter()
            .map(cv::light_box)
            .collect()
    }

    fn step_many(
        &mut self,
        steps: u32,
        filter: &ActorFilter,
    ) -> SspResult<Vec<(StepInfo, Vec<ReportedState>)>> {
        let req = pb::StepManyRequest {
            session_id: self.sid(),
            steps,
            state_filter: Some(cv::filter_pb(filter)),
        };
        call!(self, step_many, req)?
            .steps
            .into_iter()
            .map(step_result)
            .collect()
    }

    fn step(
        &mut self,
        requested_sim_time_ms: Option<u64>,
        filter: &ActorFilter,
    ) -> SspResult<(StepInfo, Vec<ReportedState>)> {
        let req = pb::StepRequest {
            session_id: self.sid(),
            requested_sim_time_ms: requested_sim_time_ms.unwrap_or(0),
            state_filter: Some(cv::filter_pb(filter)),
        };
        step_result(call!(self, step, req)?)
    }
}

/// A step's reply as the trait returns it.
fn step_result(r: pb::StepResponse) -> SspResult<(StepInfo, Vec<ReportedState>)> {
    Ok((
        StepInfo {
            sim_time_ms: r.sim_time_ms,
            step_index: r.step_index,
        },
        r.states
            .into_iter()
            .map(cv::state)
            .collect::<SspResult<_>>()?,
    ))
}
