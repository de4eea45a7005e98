//! pbrt-v3's hair scattering model (`materials/hair.cpp`, after
//! d'Eon et al. 2011 and Chiang et al. 2016): longitudinal lobes Mp,
//! attenuations Ap and azimuthal logistic lobes Np for the first three
//! paths through the fibre, and their residual. Directions are in the BSDF
//! frame, with x along the hair.

use super::reflection::abs_cos_theta;
use super::{fr_dielectric, BxDFSample, BxDFType};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::math;
use farm_common::Spectrum;
use std::f32::consts::PI;

/// Paths followed explicitly (R, TT, TRT); the rest is lumped together.
const P_MAX: usize = 3;
const SQRT_PI_OVER_8: f32 = 0.626_657_07;
/// ln 2 as pbrt-v3 writes it in `Mp` (four digits), kept for its values.
#[allow(clippy::approx_constant)]
const PBRT_LN_2: f32 = 0.6931;

/// pbrt-v3's `Pow<n>`, by its repeated squaring.
fn pow_n(v: f32, n: u32) -> f32 {
    match n {
        0 => 1.0,
        1 => v,
        _ => {
            let h = pow_n(v, n / 2);
            h * h * pow_n(v, n & 1)
        }
    }
}

fn sqr(x: f32) -> f32 {
    x * x
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

fn safe_asin(x: f32) -> f32 {
    math::asin(x.clamp(-1.0, 1.0))
}

/// The modified Bessel function I0, by pbrt-v3's ten-term series.
fn i0(x: f32) -> f32 {
    let (mut val, mut x2i, mut ifact, mut i4) = (0.0f32, 1.0f32, 1i64, 1i64);
    for i in 0..10 {
        if i > 1 {
            ifact *= i;
        }
        val += x2i / (i4 as f32 * sqr(ifact as f32));
        x2i *= x * x;
        i4 *= 4;
    }
    val
}

fn log_i0(x: f32) -> f32 {
    if x > 12.0 {
        x + 0.5 * (-math::ln(2.0 * PI) + math::ln(1.0 / x) + 1.0 / (8.0 * x))
    } else {
        math::ln(i0(x))
    }
}

/// The longitudinal scattering function.
fn mp(cos_i: f32, cos_o: f32, sin_i: f32, sin_o: f32, v: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let b = sin_i * sin_o / v;
    if v <= 0.1 {
        math::exp(log_i0(a) - b - 1.0 / v + PBRT_LN_2 + math::ln(1.0 / (2.0 * v)))
    } else {
        (math::exp(-b) * i0(a)) / (math::sinh(1.0 / v) * 2.0 * v)
    }
}

fn ap(cos_o: f32, eta: f32, h: f32, t: Spectrum) -> [Spectrum; P_MAX + 1] {
    let cos_gamma_o = safe_sqrt(1.0 - h * h);
    let cos_theta = cos_o * cos_gamma_o;
    let f = fr_dielectric(cos_theta, 1.0, eta);
    let mut a = [Spectrum::ZERO; P_MAX + 1];
    a[0] = Spectrum::splat(f);
    a[1] = t * sqr(1.0 - f);
    for p in 2..P_MAX {
        a[p] = a[p - 1] * t * f;
    }
    a[P_MAX] = a[P_MAX - 1] * f * t / (Spectrum::ONE - t * f);
    a
}

fn phi(p: usize, gamma_o: f32, gamma_t: f32) -> f32 {
    2.0 * p as f32 * gamma_t - 2.0 * gamma_o + p as f32 * PI
}

fn logistic(x: f32, s: f32) -> f32 {
    let x = x.abs();
    math::exp(-x / s) / (s * sqr(1.0 + math::exp(-x / s)))
}

fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + math::exp(-x / s))
}

fn trimmed_logistic(x: f32, s: f32, a: f32, b: f32) -> f32 {
    logistic(x, s) / (logistic_cdf(b, s) - logistic_cdf(a, s))
}

/// The azimuthal scattering function.
fn np(phi_: f32, p: usize, s: f32, gamma_o: f32, gamma_t: f32) -> f32 {
    let mut dphi = phi_ - phi(p, gamma_o, gamma_t);
    while dphi > PI {
        dphi -= 2.0 * PI;
    }
    while dphi < -PI {
        dphi += 2.0 * PI;
    }
    trimmed_logistic(dphi, s, -PI, PI)
}

/// One hair fibre's scattering at offset `h` across it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairBsdf {
    h: f32,
    gamma_o: f32,
    eta: f32,
    sigma_a: Spectrum,
    /// The R lobe's longitudinal variance; TT's is a quarter, TRT's and
    /// the rest's four times it.
    v0: f32,
    s: f32,
    sin_2k_alpha: [f32; 3],
    cos_2k_alpha: [f32; 3],
}

impl HairBsdf {
    /// pbrt-v3's `HairBSDF(h, eta, sigma_a, beta_m, beta_n, alpha)`.
    pub fn new(h: f32, eta: f32, sigma_a: Spectrum, beta_m: f32, beta_n: f32, alpha: f32) -> Self {
        let v0 = sqr(0.726 * beta_m + 0.812 * sqr(beta_m) + 3.7 * pow_n(beta_m, 20));
        let s = SQRT_PI_OVER_8 * (0.265 * beta_n + 1.194 * sqr(beta_n) + 5.372 * pow_n(beta_n, 22));
        let mut sin_2k_alpha = [0.0; 3];
        let mut cos_2k_alpha = [0.0; 3];
        sin_2k_alpha[0] = math::sin(alpha.to_radians());
        cos_2k_alpha[0] = safe_sqrt(1.0 - sqr(sin_2k_alpha[0]));
        for i in 1..3 {
            sin_2k_alpha[i] = 2.0 * cos_2k_alpha[i - 1] * sin_2k_alpha[i - 1];
            cos_2k_alpha[i] = sqr(cos_2k_alpha[i - 1]) - sqr(sin_2k_alpha[i - 1]);
        }
        HairBsdf { h, gamma_o: safe_asin(h), eta, sigma_a, v0, s, sin_2k_alpha, cos_2k_alpha }
    }

