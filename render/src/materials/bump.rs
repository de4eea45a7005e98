//! Bump mapping (pbrt-v3 `Material::Bump`): perturbs the shading frame by
//! a float displacement texture, using forward differences in u and v.

use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::geometry::Vec2;

/// Replaces `si`'s shading geometry with the bump-mapped one.
pub fn bump(d: &TexInput<f32>, si: &mut SurfaceInteraction, t: &TextureSet) {
    let mut e = *si;
    // Shift in u.
    let mut du = 0.5 * (si.dudx.abs() + si.dudy.abs());
    if du == 0.0 {
        du = 0.0005;
    }
    e.it.p = si.p() + du * si.shading.dpdu;
    e.uv = si.uv + Vec2::new(du, 0.0);
    e.it.n = (si.shading.dpdu.cross(si.shading.dpdv) + du * si.dndu).normalize();
    let u_displace = t.eval(d, &e);
    // Shift in v.
    let mut dv = 0.5 * (si.dvdx.abs() + si.dvdy.abs());
    if dv == 0.0 {
        dv = 0.0005;
    }
    e.it.p = si.p() + dv * si.shading.dpdv;
    e.uv = si.uv + Vec2::new(0.0, dv);
    e.it.n = (si.shading.dpdu.cross(si.shading.dpdv) + dv * si.dndv).normalize();
    let v_displace = t.eval(d, &e);
    let displace = t.eval(d, si);
    let sh = si.shading;
    let dpdu = sh.dpdu + (u_displace - displace) / du * sh.n + displace * sh.dndu;
    let dpdv = sh.dpdv + (v_displace - displace) / dv * sh.n + displace * sh.dndv;
    si.set_shading_geometry(dpdu, dpdv, sh.dndu, sh.dndv, false);
}
