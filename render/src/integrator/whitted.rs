//! `Integrator "whitted" "integer maxdepth" [5]` — pbrt-v3's Whitted ray
//! tracer (`integrators/whitted.cpp`, `SamplerIntegrator::SpecularReflect`
//! and `SpecularTransmit`): emitted light at hits, one light sample and
//! shadow ray per light per hit, and recursion along perfectly specular
//! reflection and transmission up to `maxdepth`.

use crate::bxdf::{Bsdf, BsdfSample, BxDFType, TransportMode};
use crate::interaction::SurfaceInteraction;
use crate::sampler::Sampler;
use crate::world::World;
use farm_common::geometry::{RayDifferential, Vec2};
pub use farm_common::stats::RayStats;
use farm_common::Spectrum;

/// The Whitted integrator.
#[derive(Clone, Copy, Debug)]
pub struct Whitted {
    /// `maxdepth`: specular bounces stop when `depth + 1` reaches it.
    pub max_depth: u32,
    /// Pass over the sample pairs nothing reads (a delta light's, the
    /// specular lobes' of a surface without them) where the sampler can
    /// (Halton, Sobol'); off only to measure or test that it changes no bit.
    pub pass_over: bool,
}

impl Whitted {
    /// Whether to look for pairs to pass over with `sampler`.
    #[inline(always)]
    fn passes_over(&self, sampler: &Sampler) -> bool {
        self.pass_over && sampler.is_stateless()
    }

    /// Radiance arriving along `ray`.
    pub fn li(
        &self,
        ray: &RayDifferential,
        scene: &World,
        sampler: &mut Sampler,
        depth: u32,
        stats: &mut RayStats,
    ) -> Spectrum {
        let mut si = SurfaceInteraction::default();
        let Some(prim) = scene.intersect(&ray.ray, &mut si) else {
            // Escaped: radiance from infinite lights.
            let mut l = Spectrum::ZERO;
            for light in &scene.lights {
                l += light.le(&ray.ray);
            }
            return l;
        };

        // Surfaces without a material only bound media: continue through them.
        let Some(material) = prim.material.get().and_then(|m| scene.materials.get(m as usize))
        else {
            stats.secondary_rays += 1;
            let mut next = *ray;
            next.ray = si.spawn_ray(ray.ray.d);
            return self.li(&next, scene, sampler, depth, stats);
        };
        let wo = si.wo;
        si.compute_differentials(ray);
        let bsdf = material.compute_bsdf(
            &mut si,
            &scene.materials,
            &scene.textures,
            TransportMode::Radiance,
            false,
        );
        let n = si.shading.n;

        // Emitted light if the hit is on an area light.
        let mut l = Spectrum::ZERO;
        if let Some(id) = prim.area_light.get() {
            l += scene.emitted(id, si.n(), wo);
        }

        // One sample of each light, with a shadow ray.
        for light in &scene.lights {
            // pbrt-v3 draws the pair for every light; a delta light ignores
            // it, so it is passed over without being computed where the
            // sampler allows (as for the specular pairs below).
            let u = if light.reads_sample() || !self.passes_over(sampler) {
                sampler.get_2d()
            } else {
                sampler.skip_2d();
                Vec2::ZERO
            };
            let Some(ls) = light.sample_li(&si.it, u) else { continue };
            if ls.li.is_black() || ls.pdf == 0.0 {
                continue;
            }
            let f = bsdf.f(wo, ls.wi, BxDFType::ALL);
            if f.is_black() {
                continue;
            }
            stats.shadow_rays += 1;
            if !scene.intersect_p(&si.it.spawn_ray_to(&ls.p_light)) {
                l += f * ls.li * (ls.wi.dot(n).abs() / ls.pdf);
            }
        }

        if depth + 1 < self.max_depth {
            l += self.specular_reflect(ray, &si, &bsdf, scene, sampler, depth, stats);
            l += self.specular_transmit(ray, &si, &bsdf, scene, sampler, depth, stats);
        }
        l
    }

