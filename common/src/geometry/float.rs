use crate::math;
use glam::Vec3;

/// Half of f32's ulp at one: pbrt-v3's `MachineEpsilon`.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// Shadow rays stop this fraction short of their target (pbrt-v3 `ShadowEpsilon`).
pub const SHADOW_EPSILON: f32 = 0.0001;

/// Bound on the relative error of `n` floating-point operations: γₙ = nε/(1−nε).
#[inline]
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPSILON) / (1.0 - n as f32 * MACHINE_EPSILON)
}

/// The smallest f32 greater than `v` (infinity stays infinity, and NaN
/// stays NaN: pbrt-v3's bit step turns some NaNs into zero or infinity).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    // One comparison keeps both: false for +∞ and for NaN.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(v < f32::INFINITY) {
        return v;
    }
    // `v + 0.0` turns −0 into +0. Then one step away from zero for a
    // positive value and towards it for a negative one, without a branch.
    let bits = (v + 0.0).to_bits();
    f32::from_bits(bits.wrapping_add(1u32.wrapping_sub((bits >> 31) << 1)))
}

/// The largest f32 less than `v` (negative infinity stays, and NaN stays
/// NaN).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(v > f32::NEG_INFINITY) {
        return v;
    }
    // `-(-v + 0.0)` turns +0 into −0, so zero steps to the smallest negative value.
    let bits = (-(-v + 0.0)).to_bits();
    f32::from_bits(bits.wrapping_add(((bits >> 31) << 1).wrapping_sub(1)))
}

/// Moves a ray origin `p` with absolute error `p_error` off the surface with
/// geometric normal `n`, to the side `w` points to, far enough that the ray
/// cannot re-intersect the surface it leaves (pbrt-v3 `OffsetRayOrigin`).
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_float_down(po[i]);
        }
    }
    po
}

/// Two unit vectors that complete `v1` (unit) to an orthonormal basis
/// (pbrt-v3 `CoordinateSystem`).
#[inline]
pub fn coordinate_system(v1: Vec3) -> (Vec3, Vec3) {
    let v2 = if v1.x.abs() > v1.y.abs() {
        Vec3::new(-v1.z, 0.0, v1.x) / (v1.x * v1.x + v1.z * v1.z).sqrt()
    } else {
        Vec3::new(0.0, v1.z, -v1.y) / (v1.y * v1.y + v1.z * v1.z).sqrt()
    };
    (v2, v1.cross(v2))
}

/// `n` flipped if needed to lie in the hemisphere of `v`.
#[inline]
pub fn face_forward(n: Vec3, v: Vec3) -> Vec3 {
    if n.dot(v) < 0.0 {
        -n
    } else {
        n
    }
}

/// The unit vector with the given spherical angles in the frame (x, y, z).
#[inline]
pub fn spherical_direction(
    sin_theta: f32,
    cos_theta: f32,
    phi: f32,
    x: Vec3,
    y: Vec3,
    z: Vec3,
) -> Vec3 {
    sin_theta * math::cos(phi) * x + sin_theta * math::sin(phi) * y + cos_theta * z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp_across_zero() {
        assert_eq!(next_float_up(0.0), f32::from_bits(1));
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(next_float_up(3.5)), 3.5);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    /// The branch-free steps agree with pbrt-v3's branchy `NextFloatUp` and
    /// `NextFloatDown` on zeros, denormals, normal values, the largest finite
    /// values and infinities, of both signs.
    #[test]
    fn next_float_matches_the_branchy_definition() {
        fn up(v: f32) -> f32 {
            if v.is_infinite() && v > 0.0 {
                return v;
            }
            let v = if v == -0.0 { 0.0 } else { v };
            let b = v.to_bits();
            f32::from_bits(if v >= 0.0 { b + 1 } else { b - 1 })
        }
        fn down(v: f32) -> f32 {
            if v.is_infinite() && v < 0.0 {
                return v;
            }
            let v = if v == 0.0 { -0.0 } else { v };
            let b = v.to_bits();
            f32::from_bits(if v > 0.0 { b - 1 } else { b + 1 })
        }
        let mut values = vec![0.0, f32::from_bits(1), f32::MIN_POSITIVE, 1.0, 3.5, 1e30, f32::MAX];
        values.extend(
            (0..1000).map(|i| f32::from_bits(i * 4_294_967 + 12_345)).filter(|v| !v.is_nan()),
        );
        for v in values.clone() {
            values.push(-v);
        }
        values.extend([f32::INFINITY, f32::NEG_INFINITY]);
        for v in values {
            assert_eq!(next_float_up(v).to_bits(), up(v).to_bits(), "up {v:e}");
            assert_eq!(next_float_down(v).to_bits(), down(v).to_bits(), "down {v:e}");
        }
    }

    /// NaN stays NaN, whatever its sign and payload, where the bit step
    /// alone would wrap the largest payloads round to a zero or an
    /// infinity (as pbrt-v3's does).
    #[test]
    fn next_float_keeps_nan() {
        for bits in
            [0x7fc0_0000u32, 0xffc0_0000, 0x7fff_ffff, 0xffff_ffff, 0x7f80_0001, 0xff80_0001]
        {
            let v = f32::from_bits(bits);
            assert!(next_float_up(v).is_nan(), "up {bits:#x}");
            assert!(next_float_down(v).is_nan(), "down {bits:#x}");
        }
    }

    #[test]
    fn offset_origin_leaves_the_plane_to_the_right_side() {
        let p = Vec3::new(1e6, 3.0, 0.0);
        let err = Vec3::splat(1e-3);
        let n = Vec3::Z;
        assert!(offset_ray_origin(p, err, n, Vec3::Z).z > 1e-3);
        assert!(offset_ray_origin(p, err, n, -Vec3::Z).z < -1e-3);
    }

    #[test]
    fn coordinate_system_is_orthonormal() {
        for v in [Vec3::X, Vec3::Y, -Vec3::Z, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let (a, b) = coordinate_system(v);
            assert!(a.dot(v).abs() < 1e-6 && b.dot(v).abs() < 1e-6 && a.dot(b).abs() < 1e-6);
            assert!((a.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
        }
    }
}
