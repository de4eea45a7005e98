//! Building a [`TextureSet`] from the scene's `Texture` directives: the
//! name → constructor table (pbrt-v3 `api.cpp` `MakeFloatTexture`,
//! `MakeSpectrumTexture`), with pbrt-v3's parameter names and defaults.

use super::checkerboard::{AaMode, Checkerboard2D, Checkerboard3D};
use super::imagemap::{Cached, Caches};
use super::mapping::{Mapping2D, Mapping3D, Spaces};
use super::{
    Bilerp, Dots, Fbm, ImageMap, Marble, Mix, Resolver, Scale, Texture, TextureSet, UvTexture,
    Windy, Wrinkled,
};
use farm_common::geometry::Transform;
use farm_common::scene::{Params, TextureEntity, TextureKind, Warning};
use farm_common::Spectrum;
use std::collections::BTreeMap;

/// Whether any texture filters with screen-space derivatives (so camera
/// rays need differentials).
pub fn uses_differentials(set: &TextureSet) -> bool {
    set.floats.iter().flatten().any(Texture::uses_differentials)
        || set.spectra.iter().flatten().any(Texture::uses_differentials)
}

#[allow(clippy::too_many_arguments)]
fn make<T: Cached>(
    e: &TextureEntity,
    p: &Params,
    r: &Resolver,
    sp: &Spaces,
    assets: &BTreeMap<String, Vec<u8>>,
    caches: &mut Caches,
    w: &mut Vec<Warning>,
    is_spectrum: bool,
) -> Option<Texture<T>> {
    let loc = &e.entity.loc;
    let one = T::splat(1.0);
    let zero = T::splat(0.0);
    let solid = Mapping3D { xf: sp.solid_from_render };
    Some(match e.entity.name.as_str() {
        "constant" => Texture::Constant(T::value(p, "value", one)),
        "scale" => Texture::Scale(Scale {
            tex1: r.input(p, "tex1", one, w),
            tex2: r.input(p, "tex2", one, w),
        }),
        "mix" => Texture::Mix(Mix {
            tex1: r.input(p, "tex1", zero, w),
            tex2: r.input(p, "tex2", one, w),
            amount: r.float(p, "amount", 0.5, w),
        }),
        "bilerp" => Texture::Bilerp(Bilerp {
            mapping: Mapping2D::create(p, sp, loc, w),
            v00: T::value(p, "v00", zero),
            v01: T::value(p, "v01", one),
            v10: T::value(p, "v10", zero),
            v11: T::value(p, "v11", one),
        }),
        "checkerboard" => match p.int("dimension", 2) {
            2 => {
                let mapping = Mapping2D::create(p, sp, loc, w);
                let tex1 = r.input(p, "tex1", one, w);
                let tex2 = r.input(p, "tex2", zero, w);
                let aa = match p.string("aamode", "closedform").as_str() {
                    "none" => AaMode::None,
                    "closedform" => AaMode::ClosedForm,
                    other => {
                        w.push(Warning::at(loc, format!("Antialiasing mode \"{other}\" not understood by Checkerboard2DTexture; using \"closedform\"")));
                        AaMode::ClosedForm
                    }
                };
                Texture::Checkerboard2D(Checkerboard2D { mapping, tex1, tex2, aa })
            }
            3 => Texture::Checkerboard3D(Checkerboard3D {
                mapping: solid,
                tex1: r.input(p, "tex1", one, w),
                tex2: r.input(p, "tex2", zero, w),
            }),
            d => {
                w.push(Warning::at(
                    loc,
                    format!("{d} dimensional checkerboard texture not supported"),
                ));
                return None;
            }
        },
        "dots" => Texture::Dots(Dots {
            mapping: Mapping2D::create(p, sp, loc, w),
            // pbrt-v3 hands "inside" to the constructor's outsideDot.
            background: r.input(p, "inside", one, w),
            dot: r.input(p, "outside", zero, w),
        }),
        "imagemap" => Texture::ImageMap(ImageMap::create(p, sp, e, assets, caches, w)),
        "uv" if is_spectrum => Texture::Uv(UvTexture { mapping: Mapping2D::create(p, sp, loc, w) }),
        "fbm" => Texture::Fbm(Fbm {
            mapping: solid,
            omega: p.float("roughness", 0.5),
            octaves: p.int("octaves", 8),
        }),
        "wrinkled" => Texture::Wrinkled(Wrinkled {
            mapping: solid,
            omega: p.float("roughness", 0.5),
            octaves: p.int("octaves", 8),
        }),
        "windy" => Texture::Windy(Windy { mapping: solid }),
        "marble" if is_spectrum => Texture::Marble(Marble {
            mapping: solid,
            octaves: p.int("octaves", 8),
            omega: p.float("roughness", 0.5),
            scale: p.float("scale", 1.0),
            variation: p.float("variation", 0.2),
        }),
        "ptex" => {
            p.touch("filename");
            p.touch("gamma");
            w.push(Warning::at(
                loc,
                "texture type \"ptex\" is not supported (farm has no Ptex reader); materials that name it use their defaults",
            ));
            return None;
        }
        other => {
            let kind = if is_spectrum { "Spectrum" } else { "Float" };
            w.push(Warning::at(loc, format!("{kind} texture type \"{other}\" unknown.")));
            return None;
        }
    })
}

/// Builds every texture, in order; parameters naming textures resolve to
/// earlier ones. Image files are read from `assets` by their `"filename"`.
pub fn build(
    textures: &[TextureEntity],
    render_from_world: &Transform,
    assets: &BTreeMap<String, Vec<u8>>,
    warnings: &mut Vec<Warning>,
) -> TextureSet {
    let mut set = TextureSet { floats: Vec::new(), spectra: Vec::new() };
    let mut caches = Caches::default();
    let world_from_render = render_from_world.inverse();
    for (i, e) in textures.iter().enumerate() {
        let world_from_texture = Transform::from_dmat4(e.world_from_texture);
        let sp = Spaces {
            texture_from_render: render_from_world.compose(&world_from_texture).inverse(),
            world_from_render,
            solid_from_render: world_from_texture.compose(&world_from_render),
        };
        let p = Params::new(&e.entity.params);
        let (f, s) = {
            let r = Resolver { set: &set, limit: i };
            match e.kind {
                TextureKind::Float => {
                    (make::<f32>(e, &p, &r, &sp, assets, &mut caches, warnings, false), None)
                }
                TextureKind::Spectrum => {
                    (None, make::<Spectrum>(e, &p, &r, &sp, assets, &mut caches, warnings, true))
                }
            }
        };
        set.floats.push(f);
        set.spectra.push(s);
        warnings.extend(p.unused_warnings());
    }
    set
}
