//! Light sources (pbrt-v3 `core/light.h`, `lights/*.cpp`): one enum, one
//! variant per pbrt-v3 light, dispatched by `match`.

mod create;
mod diffuse;
mod distant;
mod goniometric;
mod infinite;
mod point;
mod projection;
mod spot;

pub use create::create;
pub use diffuse::{DiffuseAreaLight, Glow};
pub use distant::DistantLight;
pub use goniometric::GoniometricLight;
pub use infinite::InfiniteLight;
pub use point::PointLight;
pub use projection::ProjectionLight;
pub use spot::SpotLight;

use crate::interaction::Interaction;
use farm_common::geometry::{Ray, Vec2, Vec3};
use farm_common::Spectrum;

/// Incident radiance from a light toward a point, and what is needed to test
/// whether it arrives.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving at the reference point (before visibility).
    pub li: Spectrum,
    /// Unit direction from the reference point toward the light.
    pub wi: Vec3,
    /// Density of `wi` (solid angle), 1 for delta lights.
    pub pdf: f32,
    /// The point on the light the shadow ray goes to.
    pub p_light: Interaction,
}

/// The sample of a light at the single point `p`, giving intensity `i`
/// toward `r` (before the inverse-square falloff, which this applies).
#[inline]
pub(crate) fn point_sample(p: Vec3, i: Spectrum, r: &Interaction) -> Option<LightSample> {
    let d = p - r.p;
    Some(LightSample {
        li: i / d.length_squared(),
        wi: d.normalize(),
        pdf: 1.0,
        p_light: Interaction { p, time: r.time, ..Default::default() },
    })
}

/// A light source.
#[derive(Clone, Debug)]
pub enum Light {
    /// `LightSource "point"`
    Point(PointLight),
    /// `LightSource "spot"`
    Spot(SpotLight),
    /// `LightSource "goniometric"`
    Goniometric(Box<GoniometricLight>),
    /// `LightSource "projection"`
    Projection(Box<ProjectionLight>),
    /// `LightSource "distant"`
    Distant(DistantLight),
    /// `AreaLightSource "diffuse"` on one shape.
    Area(DiffuseAreaLight),
    /// `LightSource "infinite"`
    Infinite(Box<InfiniteLight>),
}

impl Light {
    /// Samples incident illumination at `r` (pbrt-v3 `Sample_Li`); `None`
    /// when no light arrives or the density is zero.
    #[inline]
    pub fn sample_li(&self, r: &Interaction, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Point(l) => l.sample_li(r),
            Light::Spot(l) => l.sample_li(r),
            Light::Goniometric(l) => l.sample_li(r),
            Light::Projection(l) => l.sample_li(r),
            Light::Distant(l) => l.sample_li(r),
            Light::Area(l) => l.sample_li(r, u),
            Light::Infinite(l) => l.sample_li(r, u),
        }
    }

    /// Whether [`Light::sample_li`] reads its sample: lights at a point or
    /// from one direction have one way to reach a point and ignore it.
    #[inline]
    pub fn reads_sample(&self) -> bool {
        matches!(self, Light::Area(_) | Light::Infinite(_))
    }

    /// Radiance along a ray that escapes the scene (pbrt-v3 `Le`).
    #[inline]
    pub fn le(&self, ray: &Ray) -> Spectrum {
        match self {
            Light::Infinite(l) => l.le(ray),
            _ => Spectrum::ZERO,
        }
    }

    /// Gives lights that depend on the scene's extent its bounding sphere.
    pub fn preprocess(&mut self, center: Vec3, radius: f32) {
        match self {
            Light::Distant(l) => l.world_radius = radius,
            Light::Infinite(l) => l.world_radius = radius,
            _ => {}
        }
        let _ = center;
    }
}
