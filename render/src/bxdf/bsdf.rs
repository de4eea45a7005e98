//! The BSDF at a surface point (pbrt-v3 `BSDF`): up to [`MAX_BXDFS`] lobes,
//! each with a scale (what pbrt-v3's `ScaledBxDF` does for mix materials),
//! and the shading frame that takes world directions to the lobes' frame.

use super::reflection::ONE_MINUS_EPSILON;
use super::{BxDF, BxDFType};
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{Vec2, Vec3};
use farm_common::math;
use farm_common::Spectrum;
use std::mem::MaybeUninit;

/// Most lobes a BSDF holds (pbrt-v3 `MaxBxDFs`).
pub const MAX_BXDFS: usize = 8;

/// A direction sampled from a BSDF, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The BSDF's value for (wo, wi), summed over matching lobes unless specular.
    pub f: Spectrum,
    /// Incident direction (world space, unit).
    pub wi: Vec3,
    /// Density of choosing `wi`, averaged over matching lobes unless specular.
    pub pdf: f32,
    /// Flags of the lobe that was sampled.
    pub sampled_type: BxDFType,
}

/// Scattering at one point: shading frame plus scaled lobes.
#[derive(Clone, Copy)]
pub struct Bsdf<'a> {
    /// Relative index of refraction across the boundary (1 for opaque).
    pub eta: f32,
    /// Shading normal.
    pub ns: Vec3,
    /// Geometric normal.
    pub ng: Vec3,
    /// Shading tangent (normalised ∂p/∂u).
    pub ss: Vec3,
    /// Shading bitangent (ns × ss).
    pub ts: Vec3,
    n: usize,
    /// The first `n` are the lobes; the rest are never written, so that a
    /// BSDF made at every hit does not fill eight lobes (about 600 bytes)
    /// it rarely uses.
    bxdfs: [MaybeUninit<(BxDF<'a>, Spectrum)>; MAX_BXDFS],
}

impl std::fmt::Debug for Bsdf<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bsdf")
            .field("eta", &self.eta)
            .field("ns", &self.ns)
            .field("ng", &self.ng)
            .field("ss", &self.ss)
            .field("ts", &self.ts)
            .field("lobes", &self.lobes())
            .finish()
    }
}

impl PartialEq for Bsdf<'_> {
    fn eq(&self, o: &Self) -> bool {
        (self.eta, self.ns, self.ng, self.ss, self.ts) == (o.eta, o.ns, o.ng, o.ss, o.ts)
            && self.lobes() == o.lobes()
    }
}

impl<'a> Bsdf<'a> {
    /// An empty BSDF in `si`'s shading frame.
    pub fn new(si: &SurfaceInteraction, eta: f32) -> Self {
        let ns = si.shading.n;
        let ss = si.shading.dpdu.normalize();
        Bsdf {
            eta,
            ns,
            ng: si.it.n,
            ss,
            ts: ns.cross(ss),
            n: 0,
            bxdfs: [MaybeUninit::uninit(); MAX_BXDFS],
        }
    }

    /// Adds a lobe with unit scale. Lobes past [`MAX_BXDFS`] are dropped.
    #[inline]
    pub fn add(&mut self, b: BxDF<'a>) {
        self.add_scaled(b, Spectrum::ONE);
    }

    /// Adds a lobe multiplied by `scale`.
    #[inline]
    pub fn add_scaled(&mut self, b: BxDF<'a>, scale: Spectrum) {
        debug_assert!(self.n < MAX_BXDFS, "too many BxDFs");
        if self.n < MAX_BXDFS {
            self.bxdfs[self.n] = MaybeUninit::new((b, scale));
            self.n += 1;
        }
    }

    /// The lobes and their scales.
    #[inline]
    pub fn lobes(&self) -> &[(BxDF<'a>, Spectrum)] {
        let lobes = &self.bxdfs[..self.n];
        // SAFETY: the first `n` entries were written by `add_scaled`, and
        // `MaybeUninit<T>` has `T`'s layout.
        unsafe { std::slice::from_raw_parts(lobes.as_ptr().cast(), lobes.len()) }
    }

    /// Multiplies every lobe's scale by `s`.
    pub fn scale_all(&mut self, s: Spectrum) {
        let lobes = &mut self.bxdfs[..self.n];
        // SAFETY: as in `lobes`.
        let lobes: &mut [(BxDF<'a>, Spectrum)] =
            unsafe { std::slice::from_raw_parts_mut(lobes.as_mut_ptr().cast(), lobes.len()) };
        for l in lobes {
            l.1 *= s;
        }
    }

    /// Number of lobes matching `flags`.
    #[inline]
    pub fn num_components(&self, flags: BxDFType) -> usize {
        self.lobes().iter().filter(|(b, _)| b.matches_flags(flags)).count()
    }

    /// World direction to the shading frame.
    #[inline]
    pub fn world_to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.ss), v.dot(self.ts), v.dot(self.ns))
    }

