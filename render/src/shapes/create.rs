//! Building shapes from `Shape` directives with pbrt-v3's parameter names,
//! defaults and error messages (pbrt-v3 `Create*Shape` and `api.cpp` `MakeShapes`).

use super::curve::{Curve, CurveCommon, CurveType};
use super::loopsubdiv::loop_subdivide;
use super::triangle::{AlphaMask, Triangle, TriangleMesh};
use super::{Cone, Cylinder, Disk, Hyperboloid, Paraboloid, Placement, Shape, Sphere};
use farm_common::geometry::{Transform, Vec2, Vec3};
use farm_common::scene::{Params, Warning};
use std::sync::Arc;

fn warn(w: &mut Vec<Warning>, message: String) {
    w.push(Warning { loc: None, message });
}

/// The shapes for one `Shape` directive (`"plymesh"` arrives as `"trianglemesh"`).
/// Problems become warnings (with no location: the caller knows the
/// directive's) and the offending shape or data is skipped.
pub fn create(
    name: &str,
    params: &Params,
    render_from_object: &Transform,
    reverse_orientation: bool,
    warnings: &mut Vec<Warning>,
) -> Vec<Shape> {
    let pl = Placement::new(render_from_object, reverse_orientation);
    let f = |n: &str, d: f32| params.float(n, d);
    match name {
        "sphere" => {
            let radius = f("radius", 1.0);
            let (zmin, zmax) = (f("zmin", -radius), f("zmax", radius));
            vec![Shape::Sphere(Box::new(Sphere::new(pl, radius, zmin, zmax, f("phimax", 360.0))))]
        }
        "cylinder" => {
            let (radius, zmin, zmax) = (f("radius", 1.0), f("zmin", -1.0), f("zmax", 1.0));
            vec![Shape::Cylinder(Box::new(Cylinder::new(
                pl,
                radius,
                zmin,
                zmax,
                f("phimax", 360.0),
            )))]
        }
        "disk" => {
            let (height, radius, inner) =
                (f("height", 0.0), f("radius", 1.0), f("innerradius", 0.0));
            vec![Shape::Disk(Box::new(Disk::new(pl, height, radius, inner, f("phimax", 360.0))))]
        }
        "cone" => {
            let (radius, height) = (f("radius", 1.0), f("height", 1.0));
            vec![Shape::Cone(Box::new(Cone::new(pl, height, radius, f("phimax", 360.0))))]
        }
        "paraboloid" => {
            let (radius, zmin, zmax) = (f("radius", 1.0), f("zmin", 0.0), f("zmax", 1.0));
            vec![Shape::Paraboloid(Box::new(Paraboloid::new(
                pl,
                radius,
                zmin,
                zmax,
                f("phimax", 360.0),
            )))]
        }
        "hyperboloid" => {
            let p1 = params.point3("p1", Vec3::ZERO);
            let p2 = params.point3("p2", Vec3::ONE);
            match Hyperboloid::new(pl, p1, p2, f("phimax", 360.0)) {
                Some(h) => vec![Shape::Hyperboloid(Box::new(h))],
                None => {
                    warn(
                        warnings,
                        "Degenerate hyperboloid: cannot compute its implicit form. Ignoring."
                            .into(),
                    );
                    vec![]
                }
            }
        }
        "trianglemesh" => triangle_mesh(params, &pl, warnings),
        "loopsubdiv" => loop_subdiv(params, &pl, warnings),
        "heightfield" => heightfield(params, &pl, warnings),
        "curve" => curves(params, &pl, warnings),
        _ => {
            warn(warnings, format!("Shape \"{name}\" unknown."));
            vec![]
        }
    }
}

