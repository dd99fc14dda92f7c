//! The system-under-test API over gRPC (`litesim.sut.v1`).
//!
//! [`GrpcSut`] is litesim's side: a [`Sut`] whose every call goes to an
//! external process and must come back within the run's timeout; a late,
//! malformed or missing answer is a [`SutError`] that ends the run with a
//! verdict, never a hang. [`serve_sut`] is the other side for SUTs written
//! in Rust: it serves any [`SutFactory`], one SUT per `run_id`, so a
//! parallel batch can share one server.

use crate::sut_pb as pb;
use crate::sut_pb::system_under_test_client::SystemUnderTestClient;
use crate::sut_pb::system_under_test_server::{SystemUnderTest, SystemUnderTestServer};
use litesim_scenario::sut::{
    LightState, ObjectState, Observation, RoadPos, Route, Sut, SutChoice, SutCommand, SutError,
    SutFactory, SutInfo,
};
use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tonic::transport::Channel;
use tonic::{Request, Response, Status};

static RUNS: AtomicU64 = AtomicU64::new(0);

/// Makes a [`GrpcSut`] per run for `grpc://HOST:PORT`.
#[derive(Clone, Debug)]
pub struct GrpcSutFactory {
    addr: String,
    auth: Auth,
}

/// How a SUT client proves itself and checks its server: a bearer token
/// sent with every call, a CA (PEM) the server's certificate must chain
/// to (TLS).
#[derive(Clone, Default)]
pub struct Auth {
    /// Sent as `authorization: Bearer <token>`.
    pub token: Option<String>,
    /// With it, the connection is TLS.
    pub ca_pem: Option<Vec<u8>>,
}

impl std::fmt::Debug for Auth {
    /// The token never goes into a message.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Auth {{ token: {}, tls: {} }}",
            if self.token.is_some() {
                "given"
            } else {
                "none"
            },
            self.ca_pem.is_some()
        )
    }
}

impl Auth {
    /// From the files named by `LITESIM_SUT_TOKEN_FILE` and
    /// `LITESIM_SUT_CA_FILE` (what `--sut grpc://…` and Python's
    /// `sut="grpc://…"` use).
    pub fn from_env() -> Result<Self, SutError> {
        let read = |var: &str| -> Result<Option<Vec<u8>>, SutError> {
            std::env::var_os(var)
                .map(|f| {
                    litesim_core::files::read_bytes(
                        f.as_ref(),
                        litesim_core::files::MAX_INPUT_BYTES,
                    )
                    .map_err(|e| SutError(format!("{var} {e}")))
                })
                .transpose()
        };
        let token = read("LITESIM_SUT_TOKEN_FILE")?
            .map(|b| String::from_utf8_lossy(&b).trim().to_string())
            .filter(|t| !t.is_empty());
        Ok(Auth {
            token,
            ca_pem: read("LITESIM_SUT_CA_FILE")?,
        })
    }
}

impl GrpcSutFactory {
    /// For `HOST:PORT` (with or without `grpc://`).
    pub fn new(addr: &str) -> Result<Self, SutError> {
        let a = addr.strip_prefix("grpc://").unwrap_or(addr);
        let (host, port) = a
            .rsplit_once(':')
            .ok_or_else(|| SutError(format!("'{addr}': expected grpc://HOST:PORT")))?;
        if host.is_empty() || port.parse::<u16>().is_err() {
            return Err(SutError(format!(
                "'{addr}': expected grpc://HOST:PORT with a port 0..65535"
            )));
        }
        Ok(Self {
            addr: a.to_string(),
            auth: Auth::default(),
        })
    }

    /// The same, with a token and/or a CA.
    pub fn with_auth(mut self, auth: Auth) -> Self {
        self.auth = auth;
        self
    }
}

/// A SUT by name, as front ends take it (`--sut NAME`, Python's `sut=`):
/// a built-in ([`SutChoice::builtin`]) or `grpc://HOST:PORT`. `Ok(None)`
/// for any other name (the caller says what it accepts besides);
/// an error for a malformed `grpc://` address.
pub fn choice_by_name(name: &str) -> Result<Option<SutChoice>, SutError> {
    if let Some(c) = SutChoice::builtin(name) {
        return Ok(Some(c));
    }
    if name.starts_with("grpc://") {
        return Ok(Some(SutChoice::External(std::sync::Arc::new(
            GrpcSutFactory::new(name)?.with_auth(Auth::from_env()?),
        ))));
    }
    Ok(None)
}

impl SutFactory for GrpcSutFactory {
    fn name(&self) -> String {
        format!("grpc://{}", self.addr)
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        Ok(Box::new(
            GrpcSut::new(&self.addr)?.with_auth(self.auth.clone()),
        ))
    }
}

