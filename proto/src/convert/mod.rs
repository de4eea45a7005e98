//! `From`/`TryFrom` between protocol messages and the farm's types, and the
//! content-addressed encoding of scenes.

mod scene;
mod stats;
mod tile;

pub use scene::{decode_manifest, decode_scene, encode_scene, Blob, Hash, SceneDecodeError};
pub use tile::TileDecodeError;
