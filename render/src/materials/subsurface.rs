//! `Material "subsurface"` and `Material "kdsubsurface"` (pbrt-v3
//! `SubsurfaceMaterial`, `KdSubsurfaceMaterial`).
//!
//! At a hit each builds two things: the BSDF of its boundary, a smooth or
//! rough dielectric with the same lobes as glass, and a BSSRDF for light
//! that enters and leaves elsewhere. pbrt-v3's Whitted integrator uses the
//! BSDF alone, so farm builds that (as a [`Glass`]) and reads the BSSRDF's
//! parameters only to check them as pbrt-v3 does: textures they name must
//! exist, and a `name` must be one of pbrt-v3's measured media.

use super::create::MaterialParams;
use super::Glass;
use crate::textures::TexInput;
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// The measured media pbrt-v3's `GetMediumScatteringProperties` knows.
const MEASURED: &[&str] = &[
    "Apple",
    "Chicken1",
    "Chicken2",
    "Cream",
    "Ketchup",
    "Marble",
    "Potato",
    "Skimmilk",
    "Skin1",
    "Skin2",
    "Spectralon",
    "Wholemilk",
    "Lowfat Milk",
    "Reduced Milk",
    "Regular Milk",
    "Espresso",
    "Mint Mocha Coffee",
    "Lowfat Soy Milk",
    "Regular Soy Milk",
    "Lowfat Chocolate Milk",
    "Regular Chocolate Milk",
    "Coke",
    "Pepsi",
    "Sprite",
    "Gatorade",
    "Chardonnay",
    "White Zinfandel",
    "Merlot",
    "Budweiser Beer",
    "Coors Light Beer",
    "Clorox",
    "Apple Juice",
    "Cranberry Juice",
    "Grape Juice",
    "Ruby Grapefruit Juice",
    "White Grapefruit Juice",
    "Shampoo",
    "Strawberry Shampoo",
    "Head & Shoulders Shampoo",
    "Lemon Tea Powder",
    "Orange Powder",
    "Pink Lemonade Powder",
    "Cappuccino Powder",
    "Salt Powder",
    "Sugar Powder",
    "Suisse Mocha Powder",
    "Pacific Ocean Surface Water",
];

/// The boundary both materials share: `Kr`, `Kt`, `uroughness`,
/// `vroughness` as glass reads them, and `eta` a plain float (default 1.33).
fn boundary(m: MaterialParams, w: &mut Vec<Warning>) -> Glass {
    Glass {
        kr: m.s("Kr", 1.0, w),
        kt: m.s("Kt", 1.0, w),
        eta: TexInput::Value(m.value("eta", 1.33)),
        u_roughness: m.f("uroughness", 0.0, w),
        v_roughness: m.f("vroughness", 0.0, w),
        remap_roughness: m.remap,
        bump: m.bump,
    }
}

/// A `Material "subsurface"` (pbrt-v3 `CreateSubsurfaceMaterial`).
pub(super) fn subsurface(m: MaterialParams, w: &mut Vec<Warning>) -> Glass {
    let name = m.string("name", "");
    if !name.is_empty() && !MEASURED.contains(&name.as_str()) {
        m.warn(w, format!("Named material \"{name}\" not found.  Using defaults."));
    }
    let _ = (m.value("g", 0.0), m.value("scale", 1.0));
    // pbrt-v3's defaults: its skim milk, in mm⁻¹.
    let _ = m.spectrum("sigma_a", Spectrum::new(0.0011, 0.0024, 0.014), w);
    let _ = m.spectrum("sigma_s", Spectrum::new(2.55, 3.21, 3.77), w);
    boundary(m, w)
}

/// A `Material "kdsubsurface"` (pbrt-v3 `CreateKdSubsurfaceMaterial`).
pub(super) fn kd_subsurface(m: MaterialParams, w: &mut Vec<Warning>) -> Glass {
    let _ = (m.s("Kd", 0.5, w), m.s("mfp", 1.0, w));
    let _ = (m.value("g", 0.0), m.value("scale", 1.0));
    boundary(m, w)
}

#[cfg(test)]
mod tests {
    use super::super::{build, Material, MaterialFiles};
    use crate::textures::{TexInput, TextureSet};
    use farm_common::scene::{Entity, FileLoc, MaterialEntity, Param, ParamSet, ParamValue};

    fn material(name: &str, params: Vec<(&str, ParamValue)>) -> MaterialEntity {
        let mut set = ParamSet::default();
        for (n, value) in params {
            set.add(Param { name: n.into(), value, loc: FileLoc::default() });
        }
        MaterialEntity {
            name: None,
            entity: Entity { name: name.into(), params: set, loc: FileLoc::default() },
        }
    }

    /// Both build glass's boundary with pbrt-v3's eta 1.33, read the
    /// BSSRDF's parameters without a "not used" warning, and warn, as
    /// pbrt-v3 does, that the Whitted integrator ignores their scattering
    /// and of an unknown measured medium.
    #[test]
    fn the_boundary_is_a_dielectric_and_the_bssrdf_is_checked() {
        let mats = vec![
            material(
                "subsurface",
                vec![
                    ("name", ParamValue::String(vec!["Ketchup".into()])),
                    ("g", ParamValue::Float(vec![0.3])),
                ],
            ),
            material(
                "kdsubsurface",
                vec![("mfp", ParamValue::Spectrum(vec![farm_common::Spectrum::splat(2.0)]))],
            ),
            material("subsurface", vec![("name", ParamValue::String(vec!["Ketchupp".into()]))]),
        ];
        let mut w = Vec::new();
        let built = build(&mats, &TextureSet::default(), &MaterialFiles::none(), &mut w);
        for m in &built {
            let Material::Glass(g) = m else { panic!("{m:?}") };
            assert_eq!(g.eta, TexInput::Value(1.33));
            assert_eq!(
                (g.u_roughness, g.kr),
                (TexInput::Value(0.0), TexInput::Value(farm_common::Spectrum::ONE))
            );
        }
        let text: Vec<String> = w.iter().map(|w| w.message.clone()).collect();
        let whitted = |name: &str| {
            format!(
                "Subsurface scattering material \"{name}\" used, but \"whitted\" integrator \
                 doesn't support subsurface scattering."
            )
        };
        let named = "Named material \"Ketchupp\" not found.  Using defaults.".to_string();
        assert_eq!(
            text,
            [whitted("subsurface"), whitted("kdsubsurface"), whitted("subsurface"), named]
        );
    }
}
