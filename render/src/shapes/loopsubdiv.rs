//! Loop subdivision surfaces (pbrt-v3 `shapes/loopsubdiv.cpp`):
//! `Shape "loopsubdiv" "integer levels" 3 "integer indices" [...] "point P" [...]`.
//! The control mesh is refined `levels` times, its vertices pushed to the
//! limit surface, and the result is a triangle mesh with limit normals.

use super::mesh::{build_mesh, warn, MeshData};
use super::{Placement, Shape};
use farm_common::geometry::Vec3;
use farm_common::math;
use farm_common::scene::{Params, Warning};
use std::collections::HashMap;
use std::f32::consts::PI;

const NONE: usize = usize::MAX;

#[inline]
fn next(i: usize) -> usize {
    (i + 1) % 3
}
#[inline]
fn prev(i: usize) -> usize {
    (i + 2) % 3
}

#[derive(Clone, Copy)]
struct Vert {
    p: Vec3,
    start: usize,
    child: usize,
    regular: bool,
    boundary: bool,
}

#[derive(Clone, Copy)]
struct Face {
    v: [usize; 3],
    f: [usize; 3],
    children: [usize; 4],
}

/// A subdivided mesh: triangle indices, limit positions, limit normals.
pub type LimitMesh = (Vec<u32>, Vec<Vec3>, Vec<Vec3>);

/// Why the control mesh could not be subdivided.
type Topo<T> = Result<T, &'static str>;
const BAD: &str = "inconsistent mesh topology";

/// One level of the subdivision mesh.
struct Level {
    verts: Vec<Vert>,
    faces: Vec<Face>,
}

impl Level {
    fn vnum(&self, f: usize, v: usize) -> Topo<usize> {
        self.faces[f].v.iter().position(|&x| x == v).ok_or(BAD)
    }
    fn next_face(&self, f: usize, v: usize) -> Topo<usize> {
        Ok(self.faces[f].f[self.vnum(f, v)?])
    }
    fn prev_face(&self, f: usize, v: usize) -> Topo<usize> {
        Ok(self.faces[f].f[prev(self.vnum(f, v)?)])
    }
    fn next_vert(&self, f: usize, v: usize) -> Topo<usize> {
        Ok(self.faces[f].v[next(self.vnum(f, v)?)])
    }
    fn prev_vert(&self, f: usize, v: usize) -> Topo<usize> {
        Ok(self.faces[f].v[prev(self.vnum(f, v)?)])
    }
    fn other_vert(&self, f: usize, v0: usize, v1: usize) -> Topo<usize> {
        self.faces[f].v.iter().copied().find(|&x| x != v0 && x != v1).ok_or(BAD)
    }
    fn cap(&self) -> usize {
        self.faces.len() + 2
    }

    fn valence(&self, v: usize) -> Topo<usize> {
        let start = self.verts[v].start;
        let mut f = start;
        let mut nf = 1;
        if !self.verts[v].boundary {
            loop {
                f = self.next_face(f, v)?;
                if f == start {
                    return Ok(nf);
                }
                if f == NONE || nf > self.cap() {
                    return Err(BAD);
                }
                nf += 1;
            }
        }
        loop {
            f = self.next_face(f, v)?;
            if f == NONE {
                break;
            }
            nf += 1;
            if nf > self.cap() {
                return Err(BAD);
            }
        }
        f = start;
        loop {
            f = self.prev_face(f, v)?;
            if f == NONE {
                break;
            }
            nf += 1;
            if nf > self.cap() {
                return Err(BAD);
            }
        }
        Ok(nf + 1)
    }

    fn one_ring(&self, v: usize, ring: &mut Vec<Vec3>) -> Topo<()> {
        ring.clear();
        let start = self.verts[v].start;
        if !self.verts[v].boundary {
            let mut f = start;
            loop {
                ring.push(self.verts[self.next_vert(f, v)?].p);
                f = self.next_face(f, v)?;
                if f == start {
                    return Ok(());
                }
                if f == NONE || ring.len() > self.cap() {
                    return Err(BAD);
                }
            }
        }
        let mut f = start;
        let mut n = 0;
        loop {
            let f2 = self.next_face(f, v)?;
            if f2 == NONE {
                break;
            }
            f = f2;
            n += 1;
            if n > self.cap() {
                return Err(BAD);
            }
        }
        ring.push(self.verts[self.next_vert(f, v)?].p);
        while f != NONE {
            ring.push(self.verts[self.prev_vert(f, v)?].p);
            f = self.prev_face(f, v)?;
            if ring.len() > self.cap() {
                return Err(BAD);
            }
        }
        Ok(())
    }

