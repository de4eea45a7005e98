//! `Shape "nurbs"` (pbrt-v3 `shapes/nurbs.cpp`): a non-uniform rational
//! B-spline surface, diced as pbrt-v3 dices it into a 30×30 grid of
//! vertices with exact normals, then rendered as a triangle mesh.

use super::mesh::{build_mesh, warn, MeshData};
use super::{Placement, Shape};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::scene::{Params, Warning};

/// pbrt-v3's dicing rate in each direction.
const DICE: usize = 30;

/// A control point in homogeneous coordinates.
#[derive(Clone, Copy, Debug, Default)]
struct Homogeneous {
    x: f32,
    y: f32,
    z: f32,
    w: f32,
}

impl Homogeneous {
    fn lerp(self, alpha: f32, o: Homogeneous) -> Homogeneous {
        let f = |a: f32, b: f32| a * alpha + b * (1.0 - alpha);
        Homogeneous { x: f(self.x, o.x), y: f(self.y, o.y), z: f(self.z, o.z), w: f(self.w, o.w) }
    }
}

/// pbrt-v3 `KnotOffset`: the knot span holding `t`.
fn knot_offset(knot: &[f32], order: usize, np: usize, t: f32) -> usize {
    let mut k = order - 1;
    while k + 1 < np && t > knot[k + 1] {
        k += 1;
    }
    k
}

/// pbrt-v3 `NURBSEvaluate`: the curve of `np` control points (the i-th at
/// `cp(i)`) at `t`, and its derivative if asked for, by de Boor's algorithm.
fn evaluate(
    order: usize,
    knot: &[f32],
    np: usize,
    cp: impl Fn(usize) -> Homogeneous,
    t: f32,
    deriv: Option<&mut Vec3>,
) -> Homogeneous {
    let offset = knot_offset(knot, order, np, t);
    let k = &knot[offset..];
    let first = offset + 1 - order;
    let mut work = [Homogeneous::default(); 32];
    for (i, w) in work.iter_mut().enumerate().take(order) {
        *w = cp(first + i);
    }
    // Knot indices below `offset` are reached as offset + j + 2 - order + i,
    // never below offset + 1 - order.
    let kn = |i: isize| knot[(offset as isize + i) as usize];
    for i in 0..order.saturating_sub(2) {
        for j in 0..order - 1 - i {
            let lo = kn(j as isize + 2 - order as isize + i as isize);
            let alpha = (k[1 + j] - t) / (k[1 + j] - lo);
            work[j] = work[j].lerp(alpha, work[j + 1]);
        }
    }
    let alpha = (k[1] - t) / (k[1] - k[0]);
    let val = work[0].lerp(alpha, work[1]);
    if let Some(d) = deriv {
        let factor = (order - 1) as f32 / (k[1] - k[0]);
        let delta = Homogeneous {
            x: (work[1].x - work[0].x) * factor,
            y: (work[1].y - work[0].y) * factor,
            z: (work[1].z - work[0].z) * factor,
            w: (work[1].w - work[0].w) * factor,
        };
        let w2 = val.w * val.w;
        *d = Vec3::new(
            delta.x / val.w - (val.x * delta.w / w2),
            delta.y / val.w - (val.y * delta.w / w2),
            delta.z / val.w - (val.z * delta.w / w2),
        );
    }
    val
}

/// The knots and order of one direction.
struct Direction<'a> {
    order: usize,
    knots: &'a [f32],
    n: usize,
}

/// pbrt-v3 `NURBSEvaluateSurface`: the point at (u, v) and its partials.
fn evaluate_surface(
    u_dir: &Direction,
    v_dir: &Direction,
    cp: &[Homogeneous],
    u: f32,
    v: f32,
) -> (Vec3, Vec3, Vec3) {
    let (uo, vo, ucp, vcp) = (u_dir.order, v_dir.order, u_dir.n, v_dir.n);
    let u_first = knot_offset(u_dir.knots, uo, ucp, u) + 1 - uo;
    let iso: Vec<Homogeneous> = (0..uo)
        .map(|i| evaluate(vo, v_dir.knots, vcp, |j| cp[u_first + i + j * ucp], v, None))
        .collect();
    let mut dpdu = Vec3::ZERO;
    let p = evaluate(uo, u_dir.knots, ucp, |j| iso[j - u_first], u, Some(&mut dpdu));
    let v_first = knot_offset(v_dir.knots, vo, vcp, v) + 1 - vo;
    let iso: Vec<Homogeneous> = (0..vo)
        .map(|i| evaluate(uo, u_dir.knots, ucp, |j| cp[(v_first + i) * ucp + j], u, None))
        .collect();
    let mut dpdv = Vec3::ZERO;
    evaluate(vo, v_dir.knots, vcp, |j| iso[j - v_first], v, Some(&mut dpdv));
    (Vec3::new(p.x / p.w, p.y / p.w, p.z / p.w), dpdu, dpdv)
}

/// The triangles of a `Shape "nurbs"` (pbrt-v3 `CreateNURBS`).
pub(super) fn create(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
    match surface(params) {
        Ok(mesh) => build_mesh("nurbs", mesh, pl, warnings),
        Err(msg) => {
            warn(warnings, msg);
            vec![]
        }
    }
}

