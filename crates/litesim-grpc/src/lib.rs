//! # litesim-grpc
//!
//! litesim's SSP API on the wire: the generated protobuf types ([`pb`],
//! from `proto/litesim/ssp/v1/ssp.proto`, compiled by the pure-Rust `protox`),
//! a tonic [`server`] that hosts many independent sessions, and a blocking
//! [`client::RemoteSsp`] that implements `litesim_ssp::Ssp` over gRPC, so a
//! scenario engine drives a remote server exactly as it drives the
//! in-process model — with bit-identical results.
//!
//! It also carries the system-under-test API (`proto/litesim/sut/v1`):
//! [`sut::GrpcSut`] drives an external driving function in lock step, and
//! [`sut::serve_sut`] serves any in-process SUT over it.
//!
//! This is the only crate that knows protobuf and tonic.
#![warn(missing_docs)]

/// Generated protobuf and tonic code.
#[allow(missing_docs, clippy::all)]
pub mod pb {
    tonic::include_proto!("litesim.ssp.v1");
}

/// Generated protobuf and tonic code of the system-under-test API.
#[allow(missing_docs, clippy::all)]
pub mod sut_pb {
    tonic::include_proto!("litesim.sut.v1");
}

pub mod client;
pub mod convert;
pub mod server;
pub mod sut;

pub use client::RemoteSsp;
pub use server::{
    LoopbackError, LoopbackServer, ServeError, ServerConfig, SspService, TlsPem, serve,
};
