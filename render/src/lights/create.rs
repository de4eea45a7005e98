//! Lights from `LightSource` entities: the name → constructor table
//! (pbrt-v3 `api.cpp` `MakeLight`); each light's constructor, with pbrt-v3's
//! parameter names and defaults, sits in its own file.

use super::{
    DistantLight, GoniometricLight, InfiniteLight, Light, PointLight, ProjectionLight, SpotLight,
};
use crate::image::{read_image, MipMap, RgbImage, WrapMode};
use farm_common::geometry::Transform;
use farm_common::scene::{Entity, Params, Warning};
use farm_common::Spectrum;
use std::collections::BTreeMap;

/// The light an entity describes, placed by `render_from_light`; `None` (with
/// a warning) for light types this renderer does not have.
pub fn create(
    e: &Entity,
    render_from_light: &Transform,
    assets: &BTreeMap<String, Vec<u8>>,
    warnings: &mut Vec<Warning>,
) -> Option<Light> {
    let p = Params::new(&e.params);
    let t = render_from_light;
    let light = match e.name.as_str() {
        "point" => Light::Point(PointLight::create(&p, t)),
        "spot" => Light::Spot(SpotLight::create(&p, t)),
        "distant" => Light::Distant(DistantLight::create(&p, t)),
        "goniometric" => {
            let map = image_map(&p, e, assets, warnings).map(|img| mipmap(&img));
            Light::Goniometric(Box::new(GoniometricLight::create(&p, t, map)))
        }
        "projection" => {
            let map =
                image_map(&p, e, assets, warnings).map(|img| (img.width, img.height, mipmap(&img)));
            Light::Projection(Box::new(ProjectionLight::create(&p, t, map)))
        }
        "infinite" | "exinfinite" => {
            Light::Infinite(Box::new(InfiniteLight::create(&p, e, t, assets, warnings)))
        }
        other => {
            warnings
                .push(Warning::at(&e.loc, format!("LightSource: light type \"{other}\" unknown.")));
            return None;
        }
    };
    warnings.extend(p.unused_warnings());
    Some(light)
}

/// The image a light's `"string mapname"` names, read from the scene's
/// assets; `None`, with a warning saying what the light does instead, when
/// it is absent or unreadable (pbrt-v3 then lights as if there were none).
pub(super) fn image_map(
    p: &Params,
    e: &Entity,
    assets: &BTreeMap<String, Vec<u8>>,
    warnings: &mut Vec<Warning>,
) -> Option<RgbImage> {
    let map = p.string("mapname", "");
    if map.is_empty() {
        return None;
    }
    let why = match assets.get(&map).map(|b| read_image(b, &map)) {
        Some(Ok(img)) if img.width > 0 && img.height > 0 => return Some(img),
        Some(Ok(_)) => "the image is empty".to_string(),
        Some(Err(err)) => err.to_string(),
        None => "not loaded".to_string(),
    };
    warnings.push(Warning::at(
        &e.loc,
        format!("{map}: {why}; LightSource \"{}\" lights without its map", e.name),
    ));
    None
}

/// pbrt-v3's default `MIPMap<RGBSpectrum>` of a light's map: bilinear
/// lookups, repeating at the edges.
fn mipmap(img: &RgbImage) -> MipMap<Spectrum> {
    let texels = img.pixels.iter().map(|&[r, g, b]| Spectrum::new(r, g, b)).collect();
    MipMap::new(img.width, img.height, texels, false, 8.0, WrapMode::Repeat)
}