    /// pbrt-v3 `HairBSDF::f`.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let sin_o = wo.x;
        let cos_o = safe_sqrt(1.0 - sqr(sin_o));
        let phi_o = math::atan2(wo.z, wo.y);
        let sin_i = wi.x;
        let cos_i = safe_sqrt(1.0 - sqr(sin_i));
        let phi_i = math::atan2(wi.z, wi.y);
        let sin_t = sin_o / self.eta;
        let cos_t = safe_sqrt(1.0 - sqr(sin_t));
        let etap = (self.eta * self.eta - sqr(sin_o)).sqrt() / cos_o;
        let sin_gamma_t = self.h / etap;
        let cos_gamma_t = safe_sqrt(1.0 - sqr(sin_gamma_t));
        let gamma_t = safe_asin(sin_gamma_t);
        let t = (self.sigma_a * -(2.0 * cos_gamma_t / cos_t)).exp();
        let v = [self.v0, 0.25 * self.v0, 4.0 * self.v0, 4.0 * self.v0];
        let dphi = phi_i - phi_o;
        let a = ap(cos_o, self.eta, self.h, t);
        let (s2, c2) = (self.sin_2k_alpha, self.cos_2k_alpha);
        let mut sum = Spectrum::ZERO;
        for p in 0..P_MAX {
            let (sin_op, cos_op) = match p {
                0 => (sin_o * c2[1] - cos_o * s2[1], cos_o * c2[1] + sin_o * s2[1]),
                1 => (sin_o * c2[0] + cos_o * s2[0], cos_o * c2[0] - sin_o * s2[0]),
                2 => (sin_o * c2[2] + cos_o * s2[2], cos_o * c2[2] - sin_o * s2[2]),
                _ => (sin_o, cos_o),
            };
            sum += a[p]
                * (mp(cos_i, cos_op.abs(), sin_i, sin_op, v[p])
                    * np(dphi, p, self.s, self.gamma_o, gamma_t));
        }
        sum += a[P_MAX] * (mp(cos_i, cos_o, sin_i, sin_o, v[P_MAX]) / (2.0 * PI));
        if abs_cos_theta(wi) > 0.0 {
            sum = sum / abs_cos_theta(wi);
        }
        sum
    }

    /// Uniform sampling of the sphere. pbrt-v3 importance-samples the
    /// lobes; its Whitted integrator never samples a glossy lobe, so this
    /// only has to be correct.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let wi = crate::sampling::uniform_sample_sphere(u);
        Some(BxDFSample { f: self.f(wo, wi), wi, pdf: self.pdf(wo, wi), sampled_type: ty })
    }

    /// The uniform sphere's density.
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        1.0 / (4.0 * PI)
    }

    /// pbrt-v3 `SigmaAFromConcentration`: absorption from eumelanin and
    /// pheomelanin concentrations.
    pub fn sigma_a_from_concentration(ce: f32, cp: f32) -> Spectrum {
        let eu = [0.419f32, 0.697, 1.37];
        let ph = [0.187f32, 0.4, 1.05];
        Spectrum::new(ce * eu[0] + cp * ph[0], ce * eu[1] + cp * ph[1], ce * eu[2] + cp * ph[2])
    }

    /// pbrt-v3 `SigmaAFromReflectance`: the absorption that gives a
    /// fibre's multiply scattered colour `c`.
    pub fn sigma_a_from_reflectance(c: Spectrum, beta_n: f32) -> Spectrum {
        let d = 5.969 - 0.215 * beta_n + 2.532 * sqr(beta_n) - 10.73 * pow_n(beta_n, 3)
            + 5.574 * pow_n(beta_n, 4)
            + 0.245 * pow_n(beta_n, 5);
        let f = |x: f32| sqr(math::ln(x) / d);
        Spectrum::new(f(c.r), f(c.g), f(c.b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    /// pbrt-v3's own hair tests: with no absorption the fibre scatters all
    /// it receives (white furnace, ∫ f |cos θi| dωi ≈ 1 for β = 0.3 and up),
    /// and Mp integrates to one over the sphere.
    #[test]
    fn hair_scatters_all_it_receives_without_absorption() {
        let mut rng = Rng::new(11);
        let wo = Vec3::new(0.2, 0.6, 0.77).normalize();
        for beta in [0.3f32, 0.5, 0.9] {
            for h in [-0.8f32, 0.0, 0.5] {
                let hair = HairBsdf::new(h, 1.55, Spectrum::ZERO, beta, beta, 0.0);
                let n = 100_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
                    let wi = crate::sampling::uniform_sample_sphere(u);
                    sum += (hair.f(wo, wi).y() * abs_cos_theta(wi)) as f64 * 4.0 * PI as f64;
                }
                let avg = sum / n as f64;
                assert!((avg - 1.0).abs() < 0.05, "β {beta}, h {h}: ∫f cos = {avg}");
            }
        }
        for v in [0.1f32, 0.25, 0.5] {
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                // Mp over θi for a fixed θo, as a density in sin θi.
                let si = 2.0 * rng.uniform_f32() - 1.0;
                let ci = safe_sqrt(1.0 - si * si);
                sum += mp(ci, 0.8, si, 0.6, v) as f64 * 2.0;
            }
            let avg = sum / n as f64;
            assert!((avg - 1.0).abs() < 0.05, "v {v}: ∫Mp = {avg}");
        }
    }
}
