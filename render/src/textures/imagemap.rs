//! `"imagemap"` (pbrt-v3 `ImageTexture`): a MIP-mapped image looked up with
//! the hit's texture-space footprint.

use super::mapping::{Mapping2D, Spaces};
use super::resolve::Param;
use super::TexValue;
use crate::image::{read_image, MipMap, WrapMode};
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::Vec2;
use farm_common::scene::{Params, TextureEntity, Warning};
use farm_common::Spectrum;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// An image texture; identical (file, filtering) maps share one pyramid.
#[derive(Clone, Debug)]
pub struct ImageMap<T: TexValue> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// The image pyramid (scale and gamma already applied).
    pub mipmap: Pyramid<T>,
}

/// What an image texture looks up. An RGB image whose texels are all grey
/// (the same bits in every channel, as a grey PNG read as RGB is) keeps
/// one channel: a third of the memory and of the filtering's arithmetic.
/// Every step of a MIP map's build and lookups works channel by channel
/// with the same operations in the same order, so the grey pyramid's
/// value, repeated in each channel, has the bits the RGB one would give.
#[derive(Clone, Debug)]
pub enum Pyramid<T: TexValue> {
    /// The texels as they are.
    Full(Arc<MipMap<T>>),
    /// One channel of grey texels.
    Grey(Arc<MipMap<f32>>),
}

impl<T: TexValue> Pyramid<T> {
    /// pbrt-v3's filtered lookup ([`MipMap::lookup_ewa`]).
    #[inline]
    pub fn lookup_ewa(&self, st: Vec2, dst0: Vec2, dst1: Vec2) -> T {
        match self {
            Pyramid::Full(m) => m.lookup_ewa(st, dst0, dst1),
            Pyramid::Grey(m) => T::splat(m.lookup_ewa(st, dst0, dst1)),
        }
    }

    /// The pyramid of `texels`, one channel of them if they are all grey.
    fn new(
        width: usize,
        height: usize,
        texels: Vec<T>,
        trilinear: bool,
        aniso: f32,
        wrap: WrapMode,
    ) -> Self {
        match texels.iter().map(|t| t.grey()).collect::<Option<Vec<f32>>>() {
            Some(grey) => {
                drop(texels);
                Pyramid::Grey(Arc::new(MipMap::new(width, height, grey, trilinear, aniso, wrap)))
            }
            None => {
                Pyramid::Full(Arc::new(MipMap::new(width, height, texels, trilinear, aniso, wrap)))
            }
        }
    }
}

impl<T: TexValue> ImageMap<T> {
    /// The filtered value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> T {
        let m = self.mapping.map(si);
        self.mipmap.lookup_ewa(m.st, m.dstdx, m.dstdy)
    }
}

/// Image cache key: file, filtering and conversion (pbrt-v3 `TexInfo`).
type CacheKey = (String, bool, u32, WrapMode, u32, bool);

#[derive(Default)]
pub(super) struct Caches {
    floats: HashMap<CacheKey, Pyramid<f32>>,
    spectra: HashMap<CacheKey, Pyramid<Spectrum>>,
}

pub(super) trait Cached: Param + TexValue {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Pyramid<Self>>;
}
impl Cached for f32 {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Pyramid<f32>> {
        &mut c.floats
    }
}
impl Cached for Spectrum {
    fn cache(c: &mut Caches) -> &mut HashMap<CacheKey, Pyramid<Spectrum>> {
        &mut c.spectra
    }
}

fn has_ext(name: &str, ext: &str) -> bool {
    name.to_ascii_lowercase().ends_with(ext)
}

