//! Building materials from `Material`/`MakeNamedMaterial` directives: the
//! name → constructor table (pbrt-v3 `api.cpp` `MakeMaterial`); each
//! material's constructor, with pbrt-v3's parameter names and defaults,
//! sits in its own file.

use super::fourier::{Fourier, MaterialFiles};
use super::{
    subsurface, Disney, Glass, Hair, Material, Matte, Metal, Mirror, MixMaterial, Plastic,
    Substrate, Translucent, Uber,
};
use crate::textures::{Resolver, TexInput, TextureSet};
use farm_common::scene::{FileLoc, MaterialEntity, ParamSet, ParamValue, Params, Warning};
use farm_common::Spectrum;

/// What every material's constructor reads: its parameters, the textures
/// they may name, and the two parameters all materials share.
pub(super) struct MaterialParams<'a> {
    p: &'a Params<'a>,
    r: &'a Resolver<'a>,
    loc: &'a FileLoc,
    /// The files materials read.
    pub files: &'a MaterialFiles<'a>,
    /// `"float bumpmap"` (a float texture), if given.
    pub bump: Option<TexInput<f32>>,
    /// `"bool remaproughness"`.
    pub remap: bool,
}

impl MaterialParams<'_> {
    /// A spectrum texture or value, defaulting to `v` in every channel.
    pub fn s(&self, name: &str, v: f32, w: &mut Vec<Warning>) -> TexInput<Spectrum> {
        self.r.spectrum(self.p, name, Spectrum::splat(v), w)
    }

    /// A spectrum texture or value, defaulting to `default`.
    pub fn spectrum(
        &self,
        name: &str,
        default: Spectrum,
        w: &mut Vec<Warning>,
    ) -> TexInput<Spectrum> {
        self.r.spectrum(self.p, name, default, w)
    }

    /// A float texture or value, defaulting to `v`.
    pub fn f(&self, name: &str, v: f32, w: &mut Vec<Warning>) -> TexInput<f32> {
        self.r.float(self.p, name, v, w)
    }

    /// A spectrum texture or value, if given.
    pub fn spectrum_or_none(&self, name: &str, w: &mut Vec<Warning>) -> Option<TexInput<Spectrum>> {
        self.r.spectrum_or_none(self.p, name, w)
    }
    /// A float texture or value, if given.
    pub fn opt(&self, name: &str, w: &mut Vec<Warning>) -> Option<TexInput<f32>> {
        self.r.float_or_none(self.p, name, w)
    }

    /// A plain float parameter (never a texture), defaulting to `v`.
    pub fn value(&self, name: &str, v: f32) -> f32 {
        self.p.float(name, v)
    }
    /// A bool parameter, defaulting to `v`.
    pub fn flag(&self, name: &str, v: bool) -> bool {
        self.p.bool(name, v)
    }
    /// A string parameter, defaulting to `v`.
    pub fn string(&self, name: &str, v: &str) -> String {
        self.p.string(name, v)
    }
    /// Where the material was declared.
    pub fn loc(&self) -> &FileLoc {
        self.loc
    }
    /// A warning at the material's directive.
    pub fn warn(&self, w: &mut Vec<Warning>, message: String) {
        w.push(Warning::at(self.loc, message));
    }
    /// The index of refraction: `eta`, or its older name `index`.
    pub fn eta(&self, w: &mut Vec<Warning>) -> TexInput<f32> {
        self.opt("eta", w).unwrap_or_else(|| self.f("index", 1.5, w))
    }
}

fn make(
    e: &MaterialEntity,
    index: usize,
    p: &Params,
    r: &Resolver,
    files: &MaterialFiles,
    w: &mut Vec<Warning>,
) -> Material {
    let bump = r.float_or_none(p, "bumpmap", w);
    let loc = &e.entity.loc;
    let m = MaterialParams { p, r, loc, files, bump, remap: p.bool("remaproughness", true) };
    let name = e.entity.name.as_str();
    if matches!(name, "subsurface" | "kdsubsurface") {
        // pbrt-v3's MakeMaterial warning; only the material's specular
        // interface is rendered.
        w.push(Warning::at(
            loc,
            format!(
                "Subsurface scattering material \"{name}\" used, but \"whitted\" integrator \
                 doesn't support subsurface scattering."
            ),
        ));
    }
    match name {
        "plastic" => Material::Plastic(Plastic::create(m, w)),
        "mirror" => Material::Mirror(Mirror::create(m, w)),
        "glass" => Material::Glass(Glass::create(m, w)),
        "disney" => Material::Disney(Box::new(Disney::create(m, w))),
        "hair" => Material::Hair(Box::new(Hair::create(m, w))),
        "fourier" => Material::Fourier(Fourier::create(m, w)),
        "subsurface" => Material::Glass(subsurface::subsurface(m, w)),
        "kdsubsurface" => Material::Glass(subsurface::kd_subsurface(m, w)),
        "metal" => Material::Metal(Metal::create(m, w)),
        "uber" => Material::Uber(Uber::create(m, w)),
        "substrate" => Material::Substrate(Substrate::create(m, w)),
        "translucent" => Material::Translucent(Translucent::create(m, w)),
        "mix" => {
            let pick = |name: &str, w: &mut Vec<Warning>| match p.material(name) {
                Some(m) if (m as usize) < index => m,
                _ => {
                    w.push(Warning::at(loc, format!("Named material \"{name}\" undefined for mix material; using the default matte")));
                    0
                }
            };
            let m1 = pick("namedmaterial1", w);
            let m2 = pick("namedmaterial2", w);
            Material::Mix(MixMaterial { m1, m2, amount: m.s("amount", 0.5, w) })
        }
        other => {
            if other != "matte" {
                w.push(Warning::at(loc, format!("Material \"{other}\" unknown. Using \"matte\".")));
            }
            Material::Matte(Matte::create(m, w))
        }
    }
}

