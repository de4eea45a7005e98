//! Microfacet distributions (pbrt-v3 `core/microfacet.cpp`): Trowbridge–Reitz
//! (GGX) and Beckmann, sampling the distribution of visible normals by
//! default as pbrt-v3's materials do.

use super::reflection::{
    abs_cos_theta, cos2_phi, cos2_theta, cos_phi, cos_theta, same_hemisphere, sin2_phi, sin_phi,
    tan2_theta, tan_theta,
};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::math;
use std::f32::consts::PI;

/// Which microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DistributionKind {
    /// Trowbridge–Reitz (GGX).
    TrowbridgeReitz,
    /// Beckmann–Spizzichino.
    Beckmann,
}

/// A microfacet distribution with its roughness along x and y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetDistribution {
    /// The distribution family.
    pub kind: DistributionKind,
    /// α along the tangent.
    pub alpha_x: f32,
    /// α along the bitangent.
    pub alpha_y: f32,
    /// Sample only normals visible from `wo` (pbrt-v3's default).
    pub sample_visible_area: bool,
    /// Masking and shadowing as the product G1(ωo) G1(ωi) (pbrt-v3's
    /// `DisneyMicrofacetDistribution`) rather than height-correlated.
    pub separable_g: bool,
}

/// pbrt-v3's perceptual roughness → α mapping (shared by both distributions).
pub fn roughness_to_alpha(roughness: f32) -> f32 {
    let x = math::ln(roughness.max(1e-3));
    1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x + 0.000640711 * x * x * x * x
}

/// The smallest α a distribution keeps. pbrt-v3 takes α = 0 (roughness 0
/// with `remaproughness false`) as given, and D(ωh) becomes 0·∞ = NaN; like
/// pbrt-v4 we clamp it, which leaves a highlight of negligible size.
const MIN_ALPHA: f32 = 1e-4;

impl MicrofacetDistribution {
    /// A Trowbridge–Reitz distribution sampling visible normals.
    pub fn trowbridge_reitz(alpha_x: f32, alpha_y: f32) -> Self {
        MicrofacetDistribution {
            kind: DistributionKind::TrowbridgeReitz,
            alpha_x: alpha_x.max(MIN_ALPHA),
            alpha_y: alpha_y.max(MIN_ALPHA),
            sample_visible_area: true,
            separable_g: false,
        }
    }

    /// A Beckmann distribution sampling visible normals.
    pub fn beckmann(alpha_x: f32, alpha_y: f32) -> Self {
        MicrofacetDistribution {
            kind: DistributionKind::Beckmann,
            alpha_x: alpha_x.max(MIN_ALPHA),
            alpha_y: alpha_y.max(MIN_ALPHA),
            sample_visible_area: true,
            separable_g: false,
        }
    }

    /// Differential area of microfacets with normal `wh`.
    pub fn d(&self, wh: Vec3) -> f32 {
        let tan2 = tan2_theta(wh);
        if tan2.is_infinite() {
            return 0.0;
        }
        let cos4 = cos2_theta(wh) * cos2_theta(wh);
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        match self.kind {
            DistributionKind::Beckmann => {
                math::exp(-tan2 * (cos2_phi(wh) / (ax * ax) + sin2_phi(wh) / (ay * ay)))
                    / (PI * ax * ay * cos4)
            }
            DistributionKind::TrowbridgeReitz => {
                let e = (cos2_phi(wh) / (ax * ax) + sin2_phi(wh) / (ay * ay)) * tan2;
                1.0 / (PI * ax * ay * cos4 * (1.0 + e) * (1.0 + e))
            }
        }
    }

