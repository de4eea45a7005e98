//! Lights from `LightSource` entities: the name → constructor table
//! (pbrt-v3 `api.cpp` `MakeLight`); each light's constructor, with pbrt-v3's
//! parameter names and defaults, sits in its own file.

use super::{DistantLight, InfiniteLight, Light, PointLight, SpotLight};
use farm_common::geometry::Transform;
use farm_common::scene::{Entity, Params, Warning};
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
