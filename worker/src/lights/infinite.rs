//! `LightSource "infinite"` (alias `"exinfinite"`): radiance arriving from
//! every direction, constant or from a lat-long image (pbrt-v3
//! `lights/infinite.cpp`), sampled in proportion to its brightness.

use super::LightSample;
use crate::image::{MipMap, WrapMode};
use crate::interaction::Interaction;
use crate::sampling::Distribution2D;
use farm_common::geometry::{Ray, Transform, Vec2, Vec3};
use farm_common::Spectrum;
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
        // Sample the map at twice its resolution, weighted by sin θ.
        let (w, h) = (2 * width, 2 * height);
        let filter_width = 0.5 / (w.min(h) as f32);
        let mut img = vec![0.0f32; w * h];
        for v in 0..h {
            let vp = (v as f32 + 0.5) / h as f32;
            let sin_theta = (PI * (v as f32 + 0.5) / h as f32).sin();
            for u in 0..w {
                let up = (u as f32 + 0.5) / w as f32;
                img[v * w + u] = lmap.lookup(Vec2::new(up, vp), filter_width).y() * sin_theta;
            }
        }
        InfiniteLight {
            lmap,
            render_from_light,
            distribution: Distribution2D::new(&img, w, h),
            world_radius: 0.0,
        }
    }

    /// Radiance of an escaping ray.
    #[inline]
    pub fn le(&self, ray: &Ray) -> Spectrum {
        let wr = self.render_from_light.inverse().vector(ray.d).normalize();
        let st = Vec2::new(spherical_phi(wr) * (0.5 / PI), spherical_theta(wr) / PI);
        self.lmap.lookup(st, 0.0)
    }

    /// A direction drawn from the map's importance distribution.
    #[inline]
    pub fn sample_li(&self, r: &Interaction, u: Vec2) -> Option<LightSample> {
        let (uv, map_pdf) = self.distribution.sample_continuous(u);
        if map_pdf == 0.0 {
            return None;
        }
        let theta = uv.y * PI;
        let phi = uv.x * 2.0 * PI;
        let (sin_theta, cos_theta) = theta.sin_cos();
        let (sin_phi, cos_phi) = phi.sin_cos();
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
            li: self.lmap.lookup(uv, 0.0),
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
fn spherical_theta(v: Vec3) -> f32 {
    v.z.clamp(-1.0, 1.0).acos()
}

/// φ of a vector, in [0, 2π).
#[inline]
fn spherical_phi(v: Vec3) -> f32 {
    let p = v.y.atan2(v.x);
    if p < 0.0 {
        p + 2.0 * PI
    } else {
        p
    }
}
