//! `Shape "heightfield"` (pbrt-v3 `shapes/heightfield.cpp`): a grid of
//! heights over the unit square, made into a triangle mesh.

use super::mesh::{build_mesh, warn, MeshData};
use super::{Placement, Shape};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::scene::{Params, Warning};

/// The triangles of a `Shape "heightfield"` (pbrt-v3 `CreateHeightfield`).
pub(super) fn create(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
    let nu = params.int("nu", -1);
    let nv = params.int("nv", -1);
    let pz = params.floats("Pz");
    let Some(pz) = pz.filter(|z| nu > 1 && nv > 1 && z.len() == (nu as usize) * (nv as usize))
    else {
        warn(
            warnings,
            "heightfield needs \"nu\" and \"nv\" > 1 and nu*nv \"Pz\" values. Ignoring.".into(),
        );
        return vec![];
    };
    let (nu, nv) = (nu as usize, nv as usize);
    let mut p = Vec::with_capacity(nu * nv);
    let mut uv = Vec::with_capacity(nu * nv);
    for y in 0..nv {
        for x in 0..nu {
            let (px, py) = (x as f32 / (nu - 1) as f32, y as f32 / (nv - 1) as f32);
            p.push(Vec3::new(px, py, pz[y * nu + x]));
            uv.push(Vec2::new(px, py));
        }
    }
    let vert = |x: usize, y: usize| (x + y * nu) as u32;
    let mut indices = Vec::with_capacity(6 * (nu - 1) * (nv - 1));
    for y in 0..nv - 1 {
        for x in 0..nu - 1 {
            indices.extend_from_slice(&[vert(x, y), vert(x + 1, y), vert(x + 1, y + 1)]);
            indices.extend_from_slice(&[vert(x, y), vert(x + 1, y + 1), vert(x, y + 1)]);
        }
    }
    build_mesh(
        "heightfield",
        MeshData { indices, p, uv: Some(uv), ..Default::default() },
        pl,
        warnings,
    )
}
