//! The world: the renderable scene, built from a `SceneDescription` in a camera-centred
//! render space (pbrt-v4's approach): everything is translated so the camera
//! sits at the origin, which keeps float precision where the image is made
//! even when the scene lies far from the world origin.

use crate::accel::Bvh;
use crate::error::BuildError;
use crate::interaction::SurfaceInteraction;
use crate::lights::{self, DiffuseAreaLight, Glow, Light};
use crate::materials::{self, Material};
use crate::primitive::{Aggregate, Instance, MaybeIndex, Placement, Primitive};
use crate::shapes::{self, Shape};
use crate::textures::{self, TextureSet};
use farm_common::geometry::{AnimatedTransform, Bounds3f, DMat4, Ray, Transform, Vec3};
use farm_common::scene::{
    AnimatedXform, LightEntity, Params, SceneDescription, ShapeEntity, Warning,
};
use farm_common::Spectrum;
use std::collections::HashMap;
use std::sync::Arc;

/// Geometry, lights and materials, ready for rays.
#[derive(Debug)]
pub struct World {
    /// Primitives outside instances.
    pub aggregate: Aggregate,
    /// Object instances and moving shapes.
    pub instances: Vec<Instance>,
    instance_bvh: Bvh,
    /// All lights, area lights included, in pbrt-v3's order (that of
    /// their directives), in which the integrator draws their samples.
    pub lights: Vec<Light>,
    /// Area lights inside object instances: they emit where seen but light
    /// nothing (pbrt-v3's behaviour). A primitive's `area_light` with
    /// [`GLOW`] set indexes these, any other the lights.
    pub glows: Vec<Glow>,
    /// Materials, indexed by `Primitive::material`.
    pub materials: Vec<Material>,
    /// Textures the materials refer to.
    pub textures: Arc<TextureSet>,
    /// Render-space bounds of everything.
    pub bounds: Bounds3f,
    /// Render-from-world: a translation by minus the camera position.
    pub render_from_world: Transform,
}

impl World {
    /// Builds the scene from `desc` and its top-level `shapes` (taken out of
    /// it, so each is freed once built); `render_from_world` comes from the
    /// camera.
    pub fn build(
        desc: &SceneDescription,
        shapes: Vec<ShapeEntity>,
        render_from_world: DMat4,
        warnings: &mut Vec<Warning>,
    ) -> Result<World, BuildError> {
        let rfw = Transform::from_dmat4(render_from_world);
        let max_prims = crate::accel::max_prims_in_node(&desc.accelerator, warnings);
        let textures = Arc::new(textures::build(&desc.textures, &rfw, &desc.assets, warnings));
        let files = materials::MaterialFiles::new(&desc.assets);
        let materials = materials::build(&desc.materials, &textures, &files, warnings);
        let mut cx = ShapeCx { desc, textures: &textures, files: &files, materials };
        // pbrt-v3 lists lights in the order of their directives: a
        // `LightSource` after the area lights of the shapes before it. The
        // integrator draws each light's sample in that order, so farm keeps
        // it to take pbrt-v3's samples.
        let mut lights = Vec::new();
        let mut light_sources = desc.lights.iter().peekable();
        if !desc.media.is_empty() {
            warnings.push(Warning {
                loc: Some(desc.media[0].entity.loc.clone()),
                message: "participating media are ignored by the Whitted integrator".into(),
            });
        }

        // Shapes outside instances: static ones go straight into the top-level
        // BVH; moving ones become single-use instances.
        let mut prims = Vec::new();
        let mut instances = Vec::new();
        for (i, s) in shapes.into_iter().enumerate() {
            while let Some(l) = light_sources.next_if(|l| l.shapes_before as usize <= i) {
                add_light(l, render_from_world, desc, &mut lights, warnings);
            }
            if s.world_from_object.is_static() {
                let xf = Transform::from_dmat4(render_from_world * s.world_from_object.start);
                add_shape(s, &xf, &mut cx, Emitters::Lights(&mut lights), &mut prims, warnings);
            } else {
                let mut local = Vec::new();
                add_shape(&s, &Transform::default(), &mut cx, Emitters::None, &mut local, warnings);
                if s.area_light.is_some() {
                    warnings.push(Warning::at(
                        &s.entity.loc,
                        "area lights on moving shapes are not supported; the shape does not emit",
                    ));
                }
                if !local.is_empty() {
                    instances.push(Instance {
                        geometry: Arc::new(Aggregate::new(local, max_prims)),
                        placement: placement(&s.world_from_object, render_from_world),
                    });
                }
            }
        }

        for l in light_sources {
            add_light(l, render_from_world, desc, &mut lights, warnings);
        }

        // Object instances share one aggregate per object.
        let mut objects: HashMap<u32, Arc<Aggregate>> = HashMap::new();
        let mut glows = Vec::new();
        for inst in &desc.instances {
            let Some(obj) = desc.objects.get(inst.object as usize) else {
                warnings.push(Warning::at(&inst.loc, "ObjectInstance refers to an unknown object"));
                continue;
            };
            let geometry = objects
                .entry(inst.object)
                .or_insert_with(|| {
                    let mut local = Vec::new();
                    for s in &obj.shapes {
                        if !s.world_from_object.is_static() {
                            warnings.push(Warning::at(
                                &s.entity.loc,
                                "moving shapes inside object instances use their start transform",
                            ));
                        }
                        let xf = Transform::from_dmat4(s.world_from_object.start);
                        let emitters = if s.world_from_object.is_static() {
                            Emitters::Glows(&mut glows)
                        } else {
                            Emitters::None
                        };
                        add_shape(s, &xf, &mut cx, emitters, &mut local, warnings);
                    }
                    Arc::new(Aggregate::new(local, max_prims))
                })
                .clone();
            if geometry.is_empty() {
                continue;
            }
            instances.push(Instance {
                geometry,
                placement: placement(&inst.world_from_instance, render_from_world),
            });
        }

        let aggregate = Aggregate::new(prims, max_prims);
        let (instance_bvh, instances) = Bvh::build_over(instances, Instance::bounds, |_| false, 1);
        let bounds = aggregate.bounds().union(&instance_bvh.bounds());

        let (center, radius) =
            if bounds.is_empty() { (Vec3::ZERO, 0.0) } else { bounds.bounding_sphere() };
        for l in &mut lights {
            l.preprocess(center, radius);
        }
        let materials = cx.materials;
        Ok(World {
            aggregate,
            instances,
            instance_bvh,
            lights,
            glows,
            materials,
            textures,
            bounds,
            render_from_world: rfw,
        })
    }

