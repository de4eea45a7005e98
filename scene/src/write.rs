//! A [`SceneDescription`] written back as pbrt-v3 scene text: pbrt-v3's
//! `--cat` (the scene reformatted, `Include`s inlined, PLY meshes as
//! triangle meshes) and `--toply` (triangle meshes written to PLY files).
//!
//! Every transform is written as the `Transform` it composed to, in f64
//! digits that read back exactly, and every value in the digits that read
//! back to the same f32, so the text parses back to the same description
//! (the camera's placement up to the rounding of inverting its matrix
//! twice). Each shape carries its own material directive, so materials
//! that shapes shared through one anonymous `Material` come back as equal
//! copies.

use farm_common::scene::{
    AnimatedXform, Entity, LightEntity, MaterialEntity, ParamSet, ParamValue, SceneDescription,
    ShapeEntity, TextureKind,
};
use glam::DMat4;
use std::fmt::Write as _;
use std::path::Path;

/// How to write meshes.
#[derive(Clone, Copy, Debug)]
pub enum Meshes<'a> {
    /// Inline, as `Shape "trianglemesh"` with all its vertices.
    Inline,
    /// Each triangle mesh to `PREFIX_N.ply` in `dir`, as pbrt-v3's
    /// `--toply` does (its prefix is `mesh`), named by a `Shape "plymesh"`.
    Ply {
        /// Where the files go.
        dir: &'a Path,
        /// Their names' start.
        prefix: &'a str,
    },
}

/// The scene as pbrt-v3 text.
pub fn write_scene(s: &SceneDescription, meshes: Meshes) -> std::io::Result<String> {
    let mut w = Writer { out: String::new(), meshes, next_mesh: 0, scene: s };
    w.line(&format!("# {} (written by farm)", s.name));
    let cam = &s.camera.world_from_camera;
    if cam.start_time != 0.0 || cam.end_time != 1.0 {
        w.line(&format!("TransformTimes {:?} {:?}", cam.start_time, cam.end_time));
    }
    // The camera is placed by the inverse of the CTM at its directive.
    let inv = AnimatedXform { start: cam.start.inverse(), end: cam.end.inverse(), ..*cam };
    w.transform(&inv);
    if let Some(m) = &s.camera.medium {
        w.line(&format!("MediumInterface \"\" {}", quote(m)));
    }
    w.entity("Camera", &s.camera.entity);
    w.entity("Film", &s.film);
    w.entity("Sampler", &s.sampler);
    w.entity("PixelFilter", &s.filter);
    w.entity("Integrator", &s.integrator);
    w.entity("Accelerator", &s.accelerator);
    w.line("WorldBegin");
    for m in &s.media {
        w.line("TransformBegin");
        w.matrix("Transform", &m.world_from_medium);
        w.params(&format!("MakeNamedMedium {}", quote(&m.name)), &with_type(&m.entity));
        w.line("TransformEnd");
    }
    for t in &s.textures {
        w.line("TransformBegin");
        w.matrix("Transform", &t.world_from_texture);
        let kind = match t.kind {
            TextureKind::Float => "float",
            TextureKind::Spectrum => "spectrum",
        };
        let head = format!("Texture {} \"{kind}\" {}", quote(&t.name), quote(&t.entity.name));
        w.params(&head, &t.entity.params);
        w.line("TransformEnd");
    }
    for m in s.materials.iter().filter(|m| m.name.is_some()) {
        let head = format!("MakeNamedMaterial {}", quote(m.name.as_deref().unwrap_or("")));
        w.params(&head, &with_type(&m.entity));
    }
    // Each light where its directive was among the shapes: pbrt-v3 numbers
    // the lights in that order.
    let mut lights = s.lights.iter().peekable();
    for (i, shape) in s.shapes.iter().enumerate() {
        while let Some(l) = lights.next_if(|l| l.shapes_before as usize <= i) {
            w.light(l);
        }
        w.shape(shape)?;
    }
    for l in lights {
        w.light(l);
    }
    for o in &s.objects {
        w.line(&format!("ObjectBegin {}", quote(&o.name)));
        for shape in &o.shapes {
            w.shape(shape)?;
        }
        w.line("ObjectEnd");
    }
    for i in &s.instances {
        let Some(o) = s.objects.get(i.object as usize) else { continue };
        w.line("AttributeBegin");
        w.transform(&i.world_from_instance);
        w.line(&format!("ObjectInstance {}", quote(&o.name)));
        w.line("AttributeEnd");
    }
    w.line("WorldEnd");
    Ok(w.out)
}

