//! Scattering functions (pbrt-v3 `core/reflection.h`): the `BxDF` lobes in a
//! local shading frame, Fresnel terms, microfacet distributions, and the
//! `Bsdf` that holds up to eight scaled lobes without allocating.

mod bsdf;
pub mod disney;
mod fourier;
mod fresnel;
mod fresnel_blend;
pub mod hair;
mod lambert;
mod microfacet;
mod microfacet_bxdf;
mod oren_nayar;
pub mod reflection;
mod specular;

pub use bsdf::{Bsdf, BsdfSample, MAX_BXDFS};
pub use disney::{DisneyClearcoat, DisneyDiffuse, DisneyFakeSS, DisneyRetro, DisneySheen};
pub use fourier::{FourierBsdf, FourierTable, TableError};
pub use fresnel::{fr_conductor, fr_dielectric, Fresnel};
pub use fresnel_blend::FresnelBlend;
pub use hair::HairBsdf;
pub use lambert::{LambertianReflection, LambertianTransmission};
pub use microfacet::{erf, erf_inv, roughness_to_alpha, DistributionKind, MicrofacetDistribution};
pub use microfacet_bxdf::{MicrofacetReflection, MicrofacetTransmission};
pub use oren_nayar::OrenNayar;
pub use specular::{FresnelSpecular, SpecularReflection, SpecularTransmission};

use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;
use std::ops::{BitAnd, BitOr};

/// Whether a path carries radiance (from the camera) or importance (from lights).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths.
    #[default]
    Radiance,
    /// Light paths.
    Importance,
}

/// Lobe classification flags (pbrt-v3 `BxDFType`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct BxDFType(pub u8);

impl BxDFType {
    /// No flags.
    pub const NONE: BxDFType = BxDFType(0);
    /// Scatters into the hemisphere of `wo`.
    pub const REFLECTION: BxDFType = BxDFType(1);
    /// Scatters through the surface.
    pub const TRANSMISSION: BxDFType = BxDFType(2);
    /// Diffuse.
    pub const DIFFUSE: BxDFType = BxDFType(4);
    /// Glossy.
    pub const GLOSSY: BxDFType = BxDFType(8);
    /// A delta distribution.
    pub const SPECULAR: BxDFType = BxDFType(16);
    /// Every lobe.
    pub const ALL: BxDFType = BxDFType(31);

    /// Whether every flag of `self` is in `flags` (pbrt-v3 `MatchesFlags`).
    #[inline]
    pub fn matches(self, flags: BxDFType) -> bool {
        self.0 & flags.0 == self.0
    }
    /// Whether any flag of `o` is set.
    #[inline]
    pub fn contains_any(self, o: BxDFType) -> bool {
        self.0 & o.0 != 0
    }
}

impl BitOr for BxDFType {
    type Output = BxDFType;
    #[inline]
    fn bitor(self, o: BxDFType) -> BxDFType {
        BxDFType(self.0 | o.0)
    }
}

impl BitAnd for BxDFType {
    type Output = BxDFType;
    #[inline]
    fn bitand(self, o: BxDFType) -> BxDFType {
        BxDFType(self.0 & o.0)
    }
}

/// A direction sampled from one lobe, in the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BxDFSample {
    /// The lobe's value for (wo, wi).
    pub f: Spectrum,
    /// The sampled incident direction.
    pub wi: Vec3,
    /// Its density (solid angle, or the discrete probability of a delta lobe).
    pub pdf: f32,
    /// The kind of scattering chosen.
    pub sampled_type: BxDFType,
}

/// One scattering lobe in the local shading frame (+z is the shading normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BxDF<'a> {
    /// Lambertian reflection.
    LambertianReflection(LambertianReflection),
    /// Lambertian transmission.
    LambertianTransmission(LambertianTransmission),
    /// Oren–Nayar rough diffuse reflection.
    OrenNayar(OrenNayar),
    /// Perfect specular reflection.
    SpecularReflection(SpecularReflection),
    /// Perfect specular transmission.
    SpecularTransmission(SpecularTransmission),
    /// Specular reflection and transmission chosen by Fresnel.
    FresnelSpecular(FresnelSpecular),
    /// Torrance–Sparrow reflection.
    MicrofacetReflection(MicrofacetReflection),
    /// Walter et al. microfacet transmission.
    MicrofacetTransmission(MicrofacetTransmission),
    /// Ashikhmin–Shirley diffuse/glossy blend.
    FresnelBlend(FresnelBlend),
    /// Disney diffuse.
    DisneyDiffuse(DisneyDiffuse),
    /// Disney fake subsurface (thin surfaces).
    DisneyFakeSS(DisneyFakeSS),
    /// Disney retro-reflection.
    DisneyRetro(DisneyRetro),
    /// Disney sheen.
    DisneySheen(DisneySheen),
    /// Disney clearcoat.
    DisneyClearcoat(DisneyClearcoat),
    /// A hair fibre.
    Hair(HairBsdf),
    /// A tabulated (layerlab) BSDF.
    Fourier(FourierBsdf<'a>),
}

// A BSDF holds eight of these by value; keep them small.
const _: () = assert!(std::mem::size_of::<BxDF<'static>>() <= 64);

impl Default for BxDF<'_> {
    fn default() -> Self {
        BxDF::LambertianReflection(LambertianReflection { r: Spectrum::ZERO })
    }
}

