//! Shading-frame trigonometry, reflection and refraction (the inline helpers
//! of pbrt-v3 `core/reflection.h`). Directions are unit vectors in the local
//! frame where the shading normal is +z.

use farm_common::geometry::Vec3;

/// The largest f32 below one (pbrt-v3 `OneMinusEpsilon`).
pub const ONE_MINUS_EPSILON: f32 = 0.999_999_94;

/// cos θ.
#[inline]
pub fn cos_theta(w: Vec3) -> f32 {
    w.z
}
/// cos² θ.
#[inline]
pub fn cos2_theta(w: Vec3) -> f32 {
    w.z * w.z
}
/// |cos θ|.
#[inline]
pub fn abs_cos_theta(w: Vec3) -> f32 {
    w.z.abs()
}
/// sin² θ.
#[inline]
pub fn sin2_theta(w: Vec3) -> f32 {
    (1.0 - cos2_theta(w)).max(0.0)
}
/// sin θ.
#[inline]
pub fn sin_theta(w: Vec3) -> f32 {
    sin2_theta(w).sqrt()
}
/// tan θ.
#[inline]
pub fn tan_theta(w: Vec3) -> f32 {
    sin_theta(w) / cos_theta(w)
}
/// tan² θ.
#[inline]
pub fn tan2_theta(w: Vec3) -> f32 {
    sin2_theta(w) / cos2_theta(w)
}
/// cos φ.
#[inline]
pub fn cos_phi(w: Vec3) -> f32 {
    let s = sin_theta(w);
    if s == 0.0 {
        1.0
    } else {
        (w.x / s).clamp(-1.0, 1.0)
    }
}
/// sin φ.
#[inline]
pub fn sin_phi(w: Vec3) -> f32 {
    let s = sin_theta(w);
    if s == 0.0 {
        0.0
    } else {
        (w.y / s).clamp(-1.0, 1.0)
    }
}
/// cos² φ.
#[inline]
pub fn cos2_phi(w: Vec3) -> f32 {
    cos_phi(w) * cos_phi(w)
}
/// sin² φ.
#[inline]
pub fn sin2_phi(w: Vec3) -> f32 {
    sin_phi(w) * sin_phi(w)
}
/// Whether two local directions lie on the same side of the surface.
#[inline]
pub fn same_hemisphere(w: Vec3, wp: Vec3) -> bool {
    w.z * wp.z > 0.0
}
/// `wo` mirrored about `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}
/// The direction refracted from `wi` through a surface with normal `n`
/// (on `wi`'s side) and relative index `eta` = ηi/ηt; `None` on total
/// internal reflection.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_theta_i = n.dot(wi);
    let sin2_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0);
    let sin2_theta_t = eta * eta * sin2_theta_i;
    if sin2_theta_t >= 1.0 {
        return None;
    }
    let cos_theta_t = (1.0 - sin2_theta_t).sqrt();
    Some(eta * -wi + (eta * cos_theta_i - cos_theta_t) * n)
}
/// `v` flipped to the side of `w`.
#[inline]
pub fn face_forward(v: Vec3, w: Vec3) -> Vec3 {
    if v.dot(w) < 0.0 {
        -v
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refraction_obeys_snell() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let wt = refract(wi, Vec3::Z, 1.0 / 1.5).unwrap();
        assert!((sin_theta(wt) - 0.6 / 1.5).abs() < 1e-6);
        assert!(wt.z < 0.0);
        assert!(refract(Vec3::new(0.8, 0.0, 0.6), Vec3::Z, 1.5).is_none());
        let r = reflect(wi, Vec3::Z);
        assert!((r - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
    }
}
