//! The farm's wire protocol, `renderfarm.v1`: the generated messages and
//! service stubs, and conversions between them and the farm's own types.
//! Generated types stay inside this crate's `v1` module.
#![warn(missing_docs)]

/// Generated code for package `renderfarm.v1`.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod v1 {
    tonic::include_proto!("renderfarm.v1");
}

/// Tokens and roles.
pub mod auth;
/// The services' codec.
pub mod codec;
/// Connecting to a coordinator over TLS or, on loopback, plaintext.
pub mod connect;
/// Conversions between protocol messages and farm types.
pub mod convert;
/// What can be wrong with what arrives.
pub mod error;

pub use error::{Error, Result};

/// The protocol version workers and clients must speak. Bump it on any
/// incompatible change to the .proto files, or to what a worker renders
/// from the same manifest: every worker of a job must give the same bits.
/// 4: lights in directive order (a manifest's trailing list), and the
/// pbrt-v3 behaviours that came with it (see `scenes/parity/twins/`).
pub const PROTOCOL_VERSION: u32 = 4;

/// Largest message the farm's services accept or send (images, tiles and
/// blob chunks stay below it).
pub const MAX_MESSAGE_SIZE: usize = 64 * 1024 * 1024;

/// Size of the pieces blobs are streamed in.
pub const BLOB_CHUNK_SIZE: usize = 1024 * 1024;

/// Tiles a worker of `threads` render threads holds when its `Hello` asks
/// for 0 (the default): 4 × threads + 2, enough to keep every thread busy
/// over a round trip to the coordinator.
pub fn default_in_flight(threads: usize) -> u32 {
    u32::try_from(threads.max(1)).unwrap_or(u32::MAX / 2).saturating_mul(4).saturating_add(2)
}
