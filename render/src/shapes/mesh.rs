//! Building triangle meshes from `trianglemesh` (and `plymesh`) directives
//! with pbrt-v3's parameter names, checks and messages
//! (`CreateTriangleMeshShape`), and moving any mesh's object-space data to
//! render space as one shape per triangle.

use super::triangle::{AlphaMask, AlphaTexture, TriangleMesh};
use super::{Placement, Shape};
use crate::textures::TextureSet;
use farm_common::geometry::{Vec2, Vec3};
use farm_common::scene::{Params, Warning};
use std::sync::Arc;

/// A warning without a location: the caller knows the directive's.
pub(super) fn warn(w: &mut Vec<Warning>, message: String) {
    w.push(Warning { loc: None, message });
}

/// Reads `alpha`/`shadowalpha` as pbrt-v3 does: a float texture, else a float that is 0.
pub(super) fn alpha_param(
    params: &Params,
    name: &str,
    textures: Option<&Arc<TextureSet>>,
    warnings: &mut Vec<Warning>,
) -> AlphaMask {
    if let Some(t) = params.texture(name) {
        match (t.float_id, textures) {
            (Some(id), Some(set)) if matches!(set.floats.get(id as usize), Some(Some(_))) => {
                return AlphaMask::Texture(AlphaTexture { textures: set.clone(), id });
            }
            _ => {}
        }
        warn(
            warnings,
            format!("Couldn't find float texture \"{}\" for \"{name}\" parameter", t.name),
        );
        return AlphaMask::None;
    }
    if params.float(name, 1.0) == 0.0 {
        AlphaMask::Zero
    } else {
        AlphaMask::None
    }
}

/// Object-space mesh data before it is moved to render space.
#[derive(Default)]
pub(super) struct MeshData {
    pub(super) indices: Vec<u32>,
    pub(super) p: Vec<Vec3>,
    pub(super) n: Option<Vec<Vec3>>,
    pub(super) s: Option<Vec<Vec3>>,
    pub(super) uv: Option<Vec<Vec2>>,
    pub(super) alpha: AlphaMask,
    pub(super) shadow_alpha: AlphaMask,
}

/// Drops a per-vertex attribute holding NaN or infinite values (after the
/// transform to render space), with a warning naming it.
fn finite_or_drop<T: Copy>(
    shape: &str,
    name: &str,
    v: Option<Vec<T>>,
    finite: impl Fn(&T) -> bool,
    warnings: &mut Vec<Warning>,
) -> Option<Vec<T>> {
    let v = v?;
    let bad = v.iter().filter(|x| !finite(x)).count();
    if bad == 0 {
        return Some(v);
    }
    warn(
        warnings,
        format!(
            "{shape}: {bad} non-finite \"{name}\" values. Discarding \"{name}\" for this mesh."
        ),
    );
    None
}

/// Transforms a validated mesh to render space and makes one shape per
/// triangle, skipping triangles with non-finite vertices and dropping
/// non-finite normals, tangents and uvs.
pub(super) fn build_mesh(
    shape: &str,
    d: MeshData,
    pl: &Placement,
    warnings: &mut Vec<Warning>,
) -> Vec<Shape> {
    let t = &pl.render_from_object;
    let n = d.n.map(|n| n.iter().map(|&v| t.normal(v)).collect());
    let s = d.s.map(|s| s.iter().map(|&v| t.vector(v)).collect());
    let mesh = Arc::new(TriangleMesh {
        p: d.p.iter().map(|&p| t.point(p)).collect(),
        n: finite_or_drop(shape, "N", n, |v: &Vec3| v.is_finite(), warnings),
        s: finite_or_drop(shape, "S", s, |v: &Vec3| v.is_finite(), warnings),
        uv: finite_or_drop(shape, "uv", d.uv, |v: &Vec2| v.is_finite(), warnings),
        reverse_orientation: pl.reverse_orientation,
        transform_swaps_handedness: pl.transform_swaps_handedness,
        alpha: d.alpha,
        shadow_alpha: d.shadow_alpha,
    });
    let mut skipped = 0usize;
    let mut out = Vec::with_capacity(d.indices.len() / 3);
    for tri in d.indices.chunks_exact(3) {
        let v = [tri[0], tri[1], tri[2]];
        if v.iter().any(|&i| !mesh.p[i as usize].is_finite()) {
            skipped += 1;
            continue;
        }
        out.push(Shape::Triangle { mesh: mesh.clone(), v });
    }
    if skipped > 0 {
        warn(
            warnings,
            format!(
                "{shape}: skipped {skipped} of {} triangles with non-finite vertex positions.",
                d.indices.len() / 3
            ),
        );
    }
    out
}