    /// The closest hit along `ray`: the primitive, with the surface point
    /// written to `si` (left as it was on a miss).
    #[inline]
    pub fn intersect(&self, ray: &Ray, si: &mut SurfaceInteraction) -> Option<&Primitive> {
        // The aggregate reads the caller's ray itself, not a copy: loads
        // of a fresh copy wait for its stores unless each load lies within
        // one store.
        let hit = self.aggregate.intersect(ray, si);
        let mut best = hit.map(|(_, prim)| prim);
        if !self.instances.is_empty() {
            let mut r = *ray;
            if let Some((t, _)) = hit {
                r.t_max = t;
            }
            // Only hits closer than the best so far write `si`.
            self.instance_bvh.intersect(&r, |i, rr| {
                let (t, prim) = self.instances[i].intersect(rr, si)?;
                best = Some(prim);
                Some(t)
            });
        }
        best
    }

    /// Radiance the area light `id` of a primitive (its `area_light`) sends
    /// from a point with geometric normal `n` in direction `w`.
    #[inline]
    pub fn emitted(&self, id: u32, n: Vec3, w: Vec3) -> Spectrum {
        if id & GLOW != 0 {
            self.glows.get((id & !GLOW) as usize).map_or(Spectrum::ZERO, |g| g.l(n, w))
        } else if let Some(Light::Area(area)) = self.lights.get(id as usize) {
            area.l(n, w)
        } else {
            Spectrum::ZERO
        }
    }

    /// Whether anything blocks `ray` before its `t_max`.
    #[inline(always)]
    pub fn intersect_p(&self, ray: &Ray) -> bool {
        self.aggregate.intersect_p(ray)
            || (!self.instances.is_empty()
                && self.instance_bvh.intersect_any(ray, |i, r| self.instances[i].intersect_p(r)))
    }
}

/// Makes the light of a `LightSource` directive.
fn add_light(
    l: &LightEntity,
    render_from_world: DMat4,
    desc: &SceneDescription,
    lights: &mut Vec<Light>,
    warnings: &mut Vec<Warning>,
) {
    if !l.world_from_light.is_static() {
        warnings.push(Warning::at(
            &l.entity.loc,
            "animated light transforms are not supported; using the start transform",
        ));
    }
    let xf = Transform::from_dmat4(render_from_world * l.world_from_light.start);
    if let Some(light) = lights::create(&l.entity, &xf, &desc.assets, warnings) {
        lights.push(light);
    }
}

fn placement(x: &AnimatedXform, render_from_world: DMat4) -> Placement {
    let start = Transform::from_dmat4(render_from_world * x.start);
    if x.is_static() {
        return Placement::Static(start);
    }
    let end = Transform::from_dmat4(render_from_world * x.end);
    Placement::Animated(AnimatedTransform::new(start, x.start_time, end, x.end_time))
}

/// The bit of a primitive's `area_light` that says it indexes
/// [`World::glows`], not the lights.
pub const GLOW: u32 = 1 << 31;

/// Where the area light of a shape under an `AreaLightSource` goes.
enum Emitters<'a> {
    /// A diffuse area light for each of its shapes, as in pbrt-v3.
    Lights(&'a mut Vec<Light>),
    /// A glow for the entity's shapes (inside an object instance).
    Glows(&'a mut Vec<Glow>),
    /// Nowhere: a moving shape, whose area light pbrt-v3 ignores.
    None,
}

/// What shapes are built with: the textures their alpha masks read, and
/// the materials, to which a shape that sets material parameters adds its
/// own.
struct ShapeCx<'a> {
    desc: &'a SceneDescription,
    textures: &'a Arc<TextureSet>,
    files: &'a materials::MaterialFiles<'a>,
    materials: Vec<Material>,
}

