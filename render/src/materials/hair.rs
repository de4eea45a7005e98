//! `Material "hair"` (pbrt-v3 `HairMaterial`): a hair fibre's scattering,
//! its absorption given directly (`sigma_a`), by colour (`color`), or by
//! melanin concentrations, in that order of precedence.

use super::create::MaterialParams;
use crate::bxdf::{Bsdf, BxDF, HairBsdf};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// How the fibre's absorption is given.
#[derive(Clone, Debug, PartialEq)]
pub enum Absorption {
    /// `sigma_a`.
    SigmaA(TexInput<Spectrum>),
    /// `color`: the absorption that gives it after multiple scattering.
    Color(TexInput<Spectrum>),
    /// `eumelanin` and `pheomelanin` concentrations.
    Melanin(Option<TexInput<f32>>, Option<TexInput<f32>>),
}

/// Hair.
#[derive(Clone, Debug, PartialEq)]
pub struct Hair {
    /// The absorption.
    pub absorption: Absorption,
    /// `eta` (1.55).
    pub eta: TexInput<f32>,
    /// `beta_m`, longitudinal roughness (0.3).
    pub beta_m: TexInput<f32>,
    /// `beta_n`, azimuthal roughness (0.3).
    pub beta_n: TexInput<f32>,
    /// `alpha`, the scales' tilt in degrees (2).
    pub alpha: TexInput<f32>,
}

impl Hair {
    /// The BSDF at `si`: the fibre seen at offset h = 2v − 1 across it.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let bm = t.eval(&self.beta_m, si);
        let bn = t.eval(&self.beta_n, si);
        let a = t.eval(&self.alpha, si);
        let e = t.eval(&self.eta, si);
        let mut bsdf = Bsdf::new(si, e);
        let sigma_a = match &self.absorption {
            Absorption::SigmaA(s) => t.eval(s, si).clamp(0.0, f32::INFINITY),
            Absorption::Color(c) => {
                HairBsdf::sigma_a_from_reflectance(t.eval(c, si).clamp(0.0, f32::INFINITY), bn)
            }
            Absorption::Melanin(eu, ph) => {
                let c =
                    |x: &Option<TexInput<f32>>| x.as_ref().map_or(0.0, |x| t.eval(x, si)).max(0.0);
                HairBsdf::sigma_a_from_concentration(c(eu), c(ph))
            }
        };
        let h = -1.0 + 2.0 * si.uv.y;
        bsdf.add(BxDF::Hair(HairBsdf::new(h, e, sigma_a, bm, bn, a)));
        bsdf
    }

    /// A `Material "hair"` with pbrt-v3's parameters, defaults and
    /// warnings (`CreateHairMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        let sigma_a = m.spectrum_or_none("sigma_a", w);
        let color = m.spectrum_or_none("color", w);
        let eu = m.opt("eumelanin", w);
        let ph = m.opt("pheomelanin", w);
        let mut ignore = |what: &str, since: &str| {
            m.warn(w, format!("Ignoring \"{what}\" parameter since \"{since}\" was provided."))
        };
        let absorption = if let Some(s) = sigma_a {
            if color.is_some() {
                ignore("color", "sigma_a");
            }
            if eu.is_some() {
                ignore("eumelanin", "sigma_a");
            }
            if ph.is_some() {
                ignore("pheomelanin", "sigma_a");
            }
            Absorption::SigmaA(s)
        } else if let Some(c) = color {
            if eu.is_some() {
                ignore("eumelanin", "color");
            }
            if ph.is_some() {
                ignore("pheomelanin", "color");
            }
            Absorption::Color(c)
        } else if eu.is_some() || ph.is_some() {
            Absorption::Melanin(eu, ph)
        } else {
            // pbrt-v3's default: brown hair.
            Absorption::SigmaA(TexInput::Value(HairBsdf::sigma_a_from_concentration(1.3, 0.0)))
        };
        Hair {
            absorption,
            eta: m.f("eta", 1.55, w),
            beta_m: m.f("beta_m", 0.3, w),
            beta_n: m.f("beta_n", 0.3, w),
            alpha: m.f("alpha", 2.0, w),
        }
    }
}