    fn weight_one_ring(&self, v: usize, beta: f32, ring: &mut Vec<Vec3>) -> Topo<Vec3> {
        self.one_ring(v, ring)?;
        let mut p = (1.0 - ring.len() as f32 * beta) * self.verts[v].p;
        for &q in ring.iter() {
            p += beta * q;
        }
        Ok(p)
    }

    fn weight_boundary(&self, v: usize, beta: f32, ring: &mut Vec<Vec3>) -> Topo<Vec3> {
        self.one_ring(v, ring)?;
        let (first, last) = (*ring.first().ok_or(BAD)?, *ring.last().ok_or(BAD)?);
        let mut p = (1.0 - 2.0 * beta) * self.verts[v].p;
        p += beta * first;
        p += beta * last;
        Ok(p)
    }
}

fn beta(valence: usize) -> f32 {
    if valence == 3 {
        3.0 / 16.0
    } else {
        3.0 / (8.0 * valence as f32)
    }
}

fn loop_gamma(valence: usize) -> f32 {
    1.0 / (valence as f32 + 3.0 / (8.0 * beta(valence)))
}

fn edge_key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// Subdivides the control mesh (`indices` in range, a multiple of 3, every
/// vertex used) and returns the limit mesh: indices, positions and normals.
pub fn loop_subdivide(levels: u32, indices: &[u32], p: &[Vec3]) -> Result<LimitMesh, &'static str> {
    let mut lv = Level {
        verts: p
            .iter()
            .map(|&p| Vert { p, start: NONE, child: NONE, regular: false, boundary: false })
            .collect(),
        faces: Vec::with_capacity(indices.len() / 3),
    };
    for (i, tri) in indices.chunks_exact(3).enumerate() {
        let v = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
            return Err("degenerate face");
        }
        for &vi in &v {
            lv.verts[vi].start = i;
        }
        lv.faces.push(Face { v, f: [NONE; 3], children: [NONE; 4] });
    }
    // Neighbour pointers across shared edges.
    let mut edges: HashMap<(usize, usize), (usize, usize)> = HashMap::new();
    for fi in 0..lv.faces.len() {
        for e in 0..3 {
            let key = edge_key(lv.faces[fi].v[e], lv.faces[fi].v[next(e)]);
            match edges.remove(&key) {
                None => {
                    edges.insert(key, (fi, e));
                }
                Some((f0, e0)) => {
                    lv.faces[f0].f[e0] = fi;
                    lv.faces[fi].f[e] = f0;
                }
            }
        }
    }
    let mut ring = Vec::with_capacity(16);
    for vi in 0..lv.verts.len() {
        let start = lv.verts[vi].start;
        if start == NONE {
            return Err("unused vertex");
        }
        let mut f = start;
        let mut n = 0;
        loop {
            f = lv.next_face(f, vi)?;
            n += 1;
            if f == NONE || f == start {
                break;
            }
            if n > lv.cap() {
                return Err(BAD);
            }
        }
        lv.verts[vi].boundary = f == NONE;
        let val = lv.valence(vi)?;
        lv.verts[vi].regular = if lv.verts[vi].boundary { val == 4 } else { val == 6 };
    }

    for _ in 0..levels {
        lv = refine(&mut lv, &mut ring)?;
    }

    // Push vertices to the limit surface.
    let mut p_limit = Vec::with_capacity(lv.verts.len());
    for vi in 0..lv.verts.len() {
        p_limit.push(if lv.verts[vi].boundary {
            lv.weight_boundary(vi, 1.0 / 5.0, &mut ring)?
        } else {
            lv.weight_one_ring(vi, loop_gamma(lv.valence(vi)?), &mut ring)?
        });
    }
    for (v, &p) in lv.verts.iter_mut().zip(&p_limit) {
        v.p = p;
    }
    // Limit-surface tangents and normals.
    let mut normals = Vec::with_capacity(lv.verts.len());
    for vi in 0..lv.verts.len() {
        let valence = lv.valence(vi)?;
        lv.one_ring(vi, &mut ring)?;
        let vp = lv.verts[vi].p;
        let (mut s, mut t) = (Vec3::ZERO, Vec3::ZERO);
        if !lv.verts[vi].boundary {
            for (j, &q) in ring.iter().enumerate().take(valence) {
                let a = 2.0 * PI * j as f32 / valence as f32;
                s += math::cos(a) * q;
                t += math::sin(a) * q;
            }
        } else {
            s = ring[valence - 1] - ring[0];
            t = match valence {
                2 => ring[0] + ring[1] - 2.0 * vp,
                3 => ring[1] - vp,
                4 => -ring[0] + 2.0 * ring[1] + 2.0 * ring[2] - ring[3] - 2.0 * vp,
                _ => {
                    let theta = PI / (valence - 1) as f32;
                    let mut t = math::sin(theta) * (ring[0] + ring[valence - 1]);
                    for (k, &q) in ring.iter().enumerate().take(valence - 1).skip(1) {
                        t += (2.0 * math::cos(theta) - 2.0) * math::sin(k as f32 * theta) * q;
                    }
                    -t
                }
            };
        }
        normals.push(s.cross(t));
    }
    let out_indices = lv.faces.iter().flat_map(|f| f.v.map(|v| v as u32)).collect();
    Ok((out_indices, p_limit, normals))
}

