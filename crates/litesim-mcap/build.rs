//! Generates the OSI message types from the committed FileDescriptorSet
//! (`osi/osi3.fds.bin`, written by `tools/gen_osi_descriptors.py` from the
//! osi-python package): prost only, no protoc.
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let fds_path = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?).join("osi/osi3.fds.bin");
    println!("cargo:rerun-if-changed={}", fds_path.display());
    let bytes = std::fs::read(&fds_path)?;
    let fds: prost_types::FileDescriptorSet = prost::Message::decode(bytes.as_slice())?;
    prost_build::Config::new()
        // Ordered maps: no HashMap order may reach a written file.
        .btree_map(["."])
        .compile_fds(fds)?;
    Ok(())
}
