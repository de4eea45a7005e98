//! A reader for the PLY meshes of `Shape "plymesh"` (pbrt-v3
//! `shapes/plymesh.cpp`, which uses rply): ascii, binary little- and
//! big-endian; vertex positions, optional normals and texture coordinates;
//! triangle and quad faces, quads split as pbrt-v3 splits them. Elements and
//! properties it does not use are skipped.

use std::fmt;

/// The mesh read from a PLY file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyMesh {
    /// Vertex positions.
    pub p: Vec<[f32; 3]>,
    /// Per-vertex normals, if the file has `nx ny nz`.
    pub n: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates (`u v`, `s t`, `texture_u texture_v`
    /// or `texture_s texture_t`).
    pub uv: Option<Vec<[f32; 2]>>,
    /// Triangle vertex indices, three per triangle.
    pub indices: Vec<i32>,
    /// pbrt-v3's warnings (faces that are neither triangles nor quads).
    pub warnings: Vec<String>,
}

/// What is wrong with a PLY file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlyError(pub String);

impl fmt::Display for PlyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PlyError {}

type Result<T> = std::result::Result<T, PlyError>;

fn err<T>(msg: impl Into<String>) -> Result<T> {
    Err(PlyError(msg.into()))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Result<Scalar> {
        Ok(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return err(format!("unknown property type \"{s}\" (expected char, uchar, short, ushort, int, uint, float, double or their sized names)")),
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for list properties.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Reads a PLY file's bytes.
pub fn parse(data: &[u8]) -> Result<PlyMesh> {
    let (format, elements, body) = header(data)?;
    check_counts(&elements, format, body.len())?;
    let mut body = Body { data: body, pos: 0, format };
    let vertex_count = elements.iter().find(|e| e.name == "vertex").map_or(0, |e| e.count);
    let face_count = elements.iter().find(|e| e.name == "face").map_or(0, |e| e.count);
    if vertex_count == 0 || face_count == 0 {
        return err("no face/vertex elements found (expected \"element vertex N\" and \"element face M\" with N, M > 0)");
    }
    let mut mesh = PlyMesh::default();
    let mut bad_faces = std::collections::BTreeMap::<usize, usize>::new();
    for e in &elements {
        match e.name.as_str() {
            "vertex" => read_vertices(e, &mut body, &mut mesh)?,
            "face" => read_faces(e, &mut body, vertex_count, &mut mesh, &mut bad_faces)?,
            // An element with no properties takes no bytes, however many.
            _ if e.props.is_empty() => {}
            _ => {
                for i in 0..e.count {
                    for p in &e.props {
                        body.skip_property(p).map_err(|m| in_element(m, e, i))?;
                    }
                }
            }
        }
    }
    for (n, count) in bad_faces {
        mesh.warnings.push(format!(
            "plymesh: Ignoring {count} face(s) with {n} vertices (only triangles and quads are supported!)"
        ));
    }
    Ok(mesh)
}

/// Refuses a header whose element counts need more bytes than follow it,
/// before anything is allocated for them: each item takes at least one
/// scalar (binary) or one digit and a separator (ASCII) per property.
fn check_counts(elements: &[Element], format: Format, body_len: usize) -> Result<()> {
    let mut need = 0usize;
    for e in elements {
        let per_item: usize = e
            .props
            .iter()
            .map(|p| match (format, p.list) {
                (Format::Ascii, _) => 2,
                (_, Some(count)) => count.size(),
                (_, None) => p.ty.size(),
            })
            .sum();
        let bytes = e.count.checked_mul(per_item).and_then(|b| need.checked_add(b));
        // The last ASCII value needs no separator after it.
        let slack = usize::from(format == Format::Ascii);
        match bytes {
            Some(b) if b <= body_len + slack => need = b,
            _ => {
                return err(format!(
                    "element \"{}\" declares {} items, which need at least {} bytes, but only {body_len} bytes follow the header",
                    e.name,
                    e.count,
                    bytes.map_or_else(|| "more than 2^64".to_string(), |b| (b - need).to_string()),
                ))
            }
        }
    }
    Ok(())
}

fn in_element(e: PlyError, el: &Element, i: usize) -> PlyError {
    PlyError(format!("element \"{}\" item {} of {}: {}", el.name, i, el.count, e.0))
}

fn header(data: &[u8]) -> Result<(Format, Vec<Element>, &[u8])> {
    let mut pos = 0;
    let mut next_line = || -> Option<&[u8]> {
        if pos >= data.len() {
            return None;
        }
        let rest = &data[pos..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        pos += (end + 1).min(rest.len());
        let line = &rest[..end];
        Some(line.strip_suffix(b"\r").unwrap_or(line))
    };
    if next_line() != Some(b"ply".as_slice()) {
        return err("first line is not \"ply\" (expected a PLY header)");
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(line) = next_line() else {
            return err("header ends before \"end_header\"");
        };
        let line = String::from_utf8_lossy(line);
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return err(format!("unknown format \"{f}\" (expected ascii, binary_little_endian or binary_big_endian)")),
                })
            }
            ["element", name, count] => {
                let Ok(count) = count.parse() else { return err(format!("bad element count \"{count}\"")) };
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", "list", count_ty, ty, name] => {
                let Some(e) = elements.last_mut() else { return err("property before any element") };
                e.props.push(Property { name: name.to_string(), list: Some(Scalar::parse(count_ty)?), ty: Scalar::parse(ty)? });
            }
            ["property", ty, name] => {
                let Some(e) = elements.last_mut() else { return err("property before any element") };
                e.props.push(Property { name: name.to_string(), list: None, ty: Scalar::parse(ty)? });
            }
            _ => return err(format!("unexpected header line \"{line}\"")),
        }
    }
    let Some(format) = format else {
        return err("no \"format\" line in the header");
    };
    Ok((format, elements, &data[pos.min(data.len())..]))
}

struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    fn read(&mut self, ty: Scalar) -> Result<f64> {
        if self.format == Format::Ascii {
            return self.read_ascii();
        }
        let n = ty.size();
        let Some(b) = self.data.get(self.pos..self.pos + n) else {
            return err(format!(
                "file is truncated (expected {n} more bytes at body offset {})",
                self.pos
            ));
        };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => f64::from(a[0] as i8),
            Scalar::U8 => f64::from(a[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }

    fn read_ascii(&mut self) -> Result<f64> {
        let d = self.data;
        while self.pos < d.len() && d[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < d.len() && !d[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return err("file is truncated (expected another number)");
        }
        let word = std::str::from_utf8(&d[start..self.pos]).unwrap_or("?");
        match word.parse::<f64>() {
            Ok(v) => Ok(v),
            Err(_) => err(format!("\"{word}\" is not a number")),
        }
    }

    fn read_count(&mut self, ty: Scalar) -> Result<usize> {
        let n = self.read(ty)?;
        if !(0.0..=1e9).contains(&n) || n.fract() != 0.0 {
            return err(format!("bad list length {n}"));
        }
        Ok(n as usize)
    }

    fn skip_property(&mut self, p: &Property) -> Result<()> {
        let n = match p.list {
            Some(c) => self.read_count(c)?,
            None => 1,
        };
        for _ in 0..n {
            self.read(p.ty)?;
        }
        Ok(())
    }
}

fn read_vertices(e: &Element, body: &mut Body<'_>, mesh: &mut PlyMesh) -> Result<()> {
    let find = |name: &str| e.props.iter().position(|p| p.name == name && p.list.is_none());
    let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
        return err("vertex coordinate property not found (expected x, y and z)");
    };
    let normal = match (find("nx"), find("ny"), find("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let uv = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")]
        .iter()
        .find_map(|(u, v)| Some([find(u)?, find(v)?]));
    mesh.p.reserve(e.count);
    let mut ns = normal.map(|_| Vec::with_capacity(e.count));
    let mut uvs = uv.map(|_| Vec::with_capacity(e.count));
    if let Some(bytes) = float_records(e, body) {
        for rec in bytes.chunks_exact(4 * e.props.len()) {
            let f = |k: usize| {
                f32::from_le_bytes([rec[4 * k], rec[4 * k + 1], rec[4 * k + 2], rec[4 * k + 3]])
            };
            mesh.p.push([f(x), f(y), f(z)]);
            if let (Some(ns), Some([a, b, c])) = (ns.as_mut(), normal) {
                ns.push([f(a), f(b), f(c)]);
            }
            if let (Some(uvs), Some([a, b])) = (uvs.as_mut(), uv) {
                uvs.push([f(a), f(b)]);
            }
        }
        body.pos += bytes.len();
        mesh.n = ns;
        mesh.uv = uvs;
        return Ok(());
    }
    let mut vals = vec![0.0f32; e.props.len()];
    for i in 0..e.count {
        for (j, p) in e.props.iter().enumerate() {
            if p.list.is_some() {
                body.skip_property(p).map_err(|m| in_element(m, e, i))?;
            } else {
                vals[j] = body.read(p.ty).map_err(|m| in_element(m, e, i))? as f32;
            }
        }
        mesh.p.push([vals[x], vals[y], vals[z]]);
        if let (Some(ns), Some([a, b, c])) = (ns.as_mut(), normal) {
            ns.push([vals[a], vals[b], vals[c]]);
        }
        if let (Some(uvs), Some([a, b])) = (uvs.as_mut(), uv) {
            uvs.push([vals[a], vals[b]]);
        }
    }
    mesh.n = ns;
    mesh.uv = uvs;
    Ok(())
}

/// The bytes of `e`'s records next in `body` when they are little-endian
/// floats only, a common layout read a record at a time; `None` for any
/// other layout, or a file too short, which the general reader then reads
/// (or words the error for).
fn float_records<'a>(e: &Element, body: &Body<'a>) -> Option<&'a [u8]> {
    let floats = e.props.iter().all(|p| p.list.is_none() && p.ty == Scalar::F32);
    if body.format != Format::Little || !floats || e.props.is_empty() {
        return None;
    }
    let len = e.count.checked_mul(4 * e.props.len())?;
    body.data.get(body.pos..body.pos.checked_add(len)?)
}

