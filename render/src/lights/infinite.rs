//! `LightSource "infinite"` (alias `"exinfinite"`): radiance arriving from
//! every direction, constant or from a lat-long image (pbrt-v3
//! `lights/infinite.cpp`), sampled in proportion to its brightness.

use super::LightSample;
use crate::image::{MipMap, WrapMode};
use crate::interaction::Interaction;
use crate::sampling::Distribution2D;
use farm_common::geometry::{Ray, Transform, Vec2, Vec3};
use farm_common::math;
use farm_common::scene::{Entity, Params, Warning};
use farm_common::Spectrum;
use std::collections::BTreeMap;
use std::f32::consts::PI;

/// An environment light.
#[derive(Clone, Debug)]
pub struct InfiniteLight {
    /// The radiance map (lat-long), already multiplied by `L` × `scale`.
    pub lmap: MipMap<Spectrum>,
    /// Render-from-light.
    pub render_from_light: Transform,
    /// Importance distribution over the map.
    pub distribution: Distribution2D,
    /// Radius of the scene's bounding sphere (set by preprocessing).
    pub world_radius: f32,
    /// The radiance when the map is one texel (no `mapname`): then the
    /// importance distribution is uniform and no lookup is needed.
    constant: Option<Spectrum>,
}

impl InfiniteLight {
    /// A light from the map's texels (`width × height`, row-major).
    pub fn new(
        render_from_light: Transform,
        width: usize,
        height: usize,
        texels: Vec<Spectrum>,
    ) -> Self {
        let lmap = MipMap::new(width, height, texels, false, 8.0, WrapMode::Repeat);
        // Sample the map at twice its resolution, weighted by sin θ: the
        // MIP map's, a power of two each way, as pbrt-v3 takes
        // `Lmap->Width()`, not the image file's.
        let (map_w, map_h) = lmap.level_size(0);
        let (w, h) = (2 * map_w, 2 * map_h);
        let filter_width = 0.5 / (w.min(h) as f32);
        let mut img = vec![0.0f32; w * h];
        for v in 0..h {
            let vp = (v as f32 + 0.5) / h as f32;
            let sin_theta = math::sin(PI * (v as f32 + 0.5) / h as f32);
            for u in 0..w {
                let up = (u as f32 + 0.5) / w as f32;
                img[v * w + u] = lmap.lookup(Vec2::new(up, vp), filter_width).y() * sin_theta;
            }
        }
        let constant = (width == 1 && height == 1).then(|| lmap.texel(0, 0, 0));
        InfiniteLight {
            lmap,
            render_from_light,
            distribution: Distribution2D::new(&img, w, h),
            world_radius: 0.0,
            constant,
        }
    }

    /// Radiance of an escaping ray.
    #[inline]
    pub fn le(&self, ray: &Ray) -> Spectrum {
        if let Some(l) = self.constant {
            return l;
        }
        let wr = self.render_from_light.inverse().vector(ray.d).normalize();
        let st = Vec2::new(spherical_phi(wr) * (0.5 / PI), spherical_theta(wr) / PI);
        self.lmap.lookup(st, 0.0)
    }

    /// A direction drawn from the map's importance distribution.
    #[inline]
    pub fn sample_li(&self, r: &Interaction, u: Vec2) -> Option<LightSample> {
        // A constant map's distribution is uniform: (u, 1), up to rounding.
        let (uv, map_pdf) = match self.constant {
            Some(_) => (u, 1.0),
            None => self.distribution.sample_continuous(u),
        };
        if map_pdf == 0.0 {
            return None;
        }
        let theta = uv.y * PI;
        let phi = uv.x * 2.0 * PI;
        let (sin_theta, cos_theta) = math::sin_cos(theta);
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let wi = self.render_from_light.vector(Vec3::new(
            sin_theta * cos_phi,
            sin_theta * sin_phi,
            cos_theta,
        ));
        if sin_theta == 0.0 {
            return None;
        }
        let pdf = map_pdf / (2.0 * PI * PI * sin_theta);
        Some(LightSample {
            li: self.constant.unwrap_or_else(|| self.lmap.lookup(uv, 0.0)),
            wi,
            pdf,
            p_light: Interaction {
                p: r.p + wi * (2.0 * self.world_radius),
                time: r.time,
                ..Default::default()
            },
        })
    }
}