/// The material a shape gets when its own parameters may set the
/// material's (pbrt-v3 `GraphicsState::GetMaterialForShape`): `base` built
/// again from `p`, which holds the material's parameters overlaid with the
/// shape's. Its warnings are the caller's to sort.
pub fn derive(
    base: &MaterialEntity,
    index: usize,
    p: &Params,
    textures: &TextureSet,
    files: &MaterialFiles,
    warnings: &mut Vec<Warning>,
) -> Material {
    let r = Resolver { set: textures, limit: textures.floats.len().max(textures.spectra.len()) };
    make(base, index, p, &r, files, warnings)
}

/// Whether a shape's parameters may set its material's (pbrt-v3
/// `shapeMayHaveMaterialParameters`): a texture other than an alpha mask,
/// a single float other than a radius, or any spectrum.
pub fn shape_may_set_material(set: &ParamSet) -> bool {
    set.params.iter().any(|p| match &p.value {
        ParamValue::Texture(_) => p.name != "alpha" && p.name != "shadowalpha",
        ParamValue::Float(v) => v.len() == 1 && p.name != "radius",
        ParamValue::Spectrum(_) => true,
        _ => false,
    })
}

/// Builds every material, in order, reading textures from `textures`.
/// Unknown types become matte with pbrt-v3's warning; unused parameters
/// are reported.
pub fn build(
    materials: &[MaterialEntity],
    textures: &TextureSet,
    files: &MaterialFiles,
    warnings: &mut Vec<Warning>,
) -> Vec<Material> {
    let r = Resolver { set: textures, limit: textures.floats.len().max(textures.spectra.len()) };
    materials
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let p = Params::new(&e.entity.params);
            // pbrt-v3 reads "type" from MakeNamedMaterial's parameters.
            p.touch("type");
            let m = make(e, i, &p, &r, files, warnings);
            warnings.extend(p.unused_warnings());
            m
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bxdf::{BxDFType, TransportMode};
    use crate::interaction::SurfaceInteraction;
    use farm_common::geometry::{DMat4, Transform, Vec2, Vec3};
    use farm_common::scene::{
        Entity, FileLoc, Param, ParamSet, ParamValue, TextureEntity, TextureKind, TextureRef,
    };
    use std::collections::BTreeMap;

    fn entity(name: &str, params: Vec<(&str, ParamValue)>) -> Entity {
        let mut set = ParamSet::default();
        for (n, v) in params {
            set.add(Param { name: n.into(), value: v, loc: FileLoc::default() });
        }
        Entity { name: name.into(), params: set, loc: FileLoc::default() }
    }

    fn hit() -> SurfaceInteraction {
        let mut si = SurfaceInteraction::new(
            Vec3::ZERO,
            Vec3::ZERO,
            Vec2::new(0.1, 0.1),
            Vec3::Z,
            Vec3::X,
            Vec3::Y,
            Vec3::ZERO,
            Vec3::ZERO,
            0.0,
            false,
        );
        si.dudx = 0.001;
        si.dvdy = 0.001;
        si
    }

    #[test]
    fn mirror_glass_and_textured_matte() {
        let textures = vec![
            TextureEntity {
                name: "checks".into(),
                kind: TextureKind::Spectrum,
                entity: entity(
                    "checkerboard",
                    vec![
                        ("uscale", ParamValue::Float(vec![4.0])),
                        ("tex1", ParamValue::Spectrum(vec![Spectrum::new(0.8, 0.1, 0.1)])),
                    ],
                ),
                world_from_texture: DMat4::IDENTITY,
            },
            TextureEntity {
                name: "img".into(),
                kind: TextureKind::Float,
                entity: entity(
                    "imagemap",
                    vec![("filename", ParamValue::String(vec!["missing.png".into()]))],
                ),
                world_from_texture: DMat4::IDENTITY,
            },
        ];
        let mut w = Vec::new();
        let set =
            crate::textures::build(&textures, &Transform::default(), &BTreeMap::new(), &mut w);
        assert!(w.iter().any(|x| x.message.contains("missing.png")), "{w:?}");
        assert!(crate::textures::uses_differentials(&set));
        let tref = |id| {
            ParamValue::Texture(TextureRef {
                name: "checks".into(),
                float_id: None,
                spectrum_id: Some(id),
            })
        };
        let mats = vec![
            MaterialEntity { name: None, entity: entity("matte", vec![("Kd", tref(0))]) },
            MaterialEntity {
                name: None,
                entity: entity(
                    "mirror",
                    vec![("Kr", ParamValue::Spectrum(vec![Spectrum::new(0.5, 0.6, 0.7)]))],
                ),
            },
            MaterialEntity {
                name: None,
                entity: entity(
                    "glass",
                    vec![
                        ("index", ParamValue::Float(vec![1.33])),
                        ("typo", ParamValue::Float(vec![1.0])),
                    ],
                ),
            },
            MaterialEntity {
                name: None,
                entity: entity(
                    "mix",
                    vec![
                        ("namedmaterial1", ParamValue::Material(0)),
                        ("namedmaterial2", ParamValue::Material(1)),
                        ("amount", ParamValue::Spectrum(vec![Spectrum::splat(0.25)])),
                    ],
                ),
            },
            MaterialEntity { name: None, entity: entity("foo", vec![]) },
        ];
        let built = build(&mats, &set, &MaterialFiles::none(), &mut w);
        assert!(w.iter().any(|x| x.message.contains("\"typo\" not used")), "{w:?}");
        assert!(w.iter().any(|x| x.message.contains("\"foo\" unknown")), "{w:?}");
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let mode = TransportMode::Radiance;
        // Matte takes the checkerboard's first colour at (0.4, 0.1).
        let b = built[0].compute_bsdf(&mut hit(), &built, &set, mode, false);
        let f = b.f(wo, Vec3::new(0.6, 0.0, 0.8), BxDFType::ALL);
        assert!((f.r - 0.8 / std::f32::consts::PI).abs() < 1e-5, "{f:?}");
        // The mirror returns Kr / cos θ with probability one.
        let b = built[1].compute_bsdf(&mut hit(), &built, &set, mode, false);
        let s = b.sample_f(wo, Vec2::new(0.5, 0.5), BxDFType::ALL).unwrap();
        assert!((s.f * 0.8 - Spectrum::new(0.5, 0.6, 0.7)).max_component().abs() < 1e-5);
        assert!((s.wi - Vec3::new(0.0, -0.6, 0.8)).length() < 1e-5 && s.pdf == 1.0);
        // Whitted glass: separate specular reflection and transmission lobes.
        let b = built[2].compute_bsdf(&mut hit(), &built, &set, mode, false);
        assert_eq!(b.num_components(BxDFType::ALL), 2);
        assert_eq!(b.eta, 1.33);
        let b = built[2].compute_bsdf(&mut hit(), &built, &set, mode, true);
        assert_eq!(b.num_components(BxDFType::ALL), 1);
        // Mix: matte scaled by amount, mirror by 1 - amount.
        let b = built[3].compute_bsdf(&mut hit(), &built, &set, mode, false);
        assert_eq!(b.num_components(BxDFType::ALL), 2);
        let f = b.f(wo, Vec3::new(0.6, 0.0, 0.8), BxDFType::ALL);
        assert!((f.r - 0.25 * 0.8 / std::f32::consts::PI).abs() < 1e-5, "{f:?}");
        assert!(matches!(built[4], Material::Matte(_)));
    }

    #[test]
    fn bump_map_tilts_the_shading_normal() {
        let textures = vec![TextureEntity {
            name: "ramp".into(),
            kind: TextureKind::Float,
            entity: entity(
                "bilerp",
                vec![
                    ("v00", ParamValue::Float(vec![0.0])),
                    ("v01", ParamValue::Float(vec![0.0])),
                    ("v10", ParamValue::Float(vec![1.0])),
                    ("v11", ParamValue::Float(vec![1.0])),
                ],
            ),
            world_from_texture: DMat4::IDENTITY,
        }];
        let mut w = Vec::new();
        let set =
            crate::textures::build(&textures, &Transform::default(), &BTreeMap::new(), &mut w);
        let tref = ParamValue::Texture(TextureRef {
            name: "ramp".into(),
            float_id: Some(0),
            spectrum_id: None,
        });
        let mats =
            vec![MaterialEntity { name: None, entity: entity("matte", vec![("bumpmap", tref)]) }];
        let built = build(&mats, &set, &MaterialFiles::none(), &mut w);
        let mut si = hit();
        built[0].compute_bsdf(&mut si, &built, &set, TransportMode::Radiance, false);
        // Height grows with u at slope 1: the normal leans to -x by 45°.
        let n = si.shading.n;
        assert!((n - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-3, "{n}");
        assert_eq!(si.it.n, Vec3::Z);
    }
}
