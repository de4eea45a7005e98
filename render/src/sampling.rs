//! Warping uniform samples to distributions (pbrt-v3 `core/sampling.h`).

use farm_common::geometry::{Vec2, Vec3};
use farm_common::math;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// A point on the unit disk by Shirley–Chiu's concentric mapping.
#[inline]
pub fn concentric_sample_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    let (sin, cos) = math::sin_cos(theta);
    r * Vec2::new(cos, sin)
}

/// A direction in the +z hemisphere with density cos θ / π.
#[inline]
pub fn cosine_sample_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_sample_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_sample_hemisphere`].
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta * std::f32::consts::FRAC_1_PI
}

/// A uniformly distributed direction in the +z hemisphere.
#[inline]
pub fn uniform_sample_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = math::sin_cos(2.0 * PI * u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// Density of [`uniform_sample_hemisphere`].
#[inline]
pub fn uniform_hemisphere_pdf() -> f32 {
    0.5 * std::f32::consts::FRAC_1_PI
}

/// A uniformly distributed direction on the unit sphere.
#[inline]
pub fn uniform_sample_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = math::sin_cos(2.0 * PI * u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// Density of [`uniform_sample_sphere`].
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    0.25 * std::f32::consts::FRAC_1_PI
}

/// A uniformly distributed direction in the cone around +z with the given
/// cosine of its half-angle.
#[inline]
pub fn uniform_sample_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_theta_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (sin_phi, cos_phi) = math::sin_cos(u.y * 2.0 * PI);
    Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta)
}

/// Density of [`uniform_sample_cone`].
#[inline]
pub fn uniform_cone_pdf(cos_theta_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_theta_max))
}

/// Uniform barycentric coordinates (b0, b1) on a triangle.
#[inline]
pub fn uniform_sample_triangle(u: Vec2) -> Vec2 {
    let su0 = u.x.sqrt();
    Vec2::new(1.0 - su0, u.y * su0)
}

/// Veach's power heuristic with β = 2.
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let (f, g) = (nf * f_pdf, ng * g_pdf);
    f * f / (f * f + g * g)
}

/// A piecewise-constant 1D distribution (pbrt-v3 `Distribution1D`).
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// The function values.
    pub func: Vec<f32>,
    /// Its CDF, `func.len() + 1` entries from 0 to 1.
    pub cdf: Vec<f32>,
    /// Integral of `func` over [0, 1].
    pub func_int: f32,
}

impl Distribution1D {
    /// The distribution proportional to `f` (uniform if `f` integrates to zero).
    pub fn new(f: &[f32]) -> Self {
        let n = f.len();
        let mut cdf = vec![0.0f32; n + 1];
        for i in 1..=n {
            cdf[i] = cdf[i - 1] + f[i - 1] / n as f32;
        }
        let func_int = cdf[n];
        if func_int == 0.0 {
            for (i, c) in cdf.iter_mut().enumerate().skip(1) {
                *c = i as f32 / n as f32;
            }
        } else {
            for c in cdf.iter_mut().skip(1) {
                *c /= func_int;
            }
        }
        Distribution1D { func: f.to_vec(), cdf, func_int }
    }

    /// Number of pieces.
    pub fn count(&self) -> usize {
        self.func.len()
    }

    /// A sample in [0, 1), its density, and the piece it fell in.
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        // Largest index whose CDF value is <= u.
        let offset = find_interval(self.cdf.len(), |i| self.cdf[i] <= u);
        let mut du = u - self.cdf[offset];
        if self.cdf[offset + 1] - self.cdf[offset] > 0.0 {
            du /= self.cdf[offset + 1] - self.cdf[offset];
        }
        let pdf = if self.func_int > 0.0 { self.func[offset] / self.func_int } else { 0.0 };
        ((offset as f32 + du) / self.count() as f32, pdf, offset)
    }
}

/// pbrt-v3 `FindInterval`: the largest `i` in `[0, size-2]` with `pred(i)` true
/// (predicate monotone: true then false).
pub fn find_interval(size: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut first, mut len) = (0usize, size);
    while len > 0 {
        let half = len >> 1;
        let middle = first + half;
        if pred(middle) {
            first = middle + 1;
            len -= half + 1;
        } else {
            len = half;
        }
    }
    first.saturating_sub(1).min(size.saturating_sub(2))
}

/// A piecewise-constant 2D distribution over [0,1]² (pbrt-v3 `Distribution2D`).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// From `nu × nv` values, row-major in v.
    pub fn new(f: &[f32], nu: usize, nv: usize) -> Self {
        let conditional: Vec<_> =
            (0..nv).map(|v| Distribution1D::new(&f[v * nu..(v + 1) * nu])).collect();
        let marginal_f: Vec<f32> = conditional.iter().map(|c| c.func_int).collect();
        Distribution2D { conditional, marginal: Distribution1D::new(&marginal_f) }
    }

    /// A point in [0,1]² and its density.
    pub fn sample_continuous(&self, u: Vec2) -> (Vec2, f32) {
        let (d1, pdf1, v) = self.marginal.sample_continuous(u.y);
        let (d0, pdf0, _) = self.conditional[v].sample_continuous(u.x);
        (Vec2::new(d0, d1), pdf0 * pdf1)
    }

    /// Cells across (u) and down (v).
    pub fn size(&self) -> (usize, usize) {
        (self.conditional[0].count(), self.marginal.count())
    }

    /// Density at `p`.
    pub fn pdf(&self, p: Vec2) -> f32 {
        let (nu, nv) = self.size();
        let iu = ((p.x * nu as f32) as usize).min(nu - 1);
        let iv = ((p.y * nv as f32) as usize).min(nv - 1);
        self.conditional[iv].func[iu] / self.marginal.func_int
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_samples_stay_in_disk_and_hemisphere_is_unit() {
        for i in 0..32 {
            for j in 0..32 {
                let u = Vec2::new(i as f32 / 31.0, j as f32 / 31.0);
                assert!(concentric_sample_disk(u).length() <= 1.0 + 1e-6);
                let w = cosine_sample_hemisphere(u);
                assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            }
        }
    }

    #[test]
    fn distribution_samples_follow_the_function() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        let (x, pdf, i) = d.sample_continuous(0.5);
        assert_eq!(i, 2);
        assert!((pdf - 2.25).abs() < 1e-5, "{pdf}");
        assert!(x > 2.0 / 3.0);
        let (_, _, i0) = d.sample_continuous(0.1);
        assert_eq!(i0, 0);
    }
}

/// What a camera needs from the sampler for one camera ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraSample {
    /// Point on the film, in raster coordinates (pixel + offset in [0,1)²).
    pub p_film: Vec2,
    /// Point on the lens, in [0,1)².
    pub p_lens: Vec2,
    /// Time in [0,1), mapped to the shutter interval by the camera.
    pub time: f32,
}