struct Writer<'a> {
    out: String,
    meshes: Meshes<'a>,
    next_mesh: usize,
    scene: &'a SceneDescription,
}

impl Writer<'_> {
    fn line(&mut self, s: &str) {
        self.out.push_str(s);
        self.out.push('\n');
    }

    /// `Transform [m]`, where the CTM is the identity; nothing for it.
    fn matrix(&mut self, directive: &str, m: &DMat4) {
        if *m == DMat4::IDENTITY {
            return;
        }
        let v: Vec<String> = m.to_cols_array().iter().map(|x| format!("{x:?}")).collect();
        self.line(&format!("{directive} [ {} ]", v.join(" ")));
    }

    /// Sets the CTM (both keyframes when it moves).
    fn transform(&mut self, t: &AnimatedXform) {
        if t.is_static() {
            self.matrix("Transform", &t.start);
        } else {
            self.line("ActiveTransform StartTime");
            self.matrix("Transform", &t.start);
            self.line("ActiveTransform EndTime");
            self.matrix("Transform", &t.end);
            self.line("ActiveTransform All");
        }
    }

    fn entity(&mut self, directive: &str, e: &Entity) {
        let head = format!("{directive} {}", quote(&e.name));
        self.params(&head, &e.params);
    }

    fn params(&mut self, head: &str, set: &ParamSet) {
        let mut s = head.to_string();
        for p in &set.params {
            let _ = write!(s, "\n    {}", self.param(&p.name, &p.value));
        }
        self.line(&s);
    }

    fn param(&self, name: &str, v: &ParamValue) -> String {
        fn list<T>(v: &[T], f: impl Fn(&T) -> String) -> String {
            v.iter().map(f).collect::<Vec<_>>().join(" ")
        }
        let flat = |v: &[f32]| list(v, |x| format!("{x:?}"));
        let (ty, values) = match v {
            ParamValue::Int(v) => ("integer", list(v, i32::to_string)),
            ParamValue::Float(v) => ("float", flat(v)),
            ParamValue::Point2(v) => ("point2", list(v, |p| flat(p))),
            ParamValue::Vector2(v) => ("vector2", list(v, |p| flat(p))),
            ParamValue::Point3(v) => ("point3", list(v, |p| flat(p))),
            ParamValue::Vector3(v) => ("vector3", list(v, |p| flat(p))),
            ParamValue::Normal(v) => ("normal", list(v, |p| flat(p))),
            ParamValue::Spectrum(v) => ("rgb", list(v, |c| flat(&[c.r, c.g, c.b]))),
            ParamValue::Bool(v) => ("bool", list(v, |b| format!("\"{b}\""))),
            ParamValue::String(v) => ("string", list(v, |s| quote(s))),
            ParamValue::Texture(t) => ("texture", quote(&t.name)),
            ParamValue::Material(m) => {
                let name = self.scene.materials.get(*m as usize).and_then(|m| m.name.clone());
                ("string", quote(&name.unwrap_or_default()))
            }
        };
        format!("\"{ty} {name}\" [ {values} ]")
    }

    fn light(&mut self, l: &LightEntity) {
        self.line("AttributeBegin");
        if let Some(m) = &l.medium {
            self.line(&format!("MediumInterface \"\" {}", quote(m)));
        }
        self.transform(&l.world_from_light);
        self.entity("LightSource", &l.entity);
        self.line("AttributeEnd");
    }

    fn shape(&mut self, s: &ShapeEntity) -> std::io::Result<()> {
        self.line("AttributeBegin");
        match s.material.and_then(|m| self.scene.materials.get(m as usize)) {
            None => self.line("Material \"none\""),
            Some(MaterialEntity { name: Some(name), .. }) => {
                self.line(&format!("NamedMaterial {}", quote(name)))
            }
            Some(MaterialEntity { name: None, entity }) => self.entity("Material", entity),
        }
        if s.media.inside.is_some() || s.media.outside.is_some() {
            let q = |m: &Option<String>| quote(m.as_deref().unwrap_or(""));
            self.line(&format!("MediumInterface {} {}", q(&s.media.inside), q(&s.media.outside)));
        }
        self.transform(&s.world_from_object);
        if s.reverse_orientation {
            self.line("ReverseOrientation");
        }
        if let Some(a) = &s.area_light {
            self.entity("AreaLightSource", a);
        }
        match self.meshes {
            Meshes::Ply { dir, prefix } if s.entity.name == "trianglemesh" => {
                let name = format!("{prefix}_{:05}.ply", self.next_mesh);
                self.next_mesh += 1;
                let mut rest = s.entity.params.clone();
                let ply = mesh_ply(&mut rest);
                std::fs::write(dir.join(&name), ply)?;
                rest.params.insert(
                    0,
                    farm_common::scene::Param {
                        name: "filename".into(),
                        value: ParamValue::String(vec![name]),
                        loc: s.entity.loc.clone(),
                    },
                );
                self.params("Shape \"plymesh\"", &rest);
            }
            _ => self.entity("Shape", &s.entity),
        }
        self.line("AttributeEnd");
        Ok(())
    }
}

