//! Acceleration structures. pbrt-v3's `Accelerator "bvh"` is the only one:
//! a `"kdtree"` accelerator in a scene is built as a BVH too.

mod buckets;
mod bvh;
mod collapse;
mod node;
mod sah;

pub use bvh::{any_in_leaf, closest_in_leaf, Bvh, DEFAULT_MAX_PRIMS_IN_NODE};
pub use node::{detected_simd, force_simd, simd, Simd};

use farm_common::scene::{Entity, Params, Warning};

/// The leaf size the scene's `Accelerator` asks for (pbrt-v3
/// `CreateBVHAccelerator`: `maxnodeprims`, at most 255). pbrt-v3's other
/// split methods change only the build's speed, never the image; farm
/// always splits by the surface area heuristic and says so.
pub fn max_prims_in_node(accel: &Entity, warnings: &mut Vec<Warning>) -> usize {
    if accel.name.is_empty() {
        return DEFAULT_MAX_PRIMS_IN_NODE;
    }
    if accel.name != "bvh" {
        warnings.push(Warning::at(
            &accel.loc,
            format!("Accelerator \"{}\" is not supported; using \"bvh\"", accel.name),
        ));
        return DEFAULT_MAX_PRIMS_IN_NODE;
    }
    let p = Params::new(&accel.params);
    let n = p.int("maxnodeprims", DEFAULT_MAX_PRIMS_IN_NODE as i32).clamp(1, 255) as usize;
    let split = p.string("splitmethod", "sah");
    if split != "sah" {
        let what = if matches!(split.as_str(), "hlbvh" | "middle" | "equal") {
            "is not built here (the image is the same)"
        } else {
            "is unknown"
        };
        warnings.push(Warning::at(
            &accel.loc,
            format!("BVH split method \"{split}\" {what}; using \"sah\""),
        ));
    }
    warnings.extend(p.unused_warnings());
    n
}
