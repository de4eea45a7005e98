//! Building a [`TextureSet`] from the scene's `Texture` directives, with
//! pbrt-v3's parameter names and defaults (`Create*Texture` functions), and
//! resolving texture-or-value parameters for textures and materials
//! (pbrt-v3 `TextureParams::Get*Texture`).

use super::checkerboard::{AaMode, Checkerboard2D, Checkerboard3D};
use super::mapping::{Mapping2D, Mapping3D};
use super::{
    Bilerp, Dots, Fbm, ImageMap, Mix, Scale, TexInput, TexValue, Texture, TextureSet, UvTexture,
    Windy, Wrinkled,
};
use crate::image::{inverse_gamma_correct, read_image, MipMap, WrapMode};
use farm_common::geometry::{Transform, Vec3};
use farm_common::scene::{Params, TextureEntity, TextureKind, Warning};
use farm_common::Spectrum;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// Whether any texture filters with screen-space derivatives (so camera
/// rays need differentials).
pub fn uses_differentials(set: &TextureSet) -> bool {
    set.floats.iter().flatten().any(Texture::uses_differentials)
        || set.spectra.iter().flatten().any(Texture::uses_differentials)
}

/// Resolution context: textures may only refer to textures before `limit`.
pub(crate) struct Resolver<'a> {
    pub set: &'a TextureSet,
    pub limit: usize,
}

impl Resolver<'_> {
    fn lookup<T: TexValue>(
        &self,
        p: &Params,
        name: &str,
        id: impl Fn(&farm_common::scene::TextureRef) -> Option<u32>,
        what: &str,
        warnings: &mut Vec<Warning>,
    ) -> Option<TexInput<T>> {
        let tr = p.texture(name)?;
        match id(tr) {
            Some(i)
                if (i as usize) < self.limit
                    && matches!(T::table(self.set).get(i as usize), Some(Some(_))) =>
            {
                Some(TexInput::Texture(i))
            }
            _ => {
                let loc = p.set().get(name).map(|q| q.loc.clone()).unwrap_or_default();
                warnings.push(Warning::at(
                    &loc,
                    format!(
                        "Couldn't find {what} texture named \"{}\" for parameter \"{name}\"",
                        tr.name
                    ),
                ));
                None
            }
        }
    }

    /// A float texture parameter or its value, else `default`.
    pub fn float(
        &self,
        p: &Params,
        name: &str,
        default: f32,
        w: &mut Vec<Warning>,
    ) -> TexInput<f32> {
        self.lookup(p, name, |t| t.float_id, "float", w)
            .unwrap_or_else(|| TexInput::Value(p.float(name, default)))
    }

    /// A float texture parameter or value, if given.
    pub fn float_or_none(
        &self,
        p: &Params,
        name: &str,
        w: &mut Vec<Warning>,
    ) -> Option<TexInput<f32>> {
        self.lookup(p, name, |t| t.float_id, "float", w)
            .or_else(|| p.floats(name).and_then(|v| v.first()).map(|v| TexInput::Value(*v)))
    }

    /// A spectrum texture parameter or its value, else `default`.
    pub fn spectrum(
        &self,
        p: &Params,
        name: &str,
        default: Spectrum,
        w: &mut Vec<Warning>,
    ) -> TexInput<Spectrum> {
        self.lookup(p, name, |t| t.spectrum_id, "spectrum", w)
            .unwrap_or_else(|| TexInput::Value(p.spectrum(name, default)))
    }

    /// A texture of either value type.
    fn input<T: Param>(
        &self,
        p: &Params,
        name: &str,
        default: T,
        w: &mut Vec<Warning>,
    ) -> TexInput<T> {
        T::resolve(self, p, name, default, w)
    }
}

/// Reading a value-typed parameter (float or spectrum).
trait Param: TexValue {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: Self,
        w: &mut Vec<Warning>,
    ) -> TexInput<Self>;
    fn value(p: &Params, name: &str, default: Self) -> Self;
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> Self;
}

impl Param for f32 {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: f32,
        w: &mut Vec<Warning>,
    ) -> TexInput<f32> {
        r.float(p, name, default, w)
    }
    fn value(p: &Params, name: &str, default: f32) -> f32 {
        p.float(name, default)
    }
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> f32 {
        let y = rgb.y();
        scale * if gamma { inverse_gamma_correct(y) } else { y }
    }
}

impl Param for Spectrum {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: Spectrum,
        w: &mut Vec<Warning>,
    ) -> TexInput<Spectrum> {
        r.spectrum(p, name, default, w)
    }
    fn value(p: &Params, name: &str, default: Spectrum) -> Spectrum {
        p.spectrum(name, default)
    }
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> Spectrum {
        if gamma {
            rgb.map(inverse_gamma_correct) * scale
        } else {
            rgb * scale
        }
    }
}

/// Where textures map points: render space to each mapping's space.
struct Spaces {
    texture_from_render: Transform,
    world_from_render: Transform,
    /// pbrt-v3 hands `tex2world` to `IdentityMapping3D` as its world-to-texture transform.
    solid_from_render: Transform,
}

