//! Compiles `proto/` with protox (pure Rust, no system `protoc` needed) and
//! generates the tonic servers and clients; the SSP descriptor set is kept
//! for the reflection service.
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?).join("../../proto");
    let ssp = root.join("litesim/ssp/v1/ssp.proto");
    let sut = root.join("litesim/sut/v1/sut.proto");
    println!("cargo:rerun-if-changed={}", ssp.display());
    println!("cargo:rerun-if-changed={}", sut.display());
    let fds = protox::compile([&ssp], [&root])?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(
        out.join("ssp_descriptor.bin"),
        prost::Message::encode_to_vec(&fds),
    )?;
    let both = protox::compile([&ssp, &sut], [&root])?;
    tonic_prost_build::configure()
        // Ordered maps: no HashMap iteration order may leak into outputs or traces.
        .btree_map(".")
        .build_client(true)
        .build_server(true)
        .compile_fds(both)?;
    Ok(())
}