    /// Shading-frame direction to world space.
    #[inline]
    pub fn local_to_world(&self, v: Vec3) -> Vec3 {
        self.ss * v.x + self.ts * v.y + self.ns * v.z
    }

    /// Sum of matching lobes, reflection or transmission ones according to
    /// the geometric normal. Always inlined, as [`Bsdf::f`] is: out of line,
    /// its four directions came through memory, and the first load of them
    /// waited on the caller's narrower stores (1.2% of
    /// spheres-differentials' samples on that one load).
    #[inline(always)]
    fn f_local(&self, wo_w: Vec3, wi_w: Vec3, wo: Vec3, wi: Vec3, flags: BxDFType) -> Spectrum {
        let reflect = wi_w.dot(self.ng) * wo_w.dot(self.ng) > 0.0;
        let mut f = Spectrum::ZERO;
        for (b, s) in self.lobes() {
            let t = b.bxdf_type();
            if b.matches_flags(flags)
                && ((reflect && t.contains_any(BxDFType::REFLECTION))
                    || (!reflect && t.contains_any(BxDFType::TRANSMISSION)))
            {
                f += b.f(wo, wi) * *s;
            }
        }
        f
    }

    /// The BSDF's value for a pair of world directions. Always inlined: out
    /// of line, its directions arrive through memory, stored as three
    /// floats and loaded wider, which stalls the load.
    #[inline(always)]
    pub fn f(&self, wo_world: Vec3, wi_world: Vec3, flags: BxDFType) -> Spectrum {
        let wi = self.world_to_local(wi_world);
        let wo = self.world_to_local(wo_world);
        if wo.z == 0.0 {
            return Spectrum::ZERO;
        }
        self.f_local(wo_world, wi_world, wo, wi, flags)
    }

    /// Chooses a matching lobe with `u.x`, samples it, and returns the
    /// combined value and density; `None` when nothing can be sampled.
    pub fn sample_f(&self, wo_world: Vec3, u: Vec2, flags: BxDFType) -> Option<BsdfSample> {
        let matching = self.num_components(flags);
        if matching == 0 {
            return None;
        }
        let comp = (math::floor(u.x * matching as f32) as usize).min(matching - 1);
        let chosen = self
            .lobes()
            .iter()
            .enumerate()
            .filter(|(_, (b, _))| b.matches_flags(flags))
            .nth(comp)
            .map(|(i, _)| i)?;
        let (bxdf, scale) = self.lobes()[chosen];
        let u_remapped =
            Vec2::new((u.x * matching as f32 - comp as f32).min(ONE_MINUS_EPSILON), u.y);
        let wo = self.world_to_local(wo_world);
        if wo.z == 0.0 {
            return None;
        }
        let s = bxdf.sample_f(wo, u_remapped)?;
        if s.pdf == 0.0 {
            return None;
        }
        let wi = s.wi;
        let wi_world = self.local_to_world(wi);
        let specular = bxdf.bxdf_type().contains_any(BxDFType::SPECULAR);
        let mut pdf = s.pdf;
        if !specular && matching > 1 {
            for (i, (b, _)) in self.lobes().iter().enumerate() {
                if i != chosen && b.matches_flags(flags) {
                    pdf += b.pdf(wo, wi);
                }
            }
        }
        if matching > 1 {
            pdf /= matching as f32;
        }
        let f =
            if specular { s.f * scale } else { self.f_local(wo_world, wi_world, wo, wi, flags) };
        Some(BsdfSample { f, wi: wi_world, pdf, sampled_type: s.sampled_type })
    }

