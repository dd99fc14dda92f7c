//! The system-under-test API over a real loopback socket: a SUT served by
//! `serve_sut` drives a run exactly as in-process, and a server that
//! answers wrongly gives the run a sut-error verdict.

use litesim_grpc::sut::{BuiltinFactory, GrpcSutFactory, LoopbackSutServer};
use litesim_grpc::sut_pb as pb;
use litesim_grpc::sut_pb::system_under_test_server::{SystemUnderTest, SystemUnderTestServer};
use litesim_scenario::sut::SutChoice;
use litesim_scenario::{LoadOptions, RunOptions, RunResult, prepare, run};
use std::path::PathBuf;
use std::sync::Arc;
use tonic::{Request, Response, Status};

fn cut_in(sut: SutChoice) -> RunResult {
    let p = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/scenarios/cut_in.osc"
    ));
    let prep = prepare(&p, &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        record: true,
        sut,
        ..RunOptions::default()
    };
    run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap()
}

#[test]
fn a_served_sut_drives_exactly_as_in_process() {
    let server = LoopbackSutServer::start(Arc::new(BuiltinFactory("acc".into()))).unwrap();
    let f = GrpcSutFactory::new(&format!("grpc://{}", server.addr)).unwrap();
    let remote = cut_in(SutChoice::External(Arc::new(f)));
    let local = cut_in(SutChoice::Acc);
    assert!(remote.summary.pass, "{:?}", remote.summary.failures);
    assert_eq!(
        serde_json::to_string(&remote.log.unwrap()).unwrap(),
        serde_json::to_string(&local.log.unwrap()).unwrap()
    );
}

/// A SUT server that answers every step with `reply`.
struct Fixed(pb::Command);

#[tonic::async_trait]
impl SystemUnderTest for Fixed {
    async fn reset(
        &self,
        _: Request<pb::ResetRequest>,
    ) -> Result<Response<pb::ResetReply>, Status> {
        Ok(Response::new(pb::ResetReply {}))
    }
    async fn step(&self, _: Request<pb::StepRequest>) -> Result<Response<pb::Command>, Status> {
        Ok(Response::new(self.0.clone()))
    }
}

/// Serves `reply` on a loopback port in a thread of its own.
fn serve_fixed(reply: pb::Command) -> std::net::SocketAddr {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async move {
            let l = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            tx.send(l.local_addr().unwrap()).unwrap();
            tonic::transport::Server::builder()
                .add_service(SystemUnderTestServer::new(Fixed(reply)))
                .serve_with_incoming(tokio_stream::wrappers::TcpListenerStream::new(l))
                .await
                .unwrap();
        });
    });
    rx.recv().unwrap()
}

#[test]
fn wrong_answers_are_sut_errors() {
    let accel = Some(pb::command::Command::Accel(pb::Accel {
        acceleration: 0.0,
        curvature: 0.0,
        reverse: false,
    }));
    for (reply, want) in [
        (
            pb::Command {
                actor_id: "other".into(),
                command: accel,
            },
            "sut error at t=0.00 s: it commanded the unknown actor 'other' (it drives sut.car only)",
        ),
        (
            pb::Command {
                actor_id: String::new(),
                command: None,
            },
            "sut error at t=0.00 s: it returned an empty command",
        ),
        (
            pb::Command {
                actor_id: "sut.car".into(),
                command: Some(pb::command::Command::Pedals(pb::Pedals {
                    throttle: f64::INFINITY,
                    brake: 0.0,
                    steering: 0.0,
                })),
            },
            "sut error at t=0.00 s: it returned a bad command: throttle is inf, expected a finite number",
        ),
    ] {
        let addr = serve_fixed(reply);
        let f = GrpcSutFactory::new(&format!("grpc://{addr}")).unwrap();
        let r = cut_in(SutChoice::External(Arc::new(f)));
        assert!(!r.summary.pass);
        assert!(
            r.summary.failures.iter().any(|f| f.starts_with(want)),
            "{want}: {:?}",
            r.summary.failures
        );
        assert_eq!(r.summary.steps, 0);
    }
}

#[test]
fn a_sut_behind_tls_and_a_token_is_reached_with_its_ca_and_token() {
    use litesim_grpc::sut::{Auth, SutService};
    let ck = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
    let cert = ck.cert.pem();
    let identity = tonic::transport::Identity::from_pem(&cert, ck.signing_key.serialize_pem());
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let listener = rt
        .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
        .unwrap();
    let port = listener.local_addr().unwrap().port();
    let check = |req: Request<()>| match req.metadata().get("authorization") {
        Some(v) if v == "Bearer sut-token" => Ok(req),
        _ => Err(Status::unauthenticated("no token")),
    };
    let svc = SystemUnderTestServer::with_interceptor(
        SutService::new(Arc::new(BuiltinFactory("acc".into()))),
        check,
    );
    rt.spawn(
        tonic::transport::Server::builder()
            .tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))
            .unwrap()
            .add_service(svc)
            .serve_with_incoming(tokio_stream::wrappers::TcpListenerStream::new(listener)),
    );
    let with = |auth: Auth| {
        let f = GrpcSutFactory::new(&format!("grpc://localhost:{port}"))
            .unwrap()
            .with_auth(auth);
        cut_in(SutChoice::External(Arc::new(f)))
    };
    // The CA and the token: the run is the in-process one.
    let r = with(Auth {
        token: Some("sut-token".into()),
        ca_pem: Some(cert.clone().into_bytes()),
    });
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    assert_eq!(r.summary.steps, 500);
    // Without the token: the SUT's error ends the run, saying why.
    let r = with(Auth {
        token: None,
        ca_pem: Some(cert.into_bytes()),
    });
    assert_eq!(r.summary.verdict, litesim_scenario::Verdict::Error);
    assert!(
        r.summary
            .failures
            .iter()
            .any(|f| f.contains("Unauthenticated")),
        "{:?}",
        r.summary.failures
    );
}

/// The reverse gear over a real socket: a SUT that answers every step
/// with "8 m/s² in reverse" has sut.car braked to rest first (it starts
/// moving forwards; at the command's rate), then backing up, faster and
/// faster (at most the model's acceleration).
#[test]
fn a_sut_over_grpc_can_put_the_car_in_reverse() {
    let reply = pb::Command {
        actor_id: String::new(),
        command: Some(pb::command::Command::Accel(pb::Accel {
            acceleration: 8.0,
            curvature: 0.0,
            reverse: true,
        })),
    };
    let addr = serve_fixed(reply);
    let f = GrpcSutFactory::new(&format!("grpc://{addr}")).unwrap();
    let r = cut_in(SutChoice::External(Arc::new(f)));
    let log = r.log.as_ref().unwrap();
    let ego = log.tracks.iter().find(|t| t.id == "sut.car").unwrap();
    let v = &ego.state.speed;
    assert!(v[0] > 1.0, "starts moving forwards: {}", v[0]);
    let first_back = v
        .iter()
        .position(|&v| v < 0.0)
        .unwrap_or_else(|| panic!("never reversed: {:?} {:?}", &v[..5], r.summary.failures));
    // At rest before backwards: no step jumps from forwards to backwards.
    assert!(v[..first_back].iter().all(|&v| v >= 0.0));
    assert!(v[first_back - 1].abs() < 1e-9, "{}", v[first_back - 1]);
    // Then speeding up backwards, monotonically.
    let back = &v[first_back..];
    assert!(back.windows(2).all(|w| w[1] <= w[0] + 1e-12));
    assert!(*back.last().unwrap() < -1.0, "{}", back.last().unwrap());
}
