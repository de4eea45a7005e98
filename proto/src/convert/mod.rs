//! `From`/`TryFrom` between protocol messages and the farm's types, and the
//! content-addressed encoding of scenes.

mod blob;
mod image;
mod preview;
mod scene;
mod stats;
mod tile;

pub use blob::{blob_chunks, BlobAssembler, ChunkSequence};
pub use image::{
    image_chunks, image_chunks_copied, le_bytes, stop_from_name, stop_name, AssembledImage,
    FireflyFacts, ImageAssembler, ImageFacts, IMAGE_CHUNK_BYTES,
};
pub use preview::{decode_preview, push_piece, PREVIEW_PIECE};
pub use scene::{
    attach_asset, decode_manifest, decode_scene, encode_scene, is_shape_key, Blob, Hash,
};