/// Whether the faces of `e` may be read by [`fast_face`]: little-endian,
/// the index list (property `vi`) their only property, counted in a byte,
/// of 32-bit indices; and whether those are signed.
fn fast_faces(e: &Element, vi: usize, format: Format) -> Option<bool> {
    let p = &e.props[vi];
    if format != Format::Little || e.props.len() != 1 || p.list != Some(Scalar::U8) {
        return None;
    }
    match p.ty {
        Scalar::I32 => Some(true),
        Scalar::U32 => Some(false),
        _ => None,
    }
}

/// Reads the next face as the general reader would when it is a triangle
/// or a quad whose indices are all in range (nearly every face of a
/// mesh); returns false, having read nothing, for any other face, which
/// the general reader then reads or reports.
#[inline(always)]
fn fast_face(body: &mut Body<'_>, signed: bool, vertex_count: usize, out: &mut Vec<i32>) -> bool {
    let d = &body.data[body.pos..];
    let n = match d.first() {
        Some(&n @ (3 | 4)) => usize::from(n),
        _ => return false,
    };
    let Some(b) = d.get(1..1 + 4 * n) else { return false };
    let mut face = [0i32; 4];
    for (k, v) in b.chunks_exact(4).enumerate() {
        let raw = u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
        let v = if signed { i64::from(raw as i32) } else { i64::from(raw) };
        if v < 0 || v >= vertex_count as i64 || v > i64::from(i32::MAX) {
            return false;
        }
        face[k] = v as i32;
    }
    push_polygon(out, &face, n);
    body.pos += 1 + 4 * n;
    true
}

/// Appends the first `n` of `face` as triangles when it is a triangle or
/// a quad (which pbrt-v3 splits into (0, 1, 2) and (3, 0, 2)); returns
/// whether it was.
fn push_polygon(out: &mut Vec<i32>, face: &[i32; 4], n: usize) -> bool {
    match n {
        3 => out.extend_from_slice(&face[..3]),
        4 => out.extend_from_slice(&[face[0], face[1], face[2], face[3], face[0], face[2]]),
        _ => return false,
    }
    true
}

fn read_faces(
    e: &Element,
    body: &mut Body<'_>,
    vertex_count: usize,
    mesh: &mut PlyMesh,
    bad_faces: &mut std::collections::BTreeMap<usize, usize>,
) -> Result<()> {
    let Some(vi) = e
        .props
        .iter()
        .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
    else {
        return err("face element has no \"vertex_indices\" list property");
    };
    mesh.indices.reserve(e.count * 3);
    let fast = fast_faces(e, vi, body.format);
    let mut face = [0i32; 4];
    for i in 0..e.count {
        if let Some(signed) = fast {
            if fast_face(body, signed, vertex_count, &mut mesh.indices) {
                continue;
            }
        }
        for (j, p) in e.props.iter().enumerate() {
            if j != vi {
                body.skip_property(p).map_err(|m| in_element(m, e, i))?;
                continue;
            }
            let count_ty = p.list.unwrap_or(Scalar::U8);
            let n = body.read_count(count_ty).map_err(|m| in_element(m, e, i))?;
            let mut filled = 0;
            for _ in 0..n {
                let v = body.read(p.ty).map_err(|m| in_element(m, e, i))?;
                if n != 3 && n != 4 {
                    continue;
                }
                let v = v as i32;
                if v < 0 || v as usize >= vertex_count {
                    return Err(in_element(
                        PlyError(format!(
                            "vertex reference {v} is out of bounds (expected 0..{vertex_count})"
                        )),
                        e,
                        i,
                    ));
                }
                face[filled] = v;
                filled += 1;
            }
            if !push_polygon(&mut mesh.indices, &face, n) {
                *bad_faces.entry(n).or_default() += 1;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
#[path = "ply_tests.rs"]
mod tests;