/// One Loop refinement step.
fn refine(lv: &mut Level, ring: &mut Vec<Vec3>) -> Topo<Level> {
    let mut nl = Level { verts: Vec::with_capacity(lv.verts.len() * 4), faces: vec![] };
    for vi in 0..lv.verts.len() {
        lv.verts[vi].child = vi;
        let v = lv.verts[vi];
        nl.verts.push(Vert {
            p: Vec3::ZERO,
            start: NONE,
            child: NONE,
            regular: v.regular,
            boundary: v.boundary,
        });
    }
    nl.faces = vec![Face { v: [NONE; 3], f: [NONE; 3], children: [NONE; 4] }; lv.faces.len() * 4];
    for (fi, f) in lv.faces.iter_mut().enumerate() {
        f.children = [4 * fi, 4 * fi + 1, 4 * fi + 2, 4 * fi + 3];
    }
    // Even vertices.
    for vi in 0..lv.verts.len() {
        let v = lv.verts[vi];
        nl.verts[v.child].p = if v.boundary {
            lv.weight_boundary(vi, 1.0 / 8.0, ring)?
        } else if v.regular {
            lv.weight_one_ring(vi, 1.0 / 16.0, ring)?
        } else {
            lv.weight_one_ring(vi, beta(lv.valence(vi)?), ring)?
        };
    }
    // Odd (edge) vertices.
    let mut edge_verts: HashMap<(usize, usize), usize> = HashMap::new();
    for fi in 0..lv.faces.len() {
        let face = lv.faces[fi];
        for k in 0..3 {
            let (e0, e1) = edge_key(face.v[k], face.v[next(k)]);
            if edge_verts.contains_key(&(e0, e1)) {
                continue;
            }
            let boundary = face.f[k] == NONE;
            let (p0, p1) = (lv.verts[e0].p, lv.verts[e1].p);
            let p = if boundary {
                let mut p = 0.5 * p0;
                p += 0.5 * p1;
                p
            } else {
                let mut p = 3.0 / 8.0 * p0;
                p += 3.0 / 8.0 * p1;
                p += 1.0 / 8.0 * lv.verts[lv.other_vert(fi, e0, e1)?].p;
                p += 1.0 / 8.0 * lv.verts[lv.other_vert(face.f[k], e0, e1)?].p;
                p
            };
            edge_verts.insert((e0, e1), nl.verts.len());
            nl.verts.push(Vert {
                p,
                start: face.children[3],
                child: NONE,
                regular: true,
                boundary,
            });
        }
    }
    // Even vertices' start faces.
    for vi in 0..lv.verts.len() {
        let start = lv.verts[vi].start;
        let n = lv.vnum(start, vi)?;
        nl.verts[lv.verts[vi].child].start = lv.faces[start].children[n];
    }
    // Child faces' neighbours and vertices.
    for fi in 0..lv.faces.len() {
        let face = lv.faces[fi];
        let ch = face.children;
        for j in 0..3 {
            nl.faces[ch[3]].f[j] = ch[next(j)];
            nl.faces[ch[j]].f[next(j)] = ch[3];
            let f2 = face.f[j];
            nl.faces[ch[j]].f[j] =
                if f2 != NONE { lv.faces[f2].children[lv.vnum(f2, face.v[j])?] } else { NONE };
            let f2 = face.f[prev(j)];
            nl.faces[ch[j]].f[prev(j)] =
                if f2 != NONE { lv.faces[f2].children[lv.vnum(f2, face.v[j])?] } else { NONE };
        }
        for j in 0..3 {
            nl.faces[ch[j]].v[j] = lv.verts[face.v[j]].child;
            let vert = *edge_verts.get(&edge_key(face.v[j], face.v[next(j)])).ok_or(BAD)?;
            nl.faces[ch[j]].v[next(j)] = vert;
            nl.faces[ch[next(j)]].v[j] = vert;
            nl.faces[ch[3]].v[j] = vert;
        }
    }
    Ok(nl)
}

/// The triangles of a `Shape "loopsubdiv"` (pbrt-v3 `CreateLoopSubdiv`):
/// the control mesh subdivided `levels` times.
pub(super) fn create(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
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