/// The generated SUT client with its bearer-token interceptor.
type SutClient = SystemUnderTestClient<
    tonic::service::interceptor::InterceptedService<Channel, crate::client::Bearer>,
>;

/// An external SUT, stepped in lock step over gRPC.
pub struct GrpcSut {
    addr: String,
    auth: Auth,
    rt: tokio::runtime::Runtime,
    client: Option<SutClient>,
    timeout: Duration,
    run_id: String,
    ego_id: String,
}

impl GrpcSut {
    /// A client for `HOST:PORT`; it connects at `reset`.
    pub fn new(addr: &str) -> Result<Self, SutError> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| SutError(format!("cannot start a runtime: {e}")))?;
        Ok(Self {
            addr: addr.to_string(),
            auth: Auth::default(),
            rt,
            client: None,
            timeout: Duration::from_secs(1),
            run_id: String::new(),
            ego_id: String::new(),
        })
    }

    /// The same, with a token and/or a CA.
    pub fn with_auth(mut self, auth: Auth) -> Self {
        self.auth = auth;
        self
    }

    fn call<T>(
        &mut self,
        what: &str,
        f: impl AsyncFnOnce(&mut SutClient) -> Result<T, Status>,
    ) -> Result<T, SutError> {
        let timeout = self.timeout;
        let addr = self.addr.clone();
        let Some(client) = self.client.as_mut() else {
            return Err(SutError(format!("{what}: not connected to {addr}")));
        };
        self.rt.block_on(async move {
            match tokio::time::timeout(timeout, f(client)).await {
                Err(_) => Err(SutError(format!(
                    "{what}: no answer from {addr} within {:.3} s",
                    timeout.as_secs_f64()
                ))),
                Ok(Err(st))
                    if st.code() == tonic::Code::Cancelled && st.message().contains("Timeout") =>
                {
                    Err(SutError(format!(
                        "{what}: no answer from {addr} within {:.3} s",
                        timeout.as_secs_f64()
                    )))
                }
                Ok(Err(st))
                    if matches!(st.code(), tonic::Code::Unknown | tonic::Code::Unavailable)
                        && st.message().contains("transport") =>
                {
                    Err(SutError(format!(
                        "{what}: lost the connection to {addr} (did the SUT process end?): {}",
                        bounded(st.message())
                    )))
                }
                Ok(Err(st)) => Err(SutError(format!(
                    "{what}: {addr} answered {:?}: {}",
                    st.code(),
                    bounded(st.message())
                ))),
                Ok(Ok(v)) => Ok(v),
            }
        })
    }
}

/// A message quoted from the SUT, cut to a readable length.
fn bounded(s: &str) -> String {
    if s.len() <= 200 {
        s.to_string()
    } else {
        let mut end = 200;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}…({} bytes)", &s[..end], s.len())
    }
}

impl Sut for GrpcSut {
    fn name(&self) -> String {
        format!("grpc://{}", self.addr)
    }

    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        if info.timeout_s.is_finite() && info.timeout_s > 0.0 {
            self.timeout = Duration::from_secs_f64(info.timeout_s.min(3600.0));
        }
        let tls = self.auth.ca_pem.as_ref().map(|ca| {
            tonic::transport::ClientTlsConfig::new()
                .ca_certificate(tonic::transport::Certificate::from_pem(ca))
        });
        let scheme = if tls.is_some() { "https" } else { "http" };
        let uri = format!("{scheme}://{}", self.addr);
        let timeout = self.timeout;
        let channel = self.rt.block_on(async {
            let mut ep = Channel::from_shared(uri.clone())
                .map_err(|e| SutError(format!("bad address '{}': {e}", self.addr)))?;
            if let Some(t) = tls {
                ep = ep
                    .tls_config(t)
                    .map_err(|e| SutError(format!("TLS for '{}': {e}", self.addr)))?;
            }
            let ep = ep.tcp_nodelay(true).connect_timeout(timeout);
            ep.connect()
                .await
                .map_err(|e| SutError(format!("cannot connect to {uri}: {e}")))
        })?;
        let bearer = crate::client::Bearer::new(self.auth.token.as_deref())
            .map_err(|e| SutError(e.message))?;
        self.client = Some(SystemUnderTestClient::with_interceptor(channel, bearer));
        self.ego_id = info.ego_id.clone();
        self.run_id = format!(
            "{}#{}#{}#{}",
            info.test,
            info.seed,
            std::process::id(),
            RUNS.fetch_add(1, Ordering::Relaxed)
        );
        let req = reset_request(info, &self.run_id);
        self.call("reset", async move |c| c.reset(req).await.map(|_| ()))
    }

    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        let req = step_request(obs, &self.run_id);
        let cmd = self.call("step", async move |c| {
            c.step(req).await.map(Response::into_inner)
        })?;
        if !cmd.actor_id.is_empty() && cmd.actor_id != self.ego_id {
            return Err(SutError(format!(
                "it commanded the unknown actor '{}' (it drives {} only)",
                bounded(&cmd.actor_id),
                self.ego_id
            )));
        }
        from_pb_command(cmd)
    }
}