/// `"text"` with pbrt's escapes.
fn quote(s: &str) -> String {
    let mut q = String::with_capacity(s.len() + 2);
    q.push('"');
    for c in s.chars() {
        match c {
            '"' => q.push_str("\\\""),
            '\\' => q.push_str("\\\\"),
            '\n' => q.push_str("\\n"),
            '\t' => q.push_str("\\t"),
            c => q.push(c),
        }
    }
    q.push('"');
    q
}

/// An entity's parameters with its type first, as `MakeNamedMaterial` and
/// `MakeNamedMedium` take it.
fn with_type(e: &Entity) -> ParamSet {
    let mut set = e.params.clone();
    set.params.insert(
        0,
        farm_common::scene::Param {
            name: "type".into(),
            value: ParamValue::String(vec![e.name.clone()]),
            loc: e.loc.clone(),
        },
    );
    set
}

/// A binary PLY of a mesh's `P`, `N`, `uv` and `indices`, which it takes
/// out of `params` (the rest stay on the shape).
fn mesh_ply(params: &mut ParamSet) -> Vec<u8> {
    let take_p = |set: &mut ParamSet, name: &str| match set.take(name).map(|p| p.value) {
        Some(ParamValue::Point3(v)) | Some(ParamValue::Normal(v)) => Some(v),
        _ => None,
    };
    let p = take_p(params, "P").unwrap_or_default();
    let n = take_p(params, "N").filter(|n| n.len() == p.len());
    let uv = match params.take("uv").map(|p| p.value) {
        Some(ParamValue::Point2(v)) if v.len() == p.len() => Some(v),
        Some(other) => {
            params.params.push(farm_common::scene::Param {
                name: "uv".into(),
                value: other,
                loc: Default::default(),
            });
            None
        }
        None => None,
    };
    let indices = match params.take("indices").map(|p| p.value) {
        Some(ParamValue::Int(v)) => v,
        _ => Vec::new(),
    };
    let mut head = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n",
        p.len()
    );
    if n.is_some() {
        head.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if uv.is_some() {
        head.push_str("property float u\nproperty float v\n");
    }
    let _ = write!(
        head,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        indices.len() / 3
    );
    let mut out = head.into_bytes();
    for (i, v) in p.iter().enumerate() {
        let mut push = |x: f32| out.extend_from_slice(&x.to_le_bytes());
        v.iter().for_each(|&x| push(x));
        if let Some(n) = &n {
            n[i].iter().for_each(|&x| push(x));
        }
        if let Some(uv) = &uv {
            uv[i].iter().for_each(|&x| push(x));
        }
    }
    for tri in indices.chunks_exact(3) {
        out.push(3);
        for &i in tri {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}