    /// Smith's auxiliary Λ(w).
    pub fn lambda(&self, w: Vec3) -> f32 {
        let abs_tan = tan_theta(w).abs();
        if abs_tan.is_infinite() {
            return 0.0;
        }
        let alpha = (cos2_phi(w) * self.alpha_x * self.alpha_x
            + sin2_phi(w) * self.alpha_y * self.alpha_y)
            .sqrt();
        match self.kind {
            DistributionKind::Beckmann => {
                let a = 1.0 / (alpha * abs_tan);
                if a >= 1.6 {
                    return 0.0;
                }
                (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
            }
            DistributionKind::TrowbridgeReitz => {
                let a2t2 = (alpha * abs_tan) * (alpha * abs_tan);
                (-1.0 + (1.0 + a2t2).sqrt()) / 2.0
            }
        }
    }

    /// Masking G1(w).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking–shadowing G(wo, wi).
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.separable_g {
            return self.g1(wo) * self.g1(wi);
        }
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Samples a microfacet normal on `wo`'s side.
    pub fn sample_wh(&self, wo: Vec3, u: Vec2) -> Vec3 {
        if self.sample_visible_area {
            let flip = wo.z < 0.0;
            let w = if flip { -wo } else { wo };
            let wh = match self.kind {
                DistributionKind::TrowbridgeReitz => {
                    visible_sample(w, self.alpha_x, self.alpha_y, u, trowbridge_reitz_sample11)
                }
                DistributionKind::Beckmann => {
                    visible_sample(w, self.alpha_x, self.alpha_y, u, beckmann_sample11)
                }
            };
            return if flip { -wh } else { wh };
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let (tan2, phi) = if ax == ay {
            let t = match self.kind {
                DistributionKind::TrowbridgeReitz => ax * ax * u.x / (1.0 - u.x),
                DistributionKind::Beckmann => -ax * ax * math::ln(1.0 - u.x),
            };
            (t, u.y * 2.0 * PI)
        } else {
            let mut phi = math::atan(ay / ax * math::tan(2.0 * PI * u.y + 0.5 * PI));
            if u.y > 0.5 {
                phi += PI;
            }
            let (sp, cp) = math::sin_cos(phi);
            let inv = cp * cp / (ax * ax) + sp * sp / (ay * ay);
            let t = match self.kind {
                DistributionKind::TrowbridgeReitz => (1.0 / inv) * u.x / (1.0 - u.x),
                DistributionKind::Beckmann => -math::ln(1.0 - u.x) / inv,
            };
            (t, phi)
        };
        let cos_t = 1.0 / (1.0 + tan2).sqrt();
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let wh = Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t);
        if same_hemisphere(wo, wh) {
            wh
        } else {
            -wh
        }
    }

    /// Density of [`Self::sample_wh`] with respect to solid angle of `wh`.
    pub fn pdf(&self, wo: Vec3, wh: Vec3) -> f32 {
        if self.sample_visible_area {
            self.d(wh) * self.g1(wo) * wo.dot(wh).abs() / abs_cos_theta(wo)
        } else {
            self.d(wh) * abs_cos_theta(wh)
        }
    }
}

/// Heitz's visible-normal sampling: stretch, sample the unit-roughness
/// slopes, rotate, unstretch.
fn visible_sample(
    wi: Vec3,
    ax: f32,
    ay: f32,
    u: Vec2,
    sample11: fn(f32, f32, f32) -> (f32, f32),
) -> Vec3 {
    let ws = Vec3::new(ax * wi.x, ay * wi.y, wi.z).normalize();
    let (sx, sy) = sample11(cos_theta(ws), u.x, u.y);
    let (cp, sp) = (cos_phi(ws), sin_phi(ws));
    let tmp = cp * sx - sp * sy;
    let sy = sp * sx + cp * sy;
    let sx = tmp;
    Vec3::new(-ax * sx, -ay * sy, 1.0).normalize()
}

fn trowbridge_reitz_sample11(cos_theta: f32, u1: f32, u2: f32) -> (f32, f32) {
    if cos_theta > 0.9999 {
        let r = (u1 / (1.0 - u1)).sqrt();
        let (sin_phi, cos_phi) = math::sin_cos(std::f32::consts::TAU * u2);
        return (r * cos_phi, r * sin_phi);
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let tan_theta = sin_theta / cos_theta;
    let a = 1.0 / tan_theta;
    let g1 = 2.0 / (1.0 + (1.0 + 1.0 / (a * a)).sqrt());
    // Slope x.
    let aa = 2.0 * u1 / g1 - 1.0;
    let tmp = (1.0 / (aa * aa - 1.0)).min(1e10);
    let b = tan_theta;
    let d = (b * b * tmp * tmp - (aa * aa - b * b) * tmp).max(0.0).sqrt();
    let sx1 = b * tmp - d;
    let sx2 = b * tmp + d;
    let slope_x = if aa < 0.0 || sx2 > 1.0 / tan_theta { sx1 } else { sx2 };
    // Slope y.
    let (s, u2) = if u2 > 0.5 { (1.0, 2.0 * (u2 - 0.5)) } else { (-1.0, 2.0 * (0.5 - u2)) };
    let z = (u2 * (u2 * (u2 * 0.27385 - 0.73369) + 0.46341))
        / (u2 * (u2 * (u2 * 0.093073 + 0.309420) - 1.000000) + 0.597999);
    (slope_x, s * z * (1.0 + slope_x * slope_x).sqrt())
}

fn beckmann_sample11(cos_theta_i: f32, u1: f32, u2: f32) -> (f32, f32) {
    if cos_theta_i > 0.9999 {
        let r = (-math::ln(1.0 - u1)).sqrt();
        let (s, c) = math::sin_cos(2.0 * PI * u2);
        return (r * c, r * s);
    }
    let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
    let tan_theta_i = sin_theta_i / cos_theta_i;
    let cot_theta_i = 1.0 / tan_theta_i;
    // Newton–bisection search for the inverse CDF, in the erf domain.
    let mut a = -1.0f32;
    let mut c = erf(cot_theta_i);
    let sample_x = u1.max(1e-6);
    let theta_i = math::acos(cos_theta_i);
    let fit = 1.0 + theta_i * (-0.876 + theta_i * (0.4265 - 0.0594 * theta_i));
    let mut b = c - (1.0 + c) * math::powf(1.0 - sample_x, fit);
    let sqrt_pi_inv = 1.0 / PI.sqrt();
    let normalization =
        1.0 / (1.0 + c + sqrt_pi_inv * tan_theta_i * math::exp(-cot_theta_i * cot_theta_i));
    let mut it = 0;
    loop {
        it += 1;
        if it >= 10 {
            break;
        }
        if !(b >= a && b <= c) {
            b = 0.5 * (a + c);
        }
        let inv_erf = erf_inv(b);
        let value = normalization
            * (1.0 + b + sqrt_pi_inv * tan_theta_i * math::exp(-inv_erf * inv_erf))
            - sample_x;
        let derivative = normalization * (1.0 - inv_erf * tan_theta_i);
        if value.abs() < 1e-5 {
            break;
        }
        if value > 0.0 {
            c = b;
        } else {
            a = b;
        }
        b -= value / derivative;
    }
    (erf_inv(b), erf_inv(2.0 * u2.max(1e-6) - 1.0))
}

/// pbrt-v3's polynomial approximation of erf⁻¹.
pub fn erf_inv(x: f32) -> f32 {
    let x = x.clamp(-0.99999, 0.99999);
    let mut w = -math::ln((1.0 - x) * (1.0 + x));
    let mut p;
    if w < 5.0 {
        w -= 2.5;
        p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_681_6 + p * w;
        p = 0.246_640_73 + p * w;
        p = 1.501_409_4 + p * w;
    } else {
        w = w.sqrt() - 3.0;
        p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461_3 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        p = 2.832_976_8 + p * w;
    }
    p * x
}

/// pbrt-v3's approximation of erf (Abramowitz & Stegun 7.1.26).
pub fn erf(x: f32) -> f32 {
    let (a1, a2, a3, a4, a5, p) =
        (0.254_829_6, -0.284_496_74, 1.421_413_8, -1.453_152_1, 1.061_405_4, 0.327_591_1);
    let sign = if x < 0.0 { -1.0 } else { 1.0 };
    let x = x.abs();
    let t = 1.0 / (1.0 + p * x);
    let y = 1.0 - (((((a5 * t + a4) * t) + a3) * t + a2) * t + a1) * t * math::exp(-x * x);
    sign * y
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    fn spherical(u: Vec2) -> Vec3 {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        Vec3::new(r * math::cos(phi), r * math::sin(phi), z)
    }

    #[test]
    fn projected_area_is_one() {
        // ∫ D(wh) cos θh dωh = 1 for both families, isotropic and not.
        let mut rng = Rng::new(7);
        for d in [
            MicrofacetDistribution::trowbridge_reitz(0.3, 0.3),
            MicrofacetDistribution::trowbridge_reitz(0.2, 0.5),
            MicrofacetDistribution::beckmann(0.4, 0.4),
            MicrofacetDistribution::beckmann(0.3, 0.6),
        ] {
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
                let wh = spherical(u);
                if wh.z > 0.0 {
                    sum += (d.d(wh) * wh.z) as f64;
                }
            }
            let est = sum * 4.0 * std::f64::consts::PI / n as f64;
            assert!((est - 1.0).abs() < 0.05, "{d:?}: {est}");
        }
    }

    #[test]
    fn sampled_normals_face_wo() {
        let mut rng = Rng::new(3);
        let d = MicrofacetDistribution::beckmann(0.5, 0.5);
        let wo = Vec3::new(0.5, 0.1, -0.8).normalize();
        for _ in 0..1000 {
            let wh = d.sample_wh(wo, Vec2::new(rng.uniform_f32(), rng.uniform_f32()));
            assert!(wh.is_finite() && wh.z < 0.0, "{wh}");
        }
        assert!((erf(erf_inv(0.3)) - 0.3).abs() < 1e-3);
        assert!((roughness_to_alpha(0.1) - 0.461_76).abs() < 1e-4);
    }
}