/// Reads `alpha`/`shadowalpha` as pbrt-v3 does: a float texture, else a float that is 0.
fn alpha_param(params: &Params, name: &str, warnings: &mut Vec<Warning>) -> AlphaMask {
    if let Some(t) = params.texture(name) {
        if t.float_id.is_some() {
            return AlphaMask::Texture(t.clone());
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
struct MeshData {
    indices: Vec<u32>,
    p: Vec<Vec3>,
    n: Option<Vec<Vec3>>,
    s: Option<Vec<Vec3>>,
    uv: Option<Vec<Vec2>>,
    alpha: AlphaMask,
    shadow_alpha: AlphaMask,
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
fn build_mesh(shape: &str, d: MeshData, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
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
        out.push(Shape::Triangle(Triangle { mesh: mesh.clone(), v }));
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

fn triangle_mesh(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
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
    let alpha = alpha_param(params, "alpha", warnings);
    let shadow_alpha = alpha_param(params, "shadowalpha", warnings);
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

fn loop_subdiv(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
    let nlevels = params.int("nlevels", 3);
    let mut levels = params.int("levels", nlevels);
    let vi = params.ints("indices");
    let p = params.point3s("P");
    let _scheme = params.string("scheme", "loop");
    let Some(vi) = vi else {
        warn(warnings, "Vertex indices \"indices\" not provided for LoopSubdiv shape.".into());
        return vec![];
    };
    let Some(p) = p else {
        warn(warnings, "Vertex positions \"P\" not provided for LoopSubdiv shape.".into());
        return vec![];
    };
    if !(0..=10).contains(&levels) {
        warn(warnings, format!("LoopSubdiv \"levels\" {levels} out of range [0, 10]; clamping."));
        levels = levels.clamp(0, 10);
    }
    let nf = vi.len() / 3;
    let vi = &vi[..nf * 3];
    if vi.iter().any(|&i| i < 0 || i as usize >= p.len()) {
        warn(
            warnings,
            format!(
                "loopsubdiv has out of-bounds vertex index ({} \"P\" values were given). Discarding.",
                p.len()
            ),
        );
        return vec![];
    }
    if p.iter().any(|q| q.iter().any(|c| !c.is_finite())) {
        warn(warnings, "loopsubdiv has non-finite vertex positions. Discarding.".into());
        return vec![];
    }
    // Drop vertices no face uses (pbrt-v3 would crash on them).
    let mut remap = vec![u32::MAX; p.len()];
    let mut pts = Vec::new();
    let indices: Vec<u32> = vi
        .iter()
        .map(|&i| {
            let r = &mut remap[i as usize];
            if *r == u32::MAX {
                *r = pts.len() as u32;
                pts.push(Vec3::from(p[i as usize]));
            }
            *r
        })
        .collect();
    match loop_subdivide(levels as u32, &indices, &pts) {
        Ok((indices, p, n)) => build_mesh(
            "loopsubdiv",
            MeshData { indices, p, n: Some(n), ..Default::default() },
            pl,
            warnings,
        ),
        Err(e) => {
            warn(warnings, format!("loopsubdiv: {e}; the mesh is ignored."));
            vec![]
        }
    }
}

fn heightfield(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
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

fn lerp3(t: f32, a: Vec3, b: Vec3) -> Vec3 {
    (1.0 - t) * a + t * b
}

fn curves(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
    let width = params.float("width", 1.0);
    let width0 = params.float("width0", width);
    let width1 = params.float("width1", width);
    let degree = params.int("degree", 3);
    if degree != 2 && degree != 3 {
        warn(
            warnings,
            format!("Invalid degree {degree}: only degree 2 and 3 curves are supported."),
        );
        return vec![];
    }
    let basis = params.string("basis", "bezier");
    if basis != "bezier" && basis != "bspline" {
        warn(
            warnings,
            format!("Invalid basis \"{basis}\": only \"bezier\" and \"bspline\" are supported."),
        );
        return vec![];
    }
    let cp: Vec<Vec3> = params.point3s("P").unwrap_or(&[]).iter().map(|&a| Vec3::from(a)).collect();
    let ncp = cp.len() as i64;
    let deg = degree as i64;
    let n_segments = if basis == "bezier" {
        if (ncp - 1 - deg) % deg != 0 {
            warn(
                warnings,
                format!(
                    "Invalid number of control points {ncp}: for the degree {deg} Bezier basis {} + n * {deg} are required, for n >= 0.",
                    deg + 1
                ),
            );
            return vec![];
        }
        ((ncp - 1) / deg).max(0) as usize
    } else {
        if ncp < deg + 1 {
            warn(
                warnings,
                format!(
                    "Invalid number of control points {ncp}: for the degree {deg} b-spline basis, must have >= {}.",
                    deg + 1
                ),
            );
            return vec![];
        }
        (ncp - deg) as usize
    };
    let kind = match params.string("type", "flat").as_str() {
        "flat" => CurveType::Flat,
        "ribbon" => CurveType::Ribbon,
        "cylinder" => CurveType::Cylinder,
        other => {
            warn(warnings, format!("Unknown curve type \"{other}\".  Using \"cylinder\"."));
            CurveType::Cylinder
        }
    };
    let mut normals: Option<Vec<Vec3>> =
        params.normals("N").map(|n| n.iter().map(|&a| Vec3::from(a)).collect());
    if let Some(n) = &normals {
        if kind != CurveType::Ribbon {
            warn(warnings, "Curve normals are only used with \"ribbon\" type curves.".into());
            normals = None;
        } else if n.len() != n_segments + 1 {
            warn(
                warnings,
                format!(
                    "Invalid number of normals {}: must provide {} normals for ribbon curves with {n_segments} segments.",
                    n.len(),
                    n_segments + 1
                ),
            );
            return vec![];
        }
    } else if kind == CurveType::Ribbon {
        warn(warnings, "Must provide normals \"N\" at curve endpoints with ribbon curves.".into());
        return vec![];
    }
    let split_float = params.float("splitdepth", 3.0);
    let mut sd = params.int("splitdepth", split_float as i32);
    if !(0..=16).contains(&sd) {
        warn(warnings, format!("Curve \"splitdepth\" {sd} out of range [0, 16]; clamping."));
        sd = sd.clamp(0, 16);
    }
    if cp.iter().any(|p| !p.is_finite()) {
        warn(warnings, "Curve has non-finite control points. Ignoring.".into());
        return vec![];
    }
    let mut out = Vec::new();
    let mut base = 0usize;
    for seg in 0..n_segments {
        let c = &cp[base..];
        let bez = if basis == "bezier" {
            base += degree as usize;
            if degree == 2 {
                [c[0], lerp3(2.0 / 3.0, c[0], c[1]), lerp3(1.0 / 3.0, c[1], c[2]), c[2]]
            } else {
                [c[0], c[1], c[2], c[3]]
            }
        } else {
            base += 1;
            if degree == 2 {
                let (p01, p12, p23) = (c[0], c[1], c[2]);
                let p11 = lerp3(0.5, p01, p12);
                let p22 = lerp3(0.5, p12, p23);
                [p11, lerp3(2.0 / 3.0, p11, p12), lerp3(1.0 / 3.0, p12, p22), p22]
            } else {
                let (p012, p123, p234, p345) = (c[0], c[1], c[2], c[3]);
                let p122 = lerp3(2.0 / 3.0, p012, p123);
                let p223 = lerp3(1.0 / 3.0, p123, p234);
                let p233 = lerp3(2.0 / 3.0, p123, p234);
                let p334 = lerp3(1.0 / 3.0, p234, p345);
                [lerp3(0.5, p122, p223), p223, p233, lerp3(0.5, p233, p334)]
            }
        };
        let w0 = lerp1(seg as f32 / n_segments as f32, width0, width1);
        let w1 = lerp1((seg + 1) as f32 / n_segments as f32, width0, width1);
        let norm = normals.as_ref().map(|n| [n[seg], n[seg + 1]]);
        let common = Arc::new(CurveCommon::new(*pl, bez, w0, w1, kind, norm));
        let n = 1usize << sd;
        for i in 0..n {
            let (u_min, u_max) = (i as f32 / n as f32, (i + 1) as f32 / n as f32);
            out.push(Shape::Curve(Curve { common: common.clone(), u_min, u_max }));
        }
    }
    out
}

fn lerp1(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::Interaction;
    use farm_common::geometry::{Mat4, Ray};
    use farm_common::rng::Rng;
    use farm_common::scene::{FileLoc, Param, ParamSet, ParamValue};

    fn set(ps: Vec<(&str, ParamValue)>) -> ParamSet {
        let mut s = ParamSet::default();
        for (name, value) in ps {
            s.add(Param { name: name.into(), value, loc: FileLoc::default() });
        }
        s
    }

    fn make(name: &str, ps: Vec<(&str, ParamValue)>, t: &Transform) -> Vec<Shape> {
        let s = set(ps);
        let p = Params::new(&s);
        let mut w = vec![];
        let out = create(name, &p, t, false, &mut w);
        assert!(w.is_empty(), "{name}: {w:?}");
        assert!(p.unused_warnings().is_empty(), "{name}: {:?}", p.unused_warnings());
        out
    }

    fn fl(v: f32) -> ParamValue {
        ParamValue::Float(vec![v])
    }

    fn dir(rng: &mut Rng) -> Vec3 {
        crate::sampling::uniform_sample_sphere(Vec2::new(rng.uniform_f32(), rng.uniform_f32()))
    }

    fn transforms() -> Vec<Transform> {
        vec![
            Transform::default(),
            Transform::new(
                Mat4::from_translation(Vec3::new(1e3, -2e3, 5e2))
                    * Mat4::from_rotation_x(0.7)
                    * Mat4::from_scale(Vec3::splat(3.0)),
            ),
            Transform::new(
                Mat4::from_rotation_y(-1.2) * Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0)),
            ),
        ]
    }

    fn all_shapes(t: &Transform) -> Vec<(&'static str, Vec<Shape>)> {
        let octa_p: Vec<[f32; 3]> = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let octa_i = vec![0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5];
        vec![
            (
                "sphere",
                make(
                    "sphere",
                    vec![("radius", fl(1.5)), ("zmin", fl(-1.0)), ("phimax", fl(300.0))],
                    t,
                ),
            ),
            ("cylinder", make("cylinder", vec![("radius", fl(0.7)), ("phimax", fl(270.0))], t)),
            ("disk", make("disk", vec![("height", fl(0.3)), ("innerradius", fl(0.2))], t)),
            ("cone", make("cone", vec![("radius", fl(1.0)), ("height", fl(2.0))], t)),
            ("paraboloid", make("paraboloid", vec![("zmin", fl(0.1)), ("zmax", fl(1.5))], t)),
            (
                "hyperboloid",
                make(
                    "hyperboloid",
                    vec![
                        ("p1", ParamValue::Point3(vec![[1.0, 0.0, -1.0]])),
                        ("p2", ParamValue::Point3(vec![[0.0, 1.0, 1.0]])),
                    ],
                    t,
                ),
            ),
            (
                "trianglemesh",
                make(
                    "trianglemesh",
                    vec![("indices", ParamValue::Int(octa_i)), ("P", ParamValue::Point3(octa_p))],
                    t,
                ),
            ),
        ]
    }

    /// Rays aimed at points found on each shape hit them there, and rays
    /// spawned from a hit never hit the same spot again.
    #[test]
    fn reintersection_and_spawned_rays() {
        let mut rng = Rng::new(7);
        for t in transforms() {
            for (name, shapes) in all_shapes(&t) {
                let b = shapes
                    .iter()
                    .fold(farm_common::geometry::Bounds3f::default(), |b, s| b.union(&s.bounds()));
                let size = b.diagonal().length();
                let (mut hits, mut bad) = (0, 0);
                for _ in 0..3000 {
                    // Find a point on the shape with a random ray.
                    let target = b.min
                        + b.diagonal()
                            * Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
                    let o = target + dir(&mut rng) * size * 2.0;
                    let ray = Ray::new(o, target - o, 0.0);
                    let Some((sh, _, si)) = shapes
                        .iter()
                        .filter_map(|s| s.intersect(&ray).map(|(th, si)| (s, th, si)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                    else {
                        continue;
                    };
                    hits += 1;
                    assert!(sh.intersect_p(&ray), "{name}: intersect_p disagrees");
                    assert!((si.wo.length() - 1.0).abs() < 1e-4);
                    let p = si.p();
                    let n = si.n();
                    // Re-aim at p from close by, from both sides.
                    for side in [1.0f32, -1.0] {
                        let w = (side * n + 0.3 * dir(&mut rng)).normalize();
                        if w.dot(n) * side <= 0.05 {
                            continue;
                        }
                        let o2 = p + w * size * 1e-3;
                        let r2 = Ray::new(o2, p - o2, 0.0);
                        let Some((_, si2)) = sh.intersect(&r2) else {
                            bad += 1;
                            continue;
                        };
                        let tol = 1e-5 * size + 2.0 * (si.it.p_error + si2.it.p_error).length();
                        if si2.p().distance(p) >= tol {
                            bad += 1;
                        }
                    }
                    // Spawned rays leave the surface.
                    for _ in 0..4 {
                        let d = dir(&mut rng);
                        let r3 = si.spawn_ray(d);
                        if let Some((_, si3)) = sh.intersect(&r3) {
                            if si3.p().distance(p) <= 1e-4 * size {
                                bad += 1;
                            }
                        }
                    }
                }
                // pbrt-v3 reprojects sphere and cylinder hits and solves planes
                // exactly; its cone, paraboloid and hyperboloid keep the raw
                // ray point, whose EFloat bound is not fully conservative for
                // ill-conditioned roots (e.g. near a cone's apex).
                let allowed = if matches!(name, "cone" | "paraboloid" | "hyperboloid") {
                    hits / 100
                } else {
                    0
                };
                assert!(bad <= allowed, "{name}: {bad} failures in {hits} hits");
                assert!(hits > 200, "{name}: only {hits} hits");
            }
        }
    }

    /// Sampled points lie on the shape, and 1/pdf sums to the area.
    #[test]
    fn area_sampling_matches_area() {
        let mut rng = Rng::new(3);
        let t = Transform::new(
            Mat4::from_translation(Vec3::new(2.0, 3.0, -1.0)) * Mat4::from_rotation_z(0.4),
        );
        for name in ["sphere", "cylinder", "disk", "trianglemesh"] {
            let shapes = all_shapes(&t)
                .into_iter()
                .find(|(n, _)| *n == name)
                .map(|x| x.1)
                .unwrap_or_default();
            for s in &shapes {
                let (it, pdf) = s.sample_area(Vec2::new(0.3, 0.6));
                assert!((pdf * s.area() - 1.0).abs() < 1e-5, "{name}");
                assert!((it.n.length() - 1.0).abs() < 1e-4);
                // A ray from outside along the normal hits the sampled point.
                let o = it.p + it.n * 0.01;
                let r = Ray::new(o, it.p - o, 0.0);
                if name != "sphere" && name != "cylinder" {
                    assert!(s.intersect(&r).is_some(), "{name}: sampled point off the surface");
                }
            }
            // Solid-angle pdf integrates to one over the sphere of directions.
            let reference = Interaction { p: Vec3::new(6.0, 1.0, 2.0), ..Default::default() };
            let n = 20000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let wi = dir(&mut rng);
                let pdf: f32 = shapes.iter().map(|s| s.pdf_from(&reference, wi)).sum();
                sum += pdf as f64 * 4.0 * std::f64::consts::PI / n as f64;
            }
            let visible_once = name == "disk" || name == "trianglemesh";
            if visible_once {
                // Each piece's density integrates to one over the directions it subtends.
                let expect = shapes.len() as f64;
                assert!((sum - expect).abs() < 0.1 * expect, "{name}: {sum}");
            }
            // sample_from agrees with pdf_from.
            for _ in 0..50 {
                let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
                for s in &shapes {
                    if let Some((it, pdf)) = s.sample_from(&reference, u) {
                        let wi = (it.p - reference.p).normalize();
                        let p2 = s.pdf_from(&reference, wi);
                        if (name == "sphere" || name == "disk") && p2 > 0.0 {
                            assert!(
                                (pdf - p2).abs() <= 1e-2 * pdf.max(p2),
                                "{name}: {pdf} vs {p2}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn bad_mesh_data_warns_and_skips() {
        let t = Transform::default();
        let p = ParamValue::Point3(vec![
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [f32::NAN, 0.0, 0.0],
        ]);
        let s =
            set(vec![("indices", ParamValue::Int(vec![0, 1, 2, 0, 1, 3, 2])), ("P", p.clone())]);
        let mut w = vec![];
        let out = create("trianglemesh", &Params::new(&s), &t, false, &mut w);
        assert_eq!(out.len(), 1);
        assert_eq!(w.len(), 2, "{w:?}");
        let s = set(vec![("indices", ParamValue::Int(vec![0, 1, 9])), ("P", p)]);
        let mut w = vec![];
        assert!(create("trianglemesh", &Params::new(&s), &t, false, &mut w).is_empty());
        assert!(w[0].message.contains("out of-bounds"), "{w:?}");
        let mut w = vec![];
        assert!(create("blob", &Params::new(&ParamSet::default()), &t, false, &mut w).is_empty());
        assert_eq!(w[0].message, "Shape \"blob\" unknown.");
        // Three vertices need no indices.
        let s =
            set(vec![("P", ParamValue::Point3(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))]);
        let mut w = vec![];
        assert_eq!(create("trianglemesh", &Params::new(&s), &t, false, &mut w).len(), 1);
        assert!(w.is_empty());
    }

    #[test]
    fn loopsubdiv_of_tetrahedron_multiplies_faces_by_four() {
        let p = ParamValue::Point3(vec![
            [1.0, 1.0, 1.0],
            [-1.0, -1.0, 1.0],
            [-1.0, 1.0, -1.0],
            [1.0, -1.0, -1.0],
        ]);
        let i = ParamValue::Int(vec![0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2]);
        for levels in 0..4 {
            let s = make(
                "loopsubdiv",
                vec![
                    ("levels", ParamValue::Int(vec![levels])),
                    ("indices", i.clone()),
                    ("P", p.clone()),
                ],
                &Transform::default(),
            );
            assert_eq!(s.len(), 4usize.pow(levels as u32) * 4);
            // The limit surface is closed: a ray from the centre hits exactly once going out.
            let r = Ray::new(Vec3::ZERO, Vec3::new(0.3, 0.2, 0.9), 0.0);
            let n = s.iter().filter(|t| t.intersect(&r).is_some()).count();
            assert_eq!(n, 1, "levels {levels}");
            let (_, si) = s.iter().find_map(|t| t.intersect(&r)).expect("hit");
            // Interpolated limit normals point outwards.
            assert!(si.shading.n.dot(si.p()) > 0.0);
        }
    }

    #[test]
    fn curve_hit_through_the_middle() {
        let p = ParamValue::Point3(vec![
            [-1.0, 0.0, 0.0],
            [-0.3, 0.0, 0.0],
            [0.3, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        ]);
        for ty in ["flat", "cylinder"] {
            let shapes = make(
                "curve",
                vec![
                    ("P", p.clone()),
                    ("width", fl(0.2)),
                    ("type", ParamValue::String(vec![ty.into()])),
                ],
                &Transform::default(),
            );
            assert_eq!(shapes.len(), 8);
            let r = Ray::new(Vec3::new(0.05, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0), 0.0);
            let hits: Vec<_> = shapes.iter().filter_map(|s| s.intersect(&r)).collect();
            assert_eq!(hits.len(), 1, "{ty}");
            let (t, si) = hits[0];
            assert!((t - 5.0).abs() < 1e-3, "{t}");
            assert!((si.uv.x - 0.525).abs() < 0.02, "{:?}", si.uv);
            assert!((si.uv.y - 0.5).abs() < 1e-3);
            let miss = Ray::new(Vec3::new(0.05, 0.2, 5.0), Vec3::new(0.0, 0.0, -1.0), 0.0);
            assert!(shapes.iter().all(|s| !s.intersect_p(&miss)));
        }
        // Ribbons facing the ray.
        let n = ParamValue::Normal(vec![[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]);
        let shapes = make(
            "curve",
            vec![
                ("P", p),
                ("width", fl(0.2)),
                ("type", ParamValue::String(vec!["ribbon".into()])),
                ("N", n),
            ],
            &Transform::default(),
        );
        let r = Ray::new(Vec3::new(0.05, 0.05, 5.0), Vec3::new(0.0, 0.0, -1.0), 0.0);
        assert_eq!(shapes.iter().filter(|s| s.intersect(&r).is_some()).count(), 1);
    }
}