    #[allow(clippy::too_many_arguments)]
    fn specular_reflect(
        &self,
        ray: &RayDifferential,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        scene: &World,
        sampler: &mut Sampler,
        depth: u32,
        stats: &mut RayStats,
    ) -> Spectrum {
        let wo = si.wo;
        let Some(s) =
            sample_specular(si, bsdf, sampler, BxDFType::REFLECTION, self.passes_over(sampler))
        else {
            return Spectrum::ZERO;
        };
        let ns = si.shading.n;
        let wi = s.wi;
        let mut rd = RayDifferential::new(si.spawn_ray(wi));
        if ray.has_differentials {
            // Differentials of the mirrored direction.
            rd.has_differentials = true;
            rd.rx_o = si.p() + si.dpdx;
            rd.ry_o = si.p() + si.dpdy;
            let dndx = si.shading.dndu * si.dudx + si.shading.dndv * si.dvdx;
            let dndy = si.shading.dndu * si.dudy + si.shading.dndv * si.dvdy;
            let dwodx = -ray.rx_d - wo;
            let dwody = -ray.ry_d - wo;
            let ddndx = dwodx.dot(ns) + wo.dot(dndx);
            let ddndy = dwody.dot(ns) + wo.dot(dndy);
            rd.rx_d = wi - dwodx + 2.0 * (wo.dot(ns) * dndx + ddndx * ns);
            rd.ry_d = wi - dwody + 2.0 * (wo.dot(ns) * dndy + ddndy * ns);
        }
        stats.secondary_rays += 1;
        s.f * self.li(&rd, scene, sampler, depth + 1, stats) * (wi.dot(ns).abs() / s.pdf)
    }

    #[allow(clippy::too_many_arguments)]
    fn specular_transmit(
        &self,
        ray: &RayDifferential,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        scene: &World,
        sampler: &mut Sampler,
        depth: u32,
        stats: &mut RayStats,
    ) -> Spectrum {
        let wo = si.wo;
        let Some(s) =
            sample_specular(si, bsdf, sampler, BxDFType::TRANSMISSION, self.passes_over(sampler))
        else {
            return Spectrum::ZERO;
        };
        let mut ns = si.shading.n;
        let wi = s.wi;
        let mut rd = RayDifferential::new(si.spawn_ray(wi));
        if ray.has_differentials {
            // Differentials of the refracted direction (pbrt-v3's derivation
            // with the relative index of refraction).
            rd.has_differentials = true;
            rd.rx_o = si.p() + si.dpdx;
            rd.ry_o = si.p() + si.dpdy;
            let mut dndx = si.shading.dndu * si.dudx + si.shading.dndv * si.dvdx;
            let mut dndy = si.shading.dndu * si.dudy + si.shading.dndv * si.dvdy;
            let mut eta = 1.0 / bsdf.eta;
            if wo.dot(ns) < 0.0 {
                eta = 1.0 / eta;
                ns = -ns;
                dndx = -dndx;
                dndy = -dndy;
            }
            let dwodx = -ray.rx_d - wo;
            let dwody = -ray.ry_d - wo;
            let ddndx = dwodx.dot(ns) + wo.dot(dndx);
            let ddndy = dwody.dot(ns) + wo.dot(dndy);
            let mu = eta * wo.dot(ns) - wi.dot(ns).abs();
            let k = eta - (eta * eta * wo.dot(ns)) / wi.dot(ns).abs();
            rd.rx_d = wi - eta * dwodx + (mu * dndx + k * ddndx * ns);
            rd.ry_d = wi - eta * dwody + (mu * dndy + k * ddndy * ns);
        }
        stats.secondary_rays += 1;
        s.f * self.li(&rd, scene, sampler, depth + 1, stats) * (wi.dot(ns).abs() / s.pdf)
    }
}

/// Samples the specular lobes of one kind (reflection or transmission);
/// `None` when they send no light back along the sampled direction.
#[inline(always)]
fn sample_specular(
    si: &SurfaceInteraction,
    bsdf: &Bsdf,
    sampler: &mut Sampler,
    kind: BxDFType,
    pass_over: bool,
) -> Option<BsdfSample> {
    let flags = kind | BxDFType::SPECULAR;
    if pass_over && bsdf.num_components(flags) == 0 {
        // pbrt-v3 draws the pair and `Sample_f` ignores it: pass over it
        // without computing it where the sampler allows (Halton, Sobol').
        sampler.skip_2d();
        return None;
    }
    let u = sampler.get_2d();
    let s = bsdf.sample_f(si.wo, u, flags)?;
    let useful = s.pdf > 0.0 && !s.f.is_black() && s.wi.dot(si.shading.n) != 0.0;
    useful.then_some(s)
}