fn mapping_2d(
    p: &Params,
    sp: &Spaces,
    loc: &farm_common::scene::FileLoc,
    w: &mut Vec<Warning>,
) -> Mapping2D {
    match p.string("mapping", "uv").as_str() {
        "uv" => Mapping2D::Uv {
            su: p.float("uscale", 1.0),
            sv: p.float("vscale", 1.0),
            du: p.float("udelta", 0.0),
            dv: p.float("vdelta", 0.0),
        },
        "spherical" => Mapping2D::Spherical { texture_from_render: sp.texture_from_render },
        "cylindrical" => Mapping2D::Cylindrical { texture_from_render: sp.texture_from_render },
        "planar" => Mapping2D::Planar {
            vs: p.vector3("v1", Vec3::X),
            vt: p.vector3("v2", Vec3::Y),
            ds: p.float("udelta", 0.0),
            dt: p.float("vdelta", 0.0),
            world_from_render: sp.world_from_render,
        },
        other => {
            w.push(Warning::at(loc, format!("2D texture mapping \"{other}\" unknown")));
            Mapping2D::UV
        }
    }
}

/// Image cache key: file, filtering and conversion (pbrt-v3 `TexInfo`).
type CacheKey = (String, bool, u32, WrapMode, u32, bool);

#[derive(Default)]
struct Caches {
    floats: HashMap<CacheKey, Arc<MipMap<f32>>>,
    spectra: HashMap<CacheKey, Arc<MipMap<Spectrum>>>,
}

trait Cached: Param {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Arc<MipMap<Self>>>;
}
impl Cached for f32 {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Arc<MipMap<f32>>> {
        &mut c.floats
    }
}
impl Cached for Spectrum {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Arc<MipMap<Spectrum>>> {
        &mut c.spectra
    }
}

fn has_ext(name: &str, ext: &str) -> bool {
    name.to_ascii_lowercase().ends_with(ext)
}

#[allow(clippy::too_many_arguments)]
fn image_texture<T: Cached>(
    p: &Params,
    sp: &Spaces,
    e: &TextureEntity,
    assets: &BTreeMap<String, Vec<u8>>,
    caches: &mut Caches,
    w: &mut Vec<Warning>,
) -> Texture<T> {
    let loc = &e.entity.loc;
    let mapping = mapping_2d(p, sp, loc, w);
    let max_aniso = p.float("maxanisotropy", 8.0);
    let trilinear = p.bool("trilinear", false);
    let wrap = WrapMode::from_name(&p.string("wrap", "repeat"));
    let scale = p.float("scale", 1.0);
    let filename = p.string("filename", "");
    let gamma = p.bool("gamma", has_ext(&filename, ".tga") || has_ext(&filename, ".png"));
    let key = (filename.clone(), trilinear, max_aniso.to_bits(), wrap, scale.to_bits(), gamma);
    if let Some(m) = T::cache(caches).get(&key) {
        return Texture::ImageMap(ImageMap { mapping, mipmap: m.clone() });
    }
    let decoded = match assets.get(&filename) {
        Some(bytes) => read_image(bytes, &filename)
            .map_err(|err| format!("Unable to read image \"{filename}\": {err}")),
        None => Err(format!("Image file \"{filename}\" was not shipped with the scene")),
    };
    let (width, height, mut pixels) = match decoded {
        Ok(img) => {
            let texels = img.pixels.iter().map(|&[r, g, b]| Spectrum::new(r, g, b));
            (img.width, img.height, texels.collect::<Vec<_>>())
        }
        Err(msg) => {
            w.push(Warning::at(loc, msg));
            w.push(Warning::at(
                loc,
                format!("Creating a constant grey texture to replace \"{filename}\"."),
            ));
            (1, 1, vec![Spectrum::splat(0.5)])
        }
    };
    // Texture space has (0, 0) at the lower left: flip rows.
    for y in 0..height / 2 {
        for x in 0..width {
            pixels.swap(y * width + x, (height - 1 - y) * width + x);
        }
    }
    let texels: Vec<T> = pixels.iter().map(|&c| T::from_image(c, scale, gamma)).collect();
    let mip = Arc::new(MipMap::new(width, height, texels, trilinear, max_aniso, wrap));
    T::cache(caches).insert(key, mip.clone());
    Texture::ImageMap(ImageMap { mapping, mipmap: mip })
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
            mapping: mapping_2d(p, sp, loc, w),
            v00: T::value(p, "v00", zero),
            v01: T::value(p, "v01", one),
            v10: T::value(p, "v10", zero),
            v11: T::value(p, "v11", one),
        }),
        "checkerboard" => match p.int("dimension", 2) {
            2 => {
                let mapping = mapping_2d(p, sp, loc, w);
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
            mapping: mapping_2d(p, sp, loc, w),
            inside: r.input(p, "inside", one, w),
            outside: r.input(p, "outside", zero, w),
        }),
        "imagemap" => image_texture::<T>(p, sp, e, assets, caches, w),
        "uv" if is_spectrum => Texture::Uv(UvTexture { mapping: mapping_2d(p, sp, loc, w) }),
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
