//! The gRPC server's request handling must answer any bytes with a status,
//! never a panic: the input is cut into (kind, length, bytes) chunks, each
//! decoded as a protobuf request of that kind (as tonic would decode it off
//! the wire) and handed to the real `SspService` handler, in order, on one
//! session (its id is filled in where the bytes left it empty, so that the
//! calls reach the session's own checks).
#![no_main]
use libfuzzer_sys::fuzz_target;
use litesim_grpc::pb;
use litesim_grpc::pb::simulator_support_server::SimulatorSupport;
use litesim_grpc::{ServerConfig, SspService};
use prost::Message;
use std::sync::OnceLock;
use tonic::Request;

fn rt() -> &'static tokio::runtime::Runtime {
    static RT: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RT.get_or_init(|| {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
    })
}

macro_rules! call {
    ($svc:expr, $sid:expr, $bytes:expr, $ty:ty, $m:ident) => {{
        if let Ok(mut r) = <$ty>::decode($bytes) {
            if r.session_id.is_empty() {
                r.session_id = $sid.clone();
            }
            let _ = $svc.$m(Request::new(r)).await;
        }
    }};
}

fuzz_target!(|data: &[u8]| {
    rt().block_on(async {
        let Ok(svc) = SspService::new(ServerConfig::default()) else {
            return;
        };
        let sid = match svc
            .init(Request::new(pb::InitRequest::default()))
            .await
        {
            Ok(r) => r.into_inner().session_id,
            Err(_) => String::new(),
        };
        let mut rest = data;
        while rest.len() >= 3 {
            let kind = rest[0];
            let len = (usize::from(rest[1]) << 8 | usize::from(rest[2])).min(rest.len() - 3);
            let bytes = &rest[3..3 + len];
            rest = &rest[3 + len..];
            match kind % 20 {
                0 => call!(svc, sid, bytes, pb::LaunchSimulatorRequest, launch_simulator),
                1 => call!(svc, sid, bytes, pb::StartSimulationRequest, start_simulation),
                2 => call!(svc, sid, bytes, pb::StepRequest, step),
                3 => call!(svc, sid, bytes, pb::StepManyRequest, step_many),
                4 => call!(svc, sid, bytes, pb::GetActorsStatesRequest, get_actors_states),
                5 => call!(svc, sid, bytes, pb::CreateActorRequest, create_actor),
                6 => call!(svc, sid, bytes, pb::SetActorParamsRequest, set_actor_params),
                7 => call!(svc, sid, bytes, pb::DestroyActorRequest, destroy_actor),
                8 => call!(svc, sid, bytes, pb::SetXyTrajectoryRequest, set_xy_trajectory),
                9 => call!(svc, sid, bytes, pb::SetDynamicMoveRequest, set_dynamic_move),
                10 => call!(svc, sid, bytes, pb::SetExternalControllerRequest, set_external_controller),
                11 => call!(svc, sid, bytes, pb::SetWeatherRequest, set_weather),
                12 => call!(svc, sid, bytes, pb::SetTimeOfDayRequest, set_time_of_day),
                13 => call!(svc, sid, bytes, pb::SimCommandRequest, sim_command),
                14 => call!(svc, sid, bytes, pb::ListTrafficLightsRequest, list_traffic_lights),
                15 => call!(svc, sid, bytes, pb::SetTrafficLightStateRequest, set_traffic_light_state),
                16 => call!(svc, sid, bytes, pb::StartStepRequest, start_step),
                17 => call!(svc, sid, bytes, pb::WaitStepRequest, wait_step),
                18 => call!(svc, sid, bytes, pb::EndSimulationRequest, end_simulation),
                _ => call!(svc, sid, bytes, pb::KeepAliveRequest, keep_alive),
            }
        }
    });
});
