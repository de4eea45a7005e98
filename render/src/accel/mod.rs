//! Acceleration structures. pbrt-v3's `Accelerator "bvh"` is the only one:
//! a `"kdtree"` accelerator in a scene is built as a BVH too.

mod bvh;
mod sah;

pub use bvh::{Bvh, DEFAULT_MAX_PRIMS_IN_NODE};