macro_rules! dispatch {
    ($self:ident, $b:ident => $e:expr) => {
        match $self {
            BxDF::LambertianReflection($b) => $e,
            BxDF::LambertianTransmission($b) => $e,
            BxDF::OrenNayar($b) => $e,
            BxDF::SpecularReflection($b) => $e,
            BxDF::SpecularTransmission($b) => $e,
            BxDF::FresnelSpecular($b) => $e,
            BxDF::MicrofacetReflection($b) => $e,
            BxDF::MicrofacetTransmission($b) => $e,
            BxDF::FresnelBlend($b) => $e,
            BxDF::DisneyDiffuse($b) => $e,
            BxDF::DisneyFakeSS($b) => $e,
            BxDF::DisneyRetro($b) => $e,
            BxDF::DisneySheen($b) => $e,
            BxDF::DisneyClearcoat($b) => $e,
            BxDF::Hair($b) => $e,
            BxDF::Fourier($b) => $e,
        }
    };
}

impl BxDF<'_> {
    /// The lobe's flags.
    #[inline]
    pub fn bxdf_type(&self) -> BxDFType {
        use BxDFType as T;
        match self {
            BxDF::LambertianReflection(_)
            | BxDF::OrenNayar(_)
            | BxDF::DisneyDiffuse(_)
            | BxDF::DisneyFakeSS(_)
            | BxDF::DisneyRetro(_)
            | BxDF::DisneySheen(_) => T::REFLECTION | T::DIFFUSE,
            BxDF::LambertianTransmission(_) => T::TRANSMISSION | T::DIFFUSE,
            BxDF::SpecularReflection(_) => T::REFLECTION | T::SPECULAR,
            BxDF::SpecularTransmission(_) => T::TRANSMISSION | T::SPECULAR,
            BxDF::FresnelSpecular(_) => T::REFLECTION | T::TRANSMISSION | T::SPECULAR,
            BxDF::MicrofacetReflection(_) | BxDF::FresnelBlend(_) | BxDF::DisneyClearcoat(_) => {
                T::REFLECTION | T::GLOSSY
            }
            BxDF::MicrofacetTransmission(_) => T::TRANSMISSION | T::GLOSSY,
            BxDF::Hair(_) | BxDF::Fourier(_) => T::REFLECTION | T::TRANSMISSION | T::GLOSSY,
        }
    }

    /// Whether the lobe's flags are all within `flags`.
    #[inline]
    pub fn matches_flags(&self, flags: BxDFType) -> bool {
        self.bxdf_type().matches(flags)
    }

    /// The lobe's value for the pair of directions (zero for delta lobes).
    ///
    /// The diffuse and specular lobes are inlined; the others are called.
    /// Inlined into a BSDF's loop over its lobes, every lobe's set-up from
    /// `wo` and `wi` (Schlick weights, sines, square roots) would be
    /// hoisted out of the loop and paid for a plain Lambertian surface too.
    #[inline]
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        match self {
            BxDF::LambertianReflection(b) => b.f(wo, wi),
            BxDF::LambertianTransmission(b) => b.f(wo, wi),
            BxDF::SpecularReflection(b) => b.f(wo, wi),
            BxDF::SpecularTransmission(b) => b.f(wo, wi),
            BxDF::FresnelSpecular(b) => b.f(wo, wi),
            _ => self.f_called(wo, wi),
        }
    }

    /// [`Self::f`] out of line.
    #[inline(never)]
    fn f_called(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        dispatch!(self, b => b.f(wo, wi))
    }

    /// Samples an incident direction for `wo`; `None` when the density is
    /// zero. Inlined for the diffuse and specular lobes only, as [`Self::f`].
    #[inline]
    pub fn sample_f(&self, wo: Vec3, u: Vec2) -> Option<BxDFSample> {
        let ty = self.bxdf_type();
        match self {
            BxDF::LambertianReflection(b) => b.sample_f(wo, u, ty),
            BxDF::LambertianTransmission(b) => b.sample_f(wo, u, ty),
            BxDF::SpecularReflection(b) => b.sample_f(wo, u, ty),
            BxDF::SpecularTransmission(b) => b.sample_f(wo, u, ty),
            BxDF::FresnelSpecular(b) => b.sample_f(wo, u, ty),
            _ => self.sample_f_called(wo, u, ty),
        }
    }

    /// [`Self::sample_f`] out of line.
    #[inline(never)]
    fn sample_f_called(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        dispatch!(self, b => b.sample_f(wo, u, ty))
    }

    /// Density of [`Self::sample_f`] choosing `wi`. Inlined for the diffuse
    /// and specular lobes only, as [`Self::f`].
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            BxDF::LambertianReflection(b) => b.pdf(wo, wi),
            BxDF::LambertianTransmission(b) => b.pdf(wo, wi),
            BxDF::SpecularReflection(b) => b.pdf(wo, wi),
            BxDF::SpecularTransmission(b) => b.pdf(wo, wi),
            BxDF::FresnelSpecular(b) => b.pdf(wo, wi),
            _ => self.pdf_called(wo, wi),
        }
    }

    /// [`Self::pdf`] out of line.
    #[inline(never)]
    fn pdf_called(&self, wo: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, b => b.pdf(wo, wi))
    }
}

/// pbrt-v3's default `BxDF::Sample_f`: cosine-weighted on `wo`'s side.
#[inline]
pub(crate) fn cosine_sample(wo: Vec3, u: Vec2) -> Vec3 {
    let mut wi = crate::sampling::cosine_sample_hemisphere(u);
    if wo.z < 0.0 {
        wi.z = -wi.z;
    }
    wi
}

/// pbrt-v3's default `BxDF::Pdf`.
#[inline]
pub(crate) fn cosine_pdf(wo: Vec3, wi: Vec3) -> f32 {
    if reflection::same_hemisphere(wo, wi) {
        reflection::abs_cos_theta(wi) * std::f32::consts::FRAC_1_PI
    } else {
        0.0
    }
}
