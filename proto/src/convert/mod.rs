//! `From`/`TryFrom` between protocol messages and the farm's types, and the
//! content-addressed encoding of scenes.

mod blob;
mod scene;
mod stats;
mod tile;

pub use blob::{blob_chunks, BlobAssembler, ChunkError};
pub use scene::{decode_manifest, decode_scene, encode_scene, Blob, Hash, SceneDecodeError};
pub use tile::TileDecodeError;