    /// Density of [`Self::sample_f`] choosing `wi_world`.
    pub fn pdf(&self, wo_world: Vec3, wi_world: Vec3, flags: BxDFType) -> f32 {
        if self.n == 0 {
            return 0.0;
        }
        let wo = self.world_to_local(wo_world);
        let wi = self.world_to_local(wi_world);
        if wo.z == 0.0 {
            return 0.0;
        }
        let mut pdf = 0.0;
        let mut matching = 0;
        for (b, _) in self.lobes() {
            if b.matches_flags(flags) {
                matching += 1;
                pdf += b.pdf(wo, wi);
            }
        }
        if matching > 0 {
            pdf / matching as f32
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::*;
    use super::*;
    use farm_common::rng::Rng;

    fn frame() -> SurfaceInteraction {
        SurfaceInteraction::new(
            Vec3::ZERO,
            Vec3::ZERO,
            Vec2::ZERO,
            Vec3::Z,
            Vec3::X,
            Vec3::Y,
            Vec3::ZERO,
            Vec3::ZERO,
            0.0,
            false,
        )
    }

    fn lobes() -> Vec<BxDF<'static>> {
        let tr = MicrofacetDistribution::trowbridge_reitz(0.3, 0.3);
        let tra = MicrofacetDistribution::trowbridge_reitz(0.15, 0.4);
        let bk = MicrofacetDistribution::beckmann(0.35, 0.35);
        let white = Spectrum::ONE;
        vec![
            BxDF::LambertianReflection(LambertianReflection { r: white }),
            BxDF::OrenNayar(OrenNayar::new(white, 20.0)),
            BxDF::MicrofacetReflection(MicrofacetReflection {
                r: white,
                distribution: tr,
                fresnel: Fresnel::NoOp,
            }),
            BxDF::MicrofacetReflection(MicrofacetReflection {
                r: white,
                distribution: tra,
                fresnel: Fresnel::Dielectric { eta_i: 1.0, eta_t: 1.5 },
            }),
            BxDF::MicrofacetReflection(MicrofacetReflection {
                r: white,
                distribution: bk,
                fresnel: Fresnel::NoOp,
            }),
            BxDF::FresnelBlend(FresnelBlend {
                rd: Spectrum::splat(0.5),
                rs: Spectrum::splat(0.5),
                distribution: tr,
            }),
        ]
    }

    fn dir(rng: &mut Rng) -> Vec3 {
        let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
        crate::sampling::cosine_sample_hemisphere(u)
    }

    #[test]
    fn sampled_pdf_matches_pdf_and_albedo_is_at_most_one() {
        let mut rng = Rng::new(11);
        for b in lobes() {
            let mut bsdf = Bsdf::new(&frame(), 1.0);
            bsdf.add(b);
            for _ in 0..4 {
                let wo = dir(&mut rng);
                let n = 20_000;
                let mut albedo = 0.0f64;
                for _ in 0..n {
                    let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
                    let Some(s) = bsdf.sample_f(wo, u, BxDFType::ALL) else {
                        continue;
                    };
                    let p = bsdf.pdf(wo, s.wi, BxDFType::ALL);
                    assert!((p - s.pdf).abs() <= 1e-3 * p.max(1.0), "{b:?} {p} {}", s.pdf);
                    let f = bsdf.f(wo, s.wi, BxDFType::ALL);
                    assert!((f.g - s.f.g).abs() <= 1e-3 * f.g.max(1.0), "{b:?}");
                    albedo += (s.f.g * s.wi.dot(Vec3::Z).abs() / s.pdf) as f64;
                }
                let albedo = albedo / n as f64;
                assert!(albedo <= 1.02, "{b:?} wo={wo} albedo {albedo}");
                assert!(albedo > 0.01, "{b:?} wo={wo} albedo {albedo}");
            }
        }
    }

    #[test]
    fn reflection_lobes_are_reciprocal() {
        let mut rng = Rng::new(5);
        for b in lobes() {
            for _ in 0..200 {
                let (wo, wi) = (dir(&mut rng), dir(&mut rng));
                let (a, c) = (b.f(wo, wi), b.f(wi, wo));
                assert!((a.g - c.g).abs() <= 1e-4 * a.g.max(1.0), "{b:?} {a:?} {c:?}");
            }
        }
    }

    #[test]
    fn mixed_lobes_average_pdfs_and_respect_the_geometric_normal() {
        let mut bsdf = Bsdf::new(&frame(), 1.0);
        bsdf.add(BxDF::LambertianReflection(LambertianReflection { r: Spectrum::ONE }));
        bsdf.add(BxDF::LambertianTransmission(LambertianTransmission { t: Spectrum::ONE }));
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let up = Vec3::new(0.6, 0.0, 0.8);
        let down = Vec3::new(0.6, 0.0, -0.8);
        let inv_pi = std::f32::consts::FRAC_1_PI;
        assert!((bsdf.f(wo, up, BxDFType::ALL).r - inv_pi).abs() < 1e-6);
        assert!((bsdf.f(wo, down, BxDFType::ALL).r - inv_pi).abs() < 1e-6);
        assert!((bsdf.pdf(wo, up, BxDFType::ALL) - 0.4 * inv_pi).abs() < 1e-6);
        assert_eq!(bsdf.num_components(BxDFType::REFLECTION | BxDFType::DIFFUSE), 1);
        assert!(bsdf.f(wo, up, BxDFType::TRANSMISSION | BxDFType::DIFFUSE).is_black());
        let mut scaled = bsdf;
        scaled.scale_all(Spectrum::splat(0.5));
        assert!((scaled.f(wo, up, BxDFType::ALL).r - 0.5 * inv_pi).abs() < 1e-6);
    }
}