impl ShapeCx<'_> {
    /// The material index of shape `s`: its material's, or, when the shape
    /// sets material parameters, a new material built from the material's
    /// parameters overlaid with the shape's, as pbrt-v3 does. The shape's
    /// parameters the material reads count as used.
    fn material_for(
        &mut self,
        s: &ShapeEntity,
        shape_params: &Params,
        warnings: &mut Vec<Warning>,
    ) -> Option<u32> {
        let m = s.material?;
        let base = self.desc.materials.get(m as usize)?;
        if !materials::shape_may_set_material(&s.entity.params) {
            return Some(m);
        }
        let mut merged = base.entity.params.clone();
        for p in &s.entity.params.params {
            merged.add(p.clone());
        }
        let p = Params::new(&merged);
        let mut w = Vec::new();
        let material = materials::derive(base, m as usize, &p, self.textures, self.files, &mut w);
        // The material's own warnings were given when it was built; keep
        // those about the shape's parameters.
        let at_shape = |w: &Warning| {
            w.loc.as_ref().is_some_and(|l| s.entity.params.params.iter().any(|q| q.loc == *l))
        };
        warnings.extend(w.into_iter().filter(at_shape));
        for q in &s.entity.params.params {
            if p.was_used(&q.name, q.value.type_name()) {
                shape_params.touch(&q.name);
            }
        }
        self.materials.push(material);
        Some(self.materials.len() as u32 - 1)
    }
}

/// Makes shape `s`'s primitives (and area lights). A shape given by value
/// is freed once its shapes are made, before they become primitives, so a
/// mesh's arrays as parsed and its triangles are never held beside its
/// primitives.
fn add_shape(
    s: impl std::borrow::Borrow<ShapeEntity>,
    render_from_object: &Transform,
    cx: &mut ShapeCx,
    emitters: Emitters,
    prims: &mut Vec<Primitive>,
    warnings: &mut Vec<Warning>,
) {
    let entity = s;
    let s = entity.borrow();
    let params = Params::new(&s.entity.params);
    let first = warnings.len();
    let shapes: Vec<Shape> = shapes::create_in(
        &s.entity.name,
        &params,
        render_from_object,
        s.reverse_orientation,
        Some(cx.textures),
        warnings,
    );
    let material: MaybeIndex = cx.material_for(s, &params, warnings).into();
    // The shape's warnings point at its directive.
    for w in &mut warnings[first..] {
        if w.loc.is_none() {
            w.loc = Some(s.entity.loc.clone());
        }
    }
    warnings.extend(params.unused_warnings());
    let area = match (&s.area_light, emitters) {
        (_, Emitters::None) | (None, _) => None,
        (Some(al), emitters) => {
            if al.name != "diffuse" && al.name != "area" {
                warnings.push(Warning::at(
                    &al.loc,
                    format!("AreaLightSource: area light \"{}\" unknown.", al.name),
                ));
                None
            } else {
                let p = Params::new(&al.params);
                let l_emit = p.spectrum("L", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
                let two_sided = p.bool("twosided", false);
                p.touch("samples");
                p.touch("nsamples");
                warnings.extend(p.unused_warnings());
                let shape = s.entity.name.as_str();
                if matches!(emitters, Emitters::Lights(_))
                    && matches!(shape, "cone" | "paraboloid" | "hyperboloid" | "curve")
                {
                    // pbrt-v3 aborts ("Cone::Sample not implemented") at the
                    // first point it lights.
                    warnings.push(Warning::at(
                        &al.loc,
                        format!(
                            "an area light on a \"{shape}\" cannot be sampled (pbrt-v3 stops \
                             there); it is seen but lights nothing"
                        ),
                    ));
                }
                Some((l_emit, two_sided, emitters))
            }
        }
    };
    drop(params);
    drop(entity);
    match area {
        Some((l_emit, two_sided, Emitters::Glows(glows))) => {
            let id = glows.len() as u32 | GLOW;
            glows.push(Glow { l_emit, two_sided });
            prims.extend(shapes.into_iter().map(|shape| Primitive {
                shape,
                material,
                area_light: Some(id).into(),
            }));
        }
        Some((l_emit, two_sided, Emitters::Lights(lights))) => {
            for shape in shapes {
                let id = lights.len() as u32;
                lights.push(Light::Area(DiffuseAreaLight::new(l_emit, shape.clone(), two_sided)));
                prims.push(Primitive { shape, material, area_light: Some(id).into() });
            }
        }
        _ => prims.extend(shapes.into_iter().map(|shape| Primitive {
            shape,
            material,
            area_light: MaybeIndex::NONE,
        })),
    }
}
