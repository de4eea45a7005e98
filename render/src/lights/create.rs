//! Lights from `LightSource` entities, with pbrt-v3's parameter names and
//! defaults (`CreatePointLight`, `CreateSpotLight`, ...).

use super::{DistantLight, InfiniteLight, Light, PointLight, SpotLight};
use crate::image::read_image;
use farm_common::geometry::{coordinate_system, Mat4, Transform, Vec3, Vec4};
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
    let light = match e.name.as_str() {
        "point" => {
            let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
            // pbrt-v3 applies `from` after the light's transform.
            let from = p.point3("from", Vec3::ZERO);
            Some(Light::Point(PointLight { p: render_from_light.point(Vec3::ZERO) + from, i }))
        }
        "spot" => {
            let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
            let cone = p.float("coneangle", 30.0);
            let delta = p.float("conedelta", 5.0);
            let from = p.point3("from", Vec3::ZERO);
            let to = p.point3("to", Vec3::Z);
            let dir = (to - from).normalize();
            let (du, dv) = coordinate_system(dir);
            // Rows du, dv, dir: maps dir to +z.
            let dir_to_z = Mat4::from_cols(
                Vec4::new(du.x, dv.x, dir.x, 0.0),
                Vec4::new(du.y, dv.y, dir.y, 0.0),
                Vec4::new(du.z, dv.z, dir.z, 0.0),
                Vec4::W,
            );
            let light_m = render_from_light.m * Mat4::from_translation(from) * dir_to_z.transpose();
            let t = Transform::new(light_m);
            Some(Light::Spot(SpotLight {
                p: t.point(Vec3::ZERO),
                light_from_render: t.inverse(),
                i,
                cos_total_width: cone.to_radians().cos(),
                cos_falloff_start: (cone - delta).to_radians().cos(),
            }))
        }
        "distant" => {
            let l = p.spectrum("L", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
            let from = p.point3("from", Vec3::ZERO);
            let to = p.point3("to", Vec3::Z);
            let w_light = render_from_light.vector(from - to).normalize();
            Some(Light::Distant(DistantLight { l, w_light, world_radius: 0.0 }))
        }
        "infinite" | "exinfinite" => {
            let l = p.spectrum("L", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
            p.touch("samples");
            p.touch("nsamples");
            let map = p.string("mapname", "");
            let (w, h, texels) = if map.is_empty() {
                (1, 1, vec![l])
            } else {
                match assets.get(&map).map(|b| read_image(b, &map)) {
                    Some(Ok(img)) => {
                        let texels = img.pixels.iter().map(|&[r, g, b]| Spectrum::new(r, g, b) * l);
                        (img.width, img.height, texels.collect())
                    }
                    Some(Err(err)) => {
                        warnings.push(Warning::at(
                            &e.loc,
                            format!("{map}: {err}; using a constant map"),
                        ));
                        (1, 1, vec![l])
                    }
                    None => {
                        warnings.push(Warning::at(
                            &e.loc,
                            format!("{map}: not loaded; using a constant map"),
                        ));
                        (1, 1, vec![l])
                    }
                }
            };
            Some(Light::Infinite(Box::new(InfiniteLight::new(*render_from_light, w, h, texels))))
        }
        other => {
            warnings
                .push(Warning::at(&e.loc, format!("LightSource: light type \"{other}\" unknown.")));
            return None;
        }
    };
    warnings.extend(p.unused_warnings());
    light
}
