//! Building a [`Filter`] from the scene's `PixelFilter` directive (pbrt-v3
//! `MakeFilter` and the `Create*Filter` functions).

use super::{BoxFilter, Filter, GaussianFilter, LanczosSincFilter, MitchellFilter, TriangleFilter};
use farm_common::film::filter_radius;
use farm_common::scene::{Entity, Params, Warning};

/// The filter named by `entity`, with pbrt-v3's defaults; unknown names
/// warn as pbrt-v3 does and fall back to `"box"`. Unused parameters are reported.
pub fn create(entity: &Entity, warnings: &mut Vec<Warning>) -> Filter {
    let params = Params::new(&entity.params);
    // The radius is the film layout's, which the coordinator tiles by.
    let r = filter_radius(&entity.name, &params);
    let filter = match entity.name.as_str() {
        "gaussian" => Filter::Gaussian(GaussianFilter::new(r, params.float("alpha", 2.0))),
        "mitchell" => {
            let b = params.float("B", 1.0 / 3.0);
            Filter::Mitchell(MitchellFilter::new(r, b, params.float("C", 1.0 / 3.0)))
        }
        "sinc" => Filter::LanczosSinc(LanczosSincFilter::new(r, params.float("tau", 3.0))),
        "triangle" => Filter::Triangle(TriangleFilter::new(r)),
        name => {
            if name != "box" {
                warnings.push(Warning::at(&entity.loc, format!("Filter \"{name}\" unknown.")));
            }
            Filter::Box(BoxFilter::new(r))
        }
    };
    warnings.extend(params.unused_warnings());
    filter
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::Vec2;
    use farm_common::scene::{FileLoc, Param, ParamValue};

    fn entity(name: &str, floats: &[(&str, f32)]) -> Entity {
        let mut e = Entity::named(name);
        for &(n, v) in floats {
            e.params.add(Param {
                name: n.into(),
                value: ParamValue::Float(vec![v]),
                loc: FileLoc::default(),
            });
        }
        e
    }

    #[test]
    fn defaults_match_pbrt() {
        let mut w = Vec::new();
        let r = |name: &str, w: &mut Vec<Warning>| create(&entity(name, &[]), w).radius();
        assert_eq!(r("box", &mut w), Vec2::splat(0.5));
        assert_eq!(r("gaussian", &mut w), Vec2::splat(2.0));
        assert_eq!(r("mitchell", &mut w), Vec2::splat(2.0));
        assert_eq!(r("sinc", &mut w), Vec2::splat(4.0));
        assert_eq!(r("triangle", &mut w), Vec2::splat(2.0));
        assert!(w.is_empty());
        let g = create(&entity("gaussian", &[]), &mut w);
        assert_eq!(g.evaluate(Vec2::new(2.0, 0.0)), 0.0);
        assert_eq!(g.evaluate(Vec2::new(0.0, 2.0)), 0.0);
    }

    #[test]
    fn box_is_one_inside_and_unknown_falls_back() {
        let mut w = Vec::new();
        let f = create(&entity("bogus", &[("xwidth", 1.5), ("sharpness", 2.0)]), &mut w);
        assert_eq!(f.radius(), Vec2::new(1.5, 0.5));
        assert_eq!(f.evaluate(Vec2::new(1.2, -0.4)), 1.0);
        assert_eq!(w.len(), 2);
        assert_eq!(w[0].message, "Filter \"bogus\" unknown.");
        assert_eq!(w[1].message, "Parameter \"sharpness\" not used");
    }
}