/// The triangles of a `Shape "trianglemesh"`.
pub(super) fn triangle_mesh(
    params: &Params,
    pl: &Placement,
    textures: Option<&Arc<TextureSet>>,
    warnings: &mut Vec<Warning>,
) -> Vec<Shape> {
    let vi = params.ints("indices");
    let p = params.point3s("P");
    let mut uvs: Option<Vec<Vec2>> = params
        .point2s("uv")
        .or_else(|| params.point2s("st"))
        .map(|v| v.iter().map(|&a| Vec2::from(a)).collect());
    if uvs.is_none() {
        if let Some(fuv) = params.floats("uv").or_else(|| params.floats("st")) {
            uvs = Some(fuv.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect());
        }
    }
    let s = params.vector3s("S");
    let n = params.normals("N");
    // pbrt-v3 keeps per-face indices for Ptex lookups; without Ptex they
    // change nothing.
    params.touch("faceIndices");
    let alpha = alpha_param(params, "alpha", textures, warnings);
    let shadow_alpha = alpha_param(params, "shadowalpha", textures, warnings);
    let Some(p) = p else {
        warn(warnings, "Vertex positions \"P\" not provided with triangle mesh shape".into());
        return vec![];
    };
    let npi = p.len();
    if let Some(uv) = &uvs {
        if uv.len() < npi {
            warn(
                warnings,
                format!(
                    "Not enough of \"uv\"s for triangle mesh.  Expected {npi}, found {}.  Discarding.",
                    uv.len()
                ),
            );
            uvs = None;
        } else if uv.len() > npi {
            warn(
                warnings,
                format!(
                    "More \"uv\"s provided than will be used for triangle mesh.  ({npi} expcted, {} found)",
                    uv.len()
                ),
            );
        }
    }
    let mut indices: Vec<i32> = match vi {
        Some(vi) => vi.to_vec(),
        None if npi == 3 => vec![0, 1, 2],
        None => {
            warn(
                warnings,
                "Vertex indices \"indices\" not provided with triangle mesh shape".into(),
            );
            return vec![];
        }
    };
    if !indices.len().is_multiple_of(3) {
        let excess = indices.len() % 3;
        warn(
            warnings,
            format!(
                "Number of vertex indices {} not a multiple of 3. Discarding {excess} excess.",
                indices.len()
            ),
        );
        indices.truncate(indices.len() - excess);
    }
    let s = match s {
        Some(s) if s.len() != npi => {
            warn(warnings, "Number of \"S\"s for triangle mesh must match \"P\"s".into());
            None
        }
        s => s,
    };
    let n = match n {
        Some(n) if n.len() != npi => {
            warn(warnings, "Number of \"N\"s for triangle mesh must match \"P\"s".into());
            None
        }
        n => n,
    };
    if let Some(&bad) = indices.iter().find(|&&i| i < 0 || i as usize >= npi) {
        warn(
            warnings,
            format!("trianglemesh has out of-bounds vertex index {bad} ({npi} \"P\" values were given. Discarding this mesh."),
        );
        return vec![];
    }
    let v3 = |v: &[[f32; 3]]| v.iter().map(|&a| Vec3::from(a)).collect::<Vec<_>>();
    let data = MeshData {
        indices: indices.iter().map(|&i| i as u32).collect(),
        p: v3(p),
        n: n.map(v3),
        s: s.map(v3),
        uv: uvs,
        alpha,
        shadow_alpha,
    };
    build_mesh("trianglemesh", data, pl, warnings)
}