impl<T: TexValue> ImageMap<T> {
    /// An `"imagemap"` texture (pbrt-v3 `CreateImage*Texture`); images
    /// with the same file and filtering share one MIP map through `caches`.
    pub(super) fn create(
        p: &Params,
        sp: &Spaces,
        e: &TextureEntity,
        assets: &BTreeMap<String, Vec<u8>>,
        caches: &mut Caches,
        w: &mut Vec<Warning>,
    ) -> Self
    where
        T: Cached,
    {
        let loc = &e.entity.loc;
        let mapping = Mapping2D::create(p, sp, loc, w);
        let max_aniso = p.float("maxanisotropy", 8.0);
        let trilinear = p.bool("trilinear", false);
        let wrap = WrapMode::from_name(&p.string("wrap", "repeat"));
        let scale = p.float("scale", 1.0);
        let filename = p.string("filename", "");
        let gamma = p.bool("gamma", has_ext(&filename, ".tga") || has_ext(&filename, ".png"));
        let key = (filename.clone(), trilinear, max_aniso.to_bits(), wrap, scale.to_bits(), gamma);
        if let Some(m) = T::cache(caches).get(&key) {
            return ImageMap { mapping, mipmap: m.clone() };
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
        let mip = Pyramid::new(width, height, texels, trilinear, max_aniso, wrap);
        T::cache(caches).insert(key, mip.clone());
        ImageMap { mapping, mipmap: mip }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    /// Grey texels with a few exact repeats, zeros and both signs of zero.
    fn grey_texels(rng: &mut Rng, n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| match i % 11 {
                0 => 0.0,
                1 => -0.0,
                2 => 1.0,
                _ => rng.uniform_f32() * 4.0,
            })
            .collect()
    }

    #[test]
    fn a_grey_image_keeps_one_channel_and_gives_the_rgb_pyramids_bits() {
        let mut rng = Rng::new(7);
        // Powers of two and sizes resampled up to them, every wrap mode,
        // EWA and trilinear.
        for (w, h) in [(8usize, 8usize), (5, 3), (1, 7), (16, 4), (13, 9)] {
            for wrap in [WrapMode::Repeat, WrapMode::Clamp, WrapMode::Black] {
                for trilinear in [false, true] {
                    let grey = grey_texels(&mut rng, w * h);
                    let rgb: Vec<Spectrum> = grey.iter().map(|&v| Spectrum::splat(v)).collect();
                    let full = MipMap::new(w, h, rgb.clone(), trilinear, 8.0, wrap);
                    let kept = Pyramid::new(w, h, rgb, trilinear, 8.0, wrap);
                    assert!(matches!(kept, Pyramid::Grey(_)), "{w}x{h}: not kept grey");
                    for _ in 0..500 {
                        let st =
                            Vec2::new(rng.uniform_f32() * 3.0 - 1.0, rng.uniform_f32() * 3.0 - 1.0);
                        let scale = [0.0, 1e-3, 0.05, 0.4][rng.uniform_u32_below(4) as usize];
                        let d0 =
                            Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * scale;
                        let d1 =
                            Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * scale;
                        let want = full.lookup_ewa(st, d0, d1);
                        let got = kept.lookup_ewa(st, d0, d1);
                        for (a, b) in [(got.r, want.r), (got.g, want.g), (got.b, want.b)] {
                            assert_eq!(
                                a.to_bits(),
                                b.to_bits(),
                                "{w}x{h} {wrap:?} {st:?} {d0:?} {d1:?}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn an_image_with_any_colour_keeps_its_channels() {
        let mut texels = vec![Spectrum::splat(0.5); 16];
        texels[9].b = 0.25;
        assert!(matches!(
            Pyramid::new(4, 4, texels, false, 8.0, WrapMode::Repeat),
            Pyramid::Full(_)
        ));
        // Zeros of both signs are not the same bits.
        let mut texels = vec![Spectrum::splat(0.0); 4];
        texels[2].g = -0.0;
        assert!(matches!(
            Pyramid::new(2, 2, texels, false, 8.0, WrapMode::Repeat),
            Pyramid::Full(_)
        ));
        let floats = vec![0.5f32; 4];
        assert!(matches!(
            Pyramid::new(2, 2, floats, false, 8.0, WrapMode::Repeat),
            Pyramid::Full(_)
        ));
    }
}
