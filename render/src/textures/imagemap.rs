//! `"imagemap"` (pbrt-v3 `ImageTexture`): a MIP-mapped image looked up with
//! the hit's texture-space footprint.

use super::mapping::{Mapping2D, Spaces};
use super::resolve::Param;
use super::TexValue;
use crate::image::{read_image, MipMap, WrapMode};
use crate::interaction::SurfaceInteraction;
use farm_common::scene::{Params, TextureEntity, Warning};
use farm_common::Spectrum;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// An image texture; identical (file, filtering) maps share one [`MipMap`].
#[derive(Clone, Debug)]
pub struct ImageMap<T: TexValue> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// The image pyramid (scale and gamma already applied).
    pub mipmap: Arc<MipMap<T>>,
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
    floats: HashMap<CacheKey, Arc<MipMap<f32>>>,
    spectra: HashMap<CacheKey, Arc<MipMap<Spectrum>>>,
}

pub(super) trait Cached: Param {
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
        let mip = Arc::new(MipMap::new(width, height, texels, trilinear, max_aniso, wrap));
        T::cache(caches).insert(key, mip.clone());
        ImageMap { mapping, mipmap: mip }
    }
}