/// θ of a unit vector, in [0, π].
#[inline]
pub(super) fn spherical_theta(v: Vec3) -> f32 {
    math::acos(v.z.clamp(-1.0, 1.0))
}

/// φ of a vector, in [0, 2π).
#[inline]
pub(super) fn spherical_phi(v: Vec3) -> f32 {
    let p = math::atan2(v.y, v.x);
    if p < 0.0 {
        p + 2.0 * PI
    } else {
        p
    }
}

impl InfiniteLight {
    /// A `LightSource "infinite"` (pbrt-v3 `CreateInfiniteLight`): `L`
    /// times the `mapname` image read from `assets`, or `L` alone.
    pub(super) fn create(
        p: &Params,
        e: &Entity,
        render_from_light: &Transform,
        assets: &BTreeMap<String, Vec<u8>>,
        warnings: &mut Vec<Warning>,
    ) -> Self {
        let l = p.spectrum("L", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        p.touch("samples");
        p.touch("nsamples");
        let (w, h, texels) = match super::create::image_map(p, e, assets, warnings) {
            Some(img) => {
                let texels = img.pixels.iter().map(|&[r, g, b]| Spectrum::new(r, g, b) * l);
                (img.width, img.height, texels.collect())
            }
            None => (1, 1, vec![l]),
        };
        InfiniteLight::new(*render_from_light, w, h, texels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    /// The constant map's short cut gives what its distribution and lookups
    /// give, to rounding.
    #[test]
    fn constant_map_short_cut_matches_the_general_path() {
        let l = Spectrum::new(0.4, 0.45, 0.5);
        let xf = Transform::new(farm_common::geometry::Mat4::from_rotation_x(0.3));
        let mut fast = InfiniteLight::new(xf, 1, 1, vec![l]);
        fast.world_radius = 10.0;
        let general = InfiniteLight { constant: None, ..fast.clone() };
        assert!(fast.constant.is_some());
        assert!(InfiniteLight::new(xf, 2, 1, vec![l; 2]).constant.is_none());
        let r = Interaction { p: Vec3::new(1.0, 2.0, 3.0), ..Default::default() };
        let mut rng = Rng::new(3);
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1e-3);
        for _ in 0..1000 {
            let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
            let (a, b) = (fast.sample_li(&r, u).unwrap(), general.sample_li(&r, u).unwrap());
            assert!(close(a.pdf, b.pdf), "pdf {} vs {}", a.pdf, b.pdf);
            assert!((a.wi - b.wi).length() < 1e-5, "{} vs {}", a.wi, b.wi);
            for c in 0..3 {
                assert!(close(a.li[c], b.li[c]) && close(a.li[c], l[c]));
            }
            let ray = Ray::new(Vec3::ZERO, a.wi, 0.0);
            assert!(close(fast.le(&ray)[0], general.le(&ray)[0]));
        }
    }

    /// The importance distribution covers twice the MIP map's resolution,
    /// which is the image's rounded up to powers of two (pbrt-v3 builds it
    /// from `Lmap->Width()` and `Height()`): 128 × 64 cells for a 48 × 20
    /// image, not 96 × 40.
    #[test]
    fn the_distribution_covers_twice_the_map_not_the_image() {
        let texels = (0..48 * 20).map(|i| Spectrum::splat(1.0 + (i % 7) as f32)).collect();
        let l = InfiniteLight::new(Transform::default(), 48, 20, texels);
        assert_eq!(l.lmap.level_size(0), (64, 32));
        assert_eq!(l.distribution.size(), (128, 64));
    }
}
