//! Helpers shared by the gRPC test binaries.
#![allow(dead_code)]

/// What the standard gRPC health service at `addr` (`HOST:PORT`) says of
/// the SSP service: asked with a plain client, no token.
pub fn health_status(addr: &str) -> i32 {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let ch = tonic::transport::Channel::from_shared(format!("http://{addr}"))
            .unwrap()
            .connect()
            .await
            .unwrap();
        let mut h = tonic_health::pb::health_client::HealthClient::new(ch);
        h.check(tonic_health::pb::HealthCheckRequest {
            service: "litesim.ssp.v1.SimulatorSupport".into(),
        })
        .await
        .unwrap()
        .into_inner()
        .status
    })
}
