//! Generates the gRPC code from proto/renderfarm/v1/*.proto with the
//! pure-Rust `protox` compiler, so no system `protoc` is needed.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let protos = ["renderfarm/v1/farm.proto"];
    for p in protos {
        println!("cargo:rerun-if-changed={p}");
    }
    let fds = protox::compile(protos, ["."])?;
    // Every service encodes through farm_proto's codec (see src/codec.rs).
    // A finished image's rows are slices of one shared buffer
    // (`convert::image::image_chunks`), not copies.
    tonic_prost_build::configure()
        .codec_path("crate::codec::ReservingCodec")
        .bytes(".renderfarm.v1.JobImage.rgb")
        .bytes(".renderfarm.v1.JobImage.error_map")
        .compile_fds(fds)?;
    Ok(())
}