fn obj(o: &ObjectState) -> pb::Object {
    pb::Object {
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

fn obj_from(o: pb::Object) -> ObjectState {
    ObjectState {
        id: o.id,
        kind: o.kind,
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

/// The wire form of a reset.
pub fn reset_request(info: &SutInfo, run_id: &str) -> pb::ResetRequest {
    pb::ResetRequest {
        test: info.test.clone(),
        seed: info.seed,
        map_path: info.map_path.clone(),
        step_ms: info.step_ms,
        ego_id: info.ego_id.clone(),
        length: info.length,
        width: info.width,
        wheelbase: info.wheelbase,
        max_steer: info.max_steer,
        max_accel: info.max_accel,
        max_decel: info.max_decel,
        route: Some(pb::Route {
            points: info
                .route
                .points
                .iter()
                .map(|p| pb::Point { x: p[0], y: p[1] })
                .collect(),
            s: info.route.s.clone(),
            speed: info.route.speed.clone(),
        }),
        timeout_s: info.timeout_s,
        run_id: run_id.to_string(),
    }
}

/// The wire form of an observation.
pub fn step_request(o: &Observation, run_id: &str) -> pb::StepRequest {
    pb::StepRequest {
        tick: o.tick,
        time: o.time,
        ego: Some(obj(&o.ego)),
        objects: o.objects.iter().map(obj).collect(),
        lights: o
            .lights
            .iter()
            .map(|l| pb::Light {
                id: l.id.clone(),
                road: l.road.clone(),
                s: l.s,
                color: l.color.clone(),
            })
            .collect(),
        road: o.road.as_ref().map(|r| pb::RoadPosition {
            road: r.road.clone(),
            lane: r.lane,
            s: r.s,
            offset: r.offset,
        }),
        requested_speed: o.requested_speed,
        distance_to_goal: o.distance_to_goal,
        run_id: run_id.to_string(),
    }
}

/// A command from the wire (an empty one is an error).
pub fn from_pb_command(c: pb::Command) -> Result<SutCommand, SutError> {
    use pb::command::Command as C;
    match c.command {
        Some(C::Pedals(p)) => Ok(SutCommand::Pedals {
            throttle: p.throttle,
            brake: p.brake,
            steering: p.steering,
        }),
        Some(C::Physical(p)) => Ok(SutCommand::Physical {
            drive_force_n: p.drive_force_n,
            brake_force_n: p.brake_force_n,
            steering_wheel_angle_rad: p.steering_wheel_angle_rad,
        }),
        Some(C::Accel(a)) => Ok(SutCommand::Accel {
            acceleration: a.acceleration,
            curvature: a.curvature,
            reverse: a.reverse,
        }),
        None => Err(SutError(
            "it returned an empty command (set one of pedals, physical, accel)".into(),
        )),
    }
}

fn to_pb_command(c: SutCommand) -> pb::Command {
    use pb::command::Command as C;
    pb::Command {
        actor_id: String::new(),
        command: Some(match c {
            SutCommand::Pedals {
                throttle,
                brake,
                steering,
            } => C::Pedals(pb::Pedals {
                throttle,
                brake,
                steering,
            }),
            SutCommand::Physical {
                drive_force_n,
                brake_force_n,
                steering_wheel_angle_rad,
            } => C::Physical(pb::Physical {
                drive_force_n,
                brake_force_n,
                steering_wheel_angle_rad,
            }),
            SutCommand::Accel {
                acceleration,
                curvature,
                reverse,
            } => C::Accel(pb::Accel {
                acceleration,
                curvature,
                reverse,
            }),
        }),
    }
}

/// Most runs one server keeps state for at once (the oldest goes first).
pub const MAX_RUNS: usize = 1024;

/// The SUTs of the runs a server holds, and their ids oldest first.
type Runs = (BTreeMap<String, Box<dyn Sut>>, VecDeque<String>);

/// Serves a [`SutFactory`]'s SUTs, one per `run_id`.
pub struct SutService {
    factory: Arc<dyn SutFactory>,
    runs: Mutex<Runs>,
}

impl SutService {
    /// Serves `factory`.
    pub fn new(factory: Arc<dyn SutFactory>) -> Self {
        Self {
            factory,
            runs: Mutex::new((BTreeMap::new(), VecDeque::new())),
        }
    }
}

#[tonic::async_trait]
impl SystemUnderTest for SutService {
    async fn reset(
        &self,
        req: Request<pb::ResetRequest>,
    ) -> Result<Response<pb::ResetReply>, Status> {
        let r = req.into_inner();
        let route = r.route.unwrap_or_default();
        let pts: Vec<[f64; 2]> = route.points.iter().map(|p| [p.x, p.y]).collect();
        let info = SutInfo {
            test: r.test,
            seed: r.seed,
            map_path: r.map_path.clone(),
            step_ms: r.step_ms,
            ego_id: r.ego_id,
            length: r.length,
            width: r.width,
            wheelbase: r.wheelbase,
            max_steer: r.max_steer,
            max_accel: r.max_accel,
            max_decel: r.max_decel,
            route: Route::new(&pts, &route.speed),
            timeout_s: r.timeout_s,
            map: None,
        };
        let mut sut = self
            .factory
            .create()
            .map_err(|e| Status::internal(e.to_string()))?;
        sut.reset(&info)
            .map_err(|e| Status::failed_precondition(e.to_string()))?;
        let mut g = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        if !g.0.contains_key(&r.run_id) {
            g.1.push_back(r.run_id.clone());
        }
        g.0.insert(r.run_id, sut);
        while g.1.len() > MAX_RUNS {
            if let Some(old) = g.1.pop_front() {
                g.0.remove(&old);
            }
        }
        Ok(Response::new(pb::ResetReply {}))
    }

    async fn step(&self, req: Request<pb::StepRequest>) -> Result<Response<pb::Command>, Status> {
        let r = req.into_inner();
        let obs = Observation {
            tick: r.tick,
            time: r.time,
            ego: r.ego.map(obj_from).unwrap_or_default(),
            objects: r.objects.into_iter().map(obj_from).collect(),
            lights: r
                .lights
                .into_iter()
                .map(|l| LightState {
                    id: l.id,
                    road: l.road,
                    s: l.s,
                    color: l.color,
                })
                .collect(),
            road: r.road.map(|p| RoadPos {
                road: p.road,
                lane: p.lane,
                s: p.s,
                offset: p.offset,
            }),
            requested_speed: r.requested_speed,
            distance_to_goal: r.distance_to_goal,
        };
        let mut g = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        let sut = g.0.get_mut(&r.run_id).ok_or_else(|| {
            Status::not_found(format!(
                "no run '{}' (call Reset first)",
                bounded(&r.run_id)
            ))
        })?;
        let cmd = sut
            .step(&obs)
            .map_err(|e| Status::internal(e.to_string()))?;
        Ok(Response::new(to_pb_command(cmd)))
    }
}

/// Serves `factory` on `listener` until `shutdown` completes.
pub async fn serve_sut(
    listener: tokio::net::TcpListener,
    factory: Arc<dyn SutFactory>,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<(), tonic::transport::Error> {
    let incoming = crate::server::nodelay_incoming(listener);
    tonic::transport::Server::builder()
        .add_service(SystemUnderTestServer::new(SutService::new(factory)))
        .serve_with_incoming_shutdown(incoming, shutdown)
        .await
}

/// A SUT server on an ephemeral loopback port, in its own thread (tests,
/// benchmarks).
pub struct LoopbackSutServer {
    /// Where it listens.
    pub addr: std::net::SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl LoopbackSutServer {
    /// Starts serving `factory`.
    pub fn start(factory: Arc<dyn SutFactory>) -> std::io::Result<Self> {
        let (tx, rx) = std::sync::mpsc::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            else {
                return;
            };
            rt.block_on(async move {
                let l = match tokio::net::TcpListener::bind("127.0.0.1:0").await {
                    Ok(l) => l,
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        return;
                    }
                };
                let _ = tx.send(l.local_addr());
                let _ = serve_sut(l, factory, async {
                    let _ = stopped.await;
                })
                .await;
            });
        });
        let addr = rx
            .recv()
            .map_err(|_| std::io::Error::other("the SUT server ended before binding"))??;
        Ok(Self {
            addr,
            stop: Some(stop),
            thread: Some(thread),
        })
    }
}

impl Drop for LoopbackSutServer {
    fn drop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A built-in SUT by name, as a factory (for `litesim sut-serve`).
#[derive(Clone, Debug)]
pub struct BuiltinFactory(pub String);

impl SutFactory for BuiltinFactory {
    fn name(&self) -> String {
        self.0.clone()
    }
    fn create(&self) -> Result<Box<dyn Sut>, SutError> {
        litesim_scenario::sut::SutChoice::builtin(&self.0)
            .ok_or_else(|| SutError(format!("unknown SUT '{}'", self.0)))?
            .instantiate()?
            .ok_or_else(|| SutError("'planned' is not a system that can be served".into()))
    }
}
