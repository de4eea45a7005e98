//! `AreaLightSource "diffuse"` (alias `"area"`): a shape emitting constant
//! radiance from its front side, or both (pbrt-v3 `lights/diffuse.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use crate::shapes::Shape;
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;

/// An emitting shape.
#[derive(Clone, Debug)]
pub struct DiffuseAreaLight {
    /// What it emits, and to which side.
    pub emission: Glow,
    /// The emitting shape (render space); private with what is worked out
    /// from it below.
    shape: Shape,
    /// 1 / the shape's area, worked out once (pbrt-v3 keeps `area` too);
    /// private, like `shape`, so that only [`DiffuseAreaLight::new`] makes
    /// a light and it always matches `shape`.
    inv_area: f32,
    /// [`Shape::light_normal`], worked out once in the same way.
    geometric_normal: Vec3,
}

impl DiffuseAreaLight {
    /// The light of `shape` emitting `l_emit`.
    pub fn new(l_emit: Spectrum, shape: Shape, two_sided: bool) -> Self {
        let (inv_area, geometric_normal) = (1.0 / shape.area(), shape.light_normal());
        let emission = Glow { l_emit, two_sided };
        DiffuseAreaLight { emission, shape, inv_area, geometric_normal }
    }

    /// Radiance leaving a point of the shape whose geometric normal is `n`,
    /// in direction `w`.
    #[inline]
    pub fn l(&self, n: Vec3, w: Vec3) -> Spectrum {
        self.emission.l(n, w)
    }

    /// Samples a point on the shape as seen from `r`.
    #[inline]
    pub fn sample_li(&self, r: &Interaction, u: Vec2) -> Option<LightSample> {
        let (p_shape, pdf) =
            self.shape.sample_from_light(r, u, self.inv_area, self.geometric_normal)?;
        let d = p_shape.p - r.p;
        if pdf == 0.0 || d.length_squared() == 0.0 {
            return None;
        }
        let wi = d.normalize();
        Some(LightSample { li: self.l(p_shape.n, -wi), wi, pdf, p_light: p_shape })
    }
}

/// What a diffuse area light emits (pbrt-v3 `DiffuseAreaLight::L`); alone,
/// a surface that emits where it is seen but lights nothing: an area
/// light on a shape inside an object instance. pbrt-v3 warns ("Area
/// lights not supported with object instancing") but keeps the light on
/// the instance's primitives, so camera and specular rays that hit them
/// see `L`; only the scene's light list, which shadow rays sample, leaves
/// it out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glow {
    /// Emitted radiance (`L` × `scale`).
    pub l_emit: Spectrum,
    /// `twosided`: emit from the back too.
    pub two_sided: bool,
}

impl Glow {
    /// Radiance leaving a point with geometric normal `n` in direction `w`:
    /// `l_emit` on the front side, or on both.
    #[inline]
    pub fn l(&self, n: Vec3, w: Vec3) -> Spectrum {
        if self.two_sided || n.dot(w) > 0.0 {
            self.l_emit
        } else {
            Spectrum::ZERO
        }
    }
}
