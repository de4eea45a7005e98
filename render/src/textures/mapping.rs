//! Texture coordinate generation (pbrt-v3 `TextureMapping2D` and
//! `IdentityMapping3D`). Hits are in render space; the transforms stored
//! here take render-space points to the space each mapping works in.

use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{Transform, Vec2, Vec3};
use farm_common::math;
use farm_common::scene::{FileLoc, Params, Warning};
use std::f32::consts::PI;

/// (s, t) and its screen-space derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StSample {
    /// Texture coordinates.
    pub st: Vec2,
    /// ∂(s, t)/∂x.
    pub dstdx: Vec2,
    /// ∂(s, t)/∂y.
    pub dstdy: Vec2,
}

/// A 2D mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mapping2D {
    /// (su·u + du, sv·v + dv).
    Uv {
        /// u scale.
        su: f32,
        /// v scale.
        sv: f32,
        /// u offset.
        du: f32,
        /// v offset.
        dv: f32,
    },
    /// Spherical angles about the texture-space origin.
    Spherical {
        /// Texture-from-render.
        texture_from_render: Transform,
    },
    /// Cylindrical angle and height about the texture-space z axis.
    Cylindrical {
        /// Texture-from-render.
        texture_from_render: Transform,
    },
    /// Projection of the world-space point onto two vectors.
    Planar {
        /// s axis.
        vs: Vec3,
        /// t axis.
        vt: Vec3,
        /// s offset.
        ds: f32,
        /// t offset.
        dt: f32,
        /// World-from-render (pbrt-v3 projects world-space points).
        world_from_render: Transform,
    },
}

fn sphere(xf: &Transform, p: Vec3) -> Vec2 {
    let v = xf.point(p).normalize();
    let theta = math::acos(v.z.clamp(-1.0, 1.0));
    let mut phi = math::atan2(v.y, v.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    Vec2::new(theta * (1.0 / PI), phi * (1.0 / (2.0 * PI)))
}

fn cylinder(xf: &Transform, p: Vec3) -> Vec2 {
    let v = xf.point(p).normalize();
    Vec2::new((PI + math::atan2(v.y, v.x)) * (1.0 / (2.0 * PI)), v.z)
}

/// pbrt-v3's fix-up of the t derivative across the mapping's seam.
fn unwrap_seam(mut d: Vec2) -> Vec2 {
    if d.y > 0.5 {
        d.y = 1.0 - d.y;
    } else if d.y < -0.5 {
        d.y = -(d.y + 1.0);
    }
    d
}

impl Mapping2D {
    /// The identity uv mapping.
    pub const UV: Mapping2D = Mapping2D::Uv { su: 1.0, sv: 1.0, du: 0.0, dv: 0.0 };

    /// Texture coordinates and their differentials at `si`.
    pub fn map(&self, si: &SurfaceInteraction) -> StSample {
        match self {
            Mapping2D::Uv { su, sv, du, dv } => StSample {
                st: Vec2::new(su * si.uv.x + du, sv * si.uv.y + dv),
                dstdx: Vec2::new(su * si.dudx, sv * si.dvdx),
                dstdy: Vec2::new(su * si.dudy, sv * si.dvdy),
            },
            Mapping2D::Spherical { texture_from_render: xf } => {
                let st = sphere(xf, si.p());
                let delta = 0.1;
                let dx = (sphere(xf, si.p() + delta * si.dpdx) - st) / delta;
                let dy = (sphere(xf, si.p() + delta * si.dpdy) - st) / delta;
                StSample { st, dstdx: unwrap_seam(dx), dstdy: unwrap_seam(dy) }
            }
            Mapping2D::Cylindrical { texture_from_render: xf } => {
                let st = cylinder(xf, si.p());
                let delta = 0.01;
                let dx = (cylinder(xf, si.p() + delta * si.dpdx) - st) / delta;
                let dy = (cylinder(xf, si.p() + delta * si.dpdy) - st) / delta;
                StSample { st, dstdx: unwrap_seam(dx), dstdy: unwrap_seam(dy) }
            }
            Mapping2D::Planar { vs, vt, ds, dt, world_from_render: w } => {
                let p = w.point(si.p());
                let (dpdx, dpdy) = (w.vector(si.dpdx), w.vector(si.dpdy));
                StSample {
                    st: Vec2::new(ds + p.dot(*vs), dt + p.dot(*vt)),
                    dstdx: Vec2::new(dpdx.dot(*vs), dpdx.dot(*vt)),
                    dstdy: Vec2::new(dpdy.dot(*vs), dpdy.dot(*vt)),
                }
            }
        }
    }
}

/// pbrt-v3's `IdentityMapping3D`: a point and its differentials through a transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping3D {
    /// The transform applied to render-space points.
    pub xf: Transform,
}

impl Mapping3D {
    /// (p, ∂p/∂x, ∂p/∂y) in texture space.
    pub fn map(&self, si: &SurfaceInteraction) -> (Vec3, Vec3, Vec3) {
        (self.xf.point(si.p()), self.xf.vector(si.dpdx), self.xf.vector(si.dpdy))
    }
}

/// Where textures map points: render space to each mapping's space.
pub(super) struct Spaces {
    pub(super) texture_from_render: Transform,
    pub(super) world_from_render: Transform,
    /// pbrt-v3 hands `tex2world` to `IdentityMapping3D` as its world-to-texture transform.
    pub(super) solid_from_render: Transform,
}

impl Mapping2D {
    /// The `"string mapping"` of a 2D texture with its parameters (pbrt-v3
    /// `TextureParams` mapping set-up in each `Create*Texture`).
    pub(super) fn create(
        p: &Params,
        sp: &Spaces,
        loc: &FileLoc,
        w: &mut Vec<Warning>,
    ) -> Mapping2D {
        match p.string("mapping", "uv").as_str() {
            "uv" => Mapping2D::Uv {
                su: p.float("uscale", 1.0),
                sv: p.float("vscale", 1.0),
                du: p.float("udelta", 0.0),
                dv: p.float("vdelta", 0.0),
            },
            "spherical" => Mapping2D::Spherical { texture_from_render: sp.texture_from_render },
            "cylindrical" => Mapping2D::Cylindrical { texture_from_render: sp.texture_from_render },
            "planar" => Mapping2D::Planar {
                vs: p.vector3("v1", Vec3::X),
                vt: p.vector3("v2", Vec3::Y),
                ds: p.float("udelta", 0.0),
                dt: p.float("vdelta", 0.0),
                world_from_render: sp.world_from_render,
            },
            other => {
                w.push(Warning::at(loc, format!("2D texture mapping \"{other}\" unknown")));
                Mapping2D::UV
            }
        }
    }
}
