//! The scene description: what the coordinator's parser produces from a
//! pbrt-v3 file and ships to workers, who build a renderable scene from it
//! without touching the parsing host's file system.

mod description;
mod loc;
mod params;

pub use description::*;
pub use loc::{FileLoc, Warning};
pub use params::{record_lookups, Lookup, Param, ParamSet, ParamValue, Params, TextureRef};