fn direction<'a>(params: &'a Params, c: char) -> Result<(Direction<'a>, f32, f32), String> {
    let n = params.int(&format!("n{c}"), -1);
    if n == -1 {
        return Err(format!("Must provide number of control points \"n{c}\" with NURBS shape."));
    }
    let order = params.int(&format!("{c}order"), -1);
    if order == -1 {
        return Err(format!("Must provide {c} order \"{c}order\" with NURBS shape."));
    }
    let Some(knots) = params.floats(&format!("{c}knots")) else {
        return Err(format!("Must provide {c} knot vector \"{c}knots\" with NURBS shape."));
    };
    if knots.len() as i64 != n as i64 + order as i64 || n < 1 || !(2..=32).contains(&order) {
        return Err(format!(
            "Number of knots in {c} knot vector {} doesn't match sum of number of {c} control points {n} and {c} order {order}.",
            knots.len()
        ));
    }
    let sorted = knots.windows(2).all(|w| w[0] <= w[1]) && knots.iter().all(|k| k.is_finite());
    if !sorted || order > n {
        return Err(format!("The {c} knot vector of a NURBS shape must be non-decreasing, with at least {c}order control points."));
    }
    let (n, order) = (n as usize, order as usize);
    let t0 = params.float(&format!("{c}0"), knots[order - 1]);
    let t1 = params.float(&format!("{c}1"), knots[n]);
    Ok((Direction { order, knots, n }, t0, t1))
}

fn surface(params: &Params) -> Result<MeshData, String> {
    let (u_dir, u0, u1) = direction(params, 'u')?;
    let (v_dir, v0, v1) = direction(params, 'v')?;
    let cp: Vec<Homogeneous> = match params.point3s("P") {
        Some(p) => p.iter().map(|&[x, y, z]| Homogeneous { x, y, z, w: 1.0 }).collect(),
        None => {
            let Some(pw) = params.floats("Pw") else {
                return Err(
                    "Must provide control points via \"P\" or \"Pw\" parameter to NURBS shape."
                        .into(),
                );
            };
            if pw.len() % 4 != 0 {
                return Err("Number of \"Pw\" control points provided to NURBS shape must be multiple of four".into());
            }
            pw.chunks_exact(4).map(|c| Homogeneous { x: c[0], y: c[1], z: c[2], w: c[3] }).collect()
        }
    };
    if cp.len() != u_dir.n * v_dir.n {
        return Err(format!(
            "NURBS shape was expecting {}x{}={} control points, was given {}",
            u_dir.n,
            v_dir.n,
            u_dir.n * v_dir.n,
            cp.len()
        ));
    }
    // pbrt-v3 asserts the dicing stays within the knots; here a range
    // outside them is clamped to it.
    let clamp = |t: f32, d: &Direction| t.clamp(d.knots[d.order - 1], d.knots[d.n]);
    let lerp = |i: usize, a: f32, b: f32| {
        let t = i as f32 / (DICE - 1) as f32;
        (1.0 - t) * a + t * b
    };
    let ueval: Vec<f32> = (0..DICE).map(|i| clamp(lerp(i, u0, u1), &u_dir)).collect();
    let veval: Vec<f32> = (0..DICE).map(|i| clamp(lerp(i, v0, v1), &v_dir)).collect();
    let mut p = Vec::with_capacity(DICE * DICE);
    let mut n = Vec::with_capacity(DICE * DICE);
    let mut uv = Vec::with_capacity(DICE * DICE);
    for &v in &veval {
        for &u in &ueval {
            let (pt, dpdu, dpdv) = evaluate_surface(&u_dir, &v_dir, &cp, u, v);
            p.push(pt);
            n.push(dpdu.cross(dpdv).normalize());
            uv.push(Vec2::new(u, v));
        }
    }
    let vert = |u: usize, v: usize| (v * DICE + u) as u32;
    let mut indices = Vec::with_capacity(6 * (DICE - 1) * (DICE - 1));
    for v in 0..DICE - 1 {
        for u in 0..DICE - 1 {
            indices.extend_from_slice(&[vert(u, v), vert(u + 1, v), vert(u + 1, v + 1)]);
            indices.extend_from_slice(&[vert(u, v), vert(u + 1, v + 1), vert(u, v + 1)]);
        }
    }
    Ok(MeshData { indices, p, n: Some(n), uv: Some(uv), ..Default::default() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bilinear patch (order 2 in both directions, four corners) is the
    /// plane through them; a rational quadratic arc with weights 1, √½, 1
    /// is an exact quarter circle, as NURBS represent conics.
    #[test]
    fn nurbs_evaluate_planes_and_exact_circles() {
        let flat = |x: f32, y: f32| Homogeneous { x, y, z: 0.0, w: 1.0 };
        let cp = [flat(0.0, 0.0), flat(2.0, 0.0), flat(0.0, 1.0), flat(2.0, 1.0)];
        let d = Direction { order: 2, knots: &[0.0, 0.0, 1.0, 1.0], n: 2 };
        let (p, dpdu, dpdv) = evaluate_surface(&d, &d, &cp, 0.25, 0.5);
        assert!((p - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6, "{p}");
        assert!((dpdu - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5, "{dpdu}");
        assert!((dpdv - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-5, "{dpdv}");

        let s = std::f32::consts::FRAC_1_SQRT_2;
        let arc = [
            Homogeneous { x: 1.0, y: 0.0, z: 0.0, w: 1.0 },
            Homogeneous { x: s, y: s, z: 0.0, w: s },
            Homogeneous { x: 0.0, y: 1.0, z: 0.0, w: 1.0 },
        ];
        let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        for i in 0..=10 {
            let t = i as f32 / 10.0;
            let mut d = Vec3::ZERO;
            let h = evaluate(3, &knots, 3, |j| arc[j], t, Some(&mut d));
            let q = Vec3::new(h.x / h.w, h.y / h.w, 0.0);
            assert!((q.length() - 1.0).abs() < 1e-5, "t {t}: {q}");
            assert!(q.dot(d).abs() < 1e-4, "the tangent is perpendicular to the radius");
        }
    }
}
