//! Generates the gRPC code from proto/renderfarm/v1/*.proto with the
//! pure-Rust `protox` compiler, so no system `protoc` is needed.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let protos = ["renderfarm/v1/farm.proto"];
    for p in protos {
        println!("cargo:rerun-if-changed={p}");
    }
    let fds = protox::compile(protos, ["."])?;
    // Every service encodes through farm_proto's codec (see src/codec.rs).
    tonic_prost_build::configure().codec_path("crate::codec::ReservingCodec").compile_fds(fds)?;
    Ok(())
}
