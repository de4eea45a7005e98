//! pbrt-v3's Perlin noise, fractional Brownian motion and turbulence
//! (`core/texture.cpp`).

use farm_common::geometry::Vec3;
use farm_common::math;

#[rustfmt::skip]
const NOISE_PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// pbrt-v3 doubles the table; indexing modulo 256 is the same thing.
#[inline]
fn perm(i: i32) -> i32 {
    NOISE_PERM[(i & 255) as usize] as i32
}

#[inline]
fn grad(x: i32, y: i32, z: i32, dx: f32, dy: f32, dz: f32) -> f32 {
    let h = perm(perm(perm(x) + y) + z) & 15;
    let u = if h < 8 || h == 12 || h == 13 { dx } else { dy };
    let v = if h < 4 || h == 12 || h == 13 { dy } else { dz };
    (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v })
}

#[inline(always)]
fn weight(t: f32) -> f32 {
    let t3 = t * t * t;
    let t4 = t3 * t;
    6.0 * t4 * t - 15.0 * t4 + 10.0 * t3
}

#[inline]
fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

/// `math::floor(x)` and that as an `i32` (saturating, NaN 0), the same
/// bits; below 2^23 in magnitude, where truncation is exact, without the
/// general floor's and conversion's range checks.
#[inline(always)]
fn floor_parts(x: f32) -> (f32, i32) {
    // False for NaN.
    if x.abs() < 8_388_608.0 {
        let t = x as i32;
        let i = t - i32::from(t as f32 > x);
        // A negative x that truncates to 0 floors to -1, so only a zero
        // result needs the sign, which `math::floor` takes from x.
        ((i as f32).copysign(x), i)
    } else {
        let f = math::floor(x);
        (f, f as i32)
    }
}

/// Perlin noise at (x, y, z), in about [−1, 1]: [`noise_scalar`]'s bits
/// (NaN for NaN), its eight corners' gradients in two SSE vectors.
#[cfg(target_arch = "x86_64")]
pub fn noise(x: f32, y: f32, z: f32) -> f32 {
    let ((fx, ix), (fy, iy), (fz, iz)) = (floor_parts(x), floor_parts(y), floor_parts(z));
    let d = [x - fx, y - fy, z - fz];
    sse::blend(d, hashes(ix & 255, iy & 255, iz & 255))
}

/// Perlin noise at (x, y, z), in about [−1, 1].
#[cfg(not(target_arch = "x86_64"))]
pub fn noise(x: f32, y: f32, z: f32) -> f32 {
    noise_scalar(x, y, z)
}

/// The gradient indices (`h` of [`grad`]) of the eight corners of the
/// lattice cell at `ix`, `iy`, `iz`: the corners at x offset 0, then 1,
/// each in (y, z) offsets (0, 0), (1, 0), (0, 1), (1, 1).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn hashes(ix: i32, iy: i32, iz: i32) -> [[i32; 4]; 2] {
    let at = |px: i32| {
        let (p0, p1) = (perm(px + iy), perm(px + iy + 1));
        [p0 + iz, p1 + iz, p0 + iz + 1, p1 + iz + 1].map(|i| perm(i) & 15)
    };
    [at(perm(ix)), at(perm(ix + 1))]
}

#[cfg(target_arch = "x86_64")]
#[path = "noise_sse.rs"]
mod sse;

/// pbrt-v3's `Noise` as written, a corner at a time.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn noise_scalar(x: f32, y: f32, z: f32) -> f32 {
    let ((fx, ix), (fy, iy), (fz, iz)) = (floor_parts(x), floor_parts(y), floor_parts(z));
    let (dx, dy, dz) = (x - fx, y - fy, z - fz);
    let (ix, iy, iz) = (ix & 255, iy & 255, iz & 255);
    let w000 = grad(ix, iy, iz, dx, dy, dz);
    let w100 = grad(ix + 1, iy, iz, dx - 1.0, dy, dz);
    let w010 = grad(ix, iy + 1, iz, dx, dy - 1.0, dz);
    let w110 = grad(ix + 1, iy + 1, iz, dx - 1.0, dy - 1.0, dz);
    let w001 = grad(ix, iy, iz + 1, dx, dy, dz - 1.0);
    let w101 = grad(ix + 1, iy, iz + 1, dx - 1.0, dy, dz - 1.0);
    let w011 = grad(ix, iy + 1, iz + 1, dx, dy - 1.0, dz - 1.0);
    let w111 = grad(ix + 1, iy + 1, iz + 1, dx - 1.0, dy - 1.0, dz - 1.0);
    let (wx, wy, wz) = (weight(dx), weight(dy), weight(dz));
    let x00 = lerp(wx, w000, w100);
    let x10 = lerp(wx, w010, w110);
    let x01 = lerp(wx, w001, w101);
    let x11 = lerp(wx, w011, w111);
    let y0 = lerp(wy, x00, x10);
    let y1 = lerp(wy, x01, x11);
    lerp(wz, y0, y1)
}

fn smooth_step(min: f32, max: f32, value: f32) -> f32 {
    let v = ((value - min) / (max - min)).clamp(0.0, 1.0);
    v * v * (-2.0 * v + 3.0)
}

/// How many octaves the footprint `dpdx`, `dpdy` can show, at most
/// `max_octaves` (pbrt-v3's `Clamp(-1 - .5 Log2(len2), 0, maxOctaves)`;
/// with `max_octaves` below 0 that is 0 for a count below 0 and
/// `max_octaves` otherwise).
#[inline]
fn octaves(dpdx: Vec3, dpdy: Vec3, max_octaves: i32) -> f32 {
    let len2 = dpdx.length_squared().max(dpdy.length_squared());
    let max = max_octaves as f32;
    // Footprints far below or above the octaves' range clamp whatever
    // log2's last bit: at most 2^(-2 max - 4) gives max + 1 or more, at
    // least 1/2 gives -1/2 or less. They skip the logarithm.
    let tiny = if (0..=61).contains(&max_octaves) {
        f32::from_bits(((127 - 4 - 2 * max_octaves) as u32) << 23)
    } else {
        0.0
    };
    let n = if len2 <= tiny {
        f32::INFINITY
    } else if len2 >= 0.5 {
        f32::NEG_INFINITY
    } else {
        -1.0 - 0.5 * math::log2(len2)
    };
    math::clamp(n, 0.0, max)
}

/// Antialiased fractional Brownian motion.
pub fn fbm(p: Vec3, dpdx: Vec3, dpdy: Vec3, omega: f32, max_octaves: i32) -> f32 {
    let n = octaves(dpdx, dpdy, max_octaves);
    let n_int = math::floor(n) as i32;
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..n_int {
        let q = lambda * p;
        sum += o * noise(q.x, q.y, q.z);
        lambda *= 1.99;
        o *= omega;
    }
    let w = smooth_step(0.3, 0.7, n - n_int as f32);
    sum + o * w * unless_weightless(w, lambda * p)
}

/// `noise(q)`, or 0 where its weight `w` is 0 and it is finite: the
/// fractional octave of a footprint with a whole number of octaves, which
/// adds ±0 to a sum that is never -0 (or NaN, when the octave's scale is
/// infinite, either way).
#[inline]
fn unless_weightless(w: f32, q: Vec3) -> f32 {
    if w == 0.0 && q.is_finite() {
        0.0
    } else {
        noise(q.x, q.y, q.z)
    }
}

/// Antialiased turbulence (sum of |noise|).
pub fn turbulence(p: Vec3, dpdx: Vec3, dpdy: Vec3, omega: f32, max_octaves: i32) -> f32 {
    let n = octaves(dpdx, dpdy, max_octaves);
    let n_int = math::floor(n) as i32;
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..n_int {
        let q = lambda * p;
        sum += o * noise(q.x, q.y, q.z).abs();
        lambda *= 1.99;
        o *= omega;
    }
    let w = smooth_step(0.3, 0.7, n - n_int as f32);
    sum += o * lerp(w, 0.2, unless_weightless(w, lambda * p).abs());
    for _ in n_int..max_octaves {
        sum += o * 0.2;
        o *= omega;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_parts_are_the_floor_and_its_integer() {
        let mut xs = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, -1e-30, 8_388_607.5, -8_388_607.5];
        xs.extend([8_388_608.0, -8_388_608.0, 3e9, -3e9, f32::MAX, f32::INFINITY, f32::NAN]);
        xs.extend([f32::NEG_INFINITY, f32::MIN_POSITIVE, -f32::MIN_POSITIVE]);
        let mut x = -70_000.0f32;
        while x < 70_000.0 {
            xs.extend([x, x.next_up(), x.next_down()]);
            x += 137.37;
        }
        for x in xs {
            let (f, i) = floor_parts(x);
            let want = math::floor(x);
            assert_eq!(f.to_bits(), want.to_bits(), "{x}");
            assert_eq!(i, want as i32, "{x}");
        }
    }

    /// pbrt-v3's `FBm` and `Turbulence` as written: the logarithm always,
    /// every octave's noise, and its `Clamp`.
    fn pbrt_fbm_turbulence(p: Vec3, dx: Vec3, dy: Vec3, omega: f32, max: i32) -> (f32, f32) {
        // pbrt-v3's `Clamp`, written out again so that the test does not
        // lean on `math::clamp`.
        let clamp = |v: f32, lo: f32, hi: f32| {
            if v < lo {
                lo
            } else if v > hi {
                hi
            } else {
                v
            }
        };
        let len2 = dx.length_squared().max(dy.length_squared());
        let n = clamp(-1.0 - 0.5 * math::log2(len2), 0.0, max as f32);
        let n_int = math::floor(n) as i32;
        let (mut f, mut t, mut lambda, mut o) = (0.0, 0.0, 1.0, 1.0);
        for _ in 0..n_int {
            let v = noise(lambda * p.x, lambda * p.y, lambda * p.z);
            f += o * v;
            t += o * v.abs();
            lambda *= 1.99;
            o *= omega;
        }
        let w = smooth_step(0.3, 0.7, n - n_int as f32);
        let v = noise(lambda * p.x, lambda * p.y, lambda * p.z);
        f += o * w * v;
        t += o * lerp(w, 0.2, v.abs());
        for _ in n_int..max {
            t += o * 0.2;
            o *= omega;
        }
        (f, t)
    }

    #[test]
    fn fbm_and_turbulence_keep_pbrts_bits_and_take_any_octave_count() {
        let mut rng = farm_common::rng::Rng::new(5);
        let mut u = || rng.uniform_f32() * 2.0 - 1.0;
        for k in 0..4000 {
            let p = Vec3::new(u(), u(), u()) * [1.0, 37.0, 1e5, f32::INFINITY][k % 4].min(1e30);
            // Footprints from far below one octave's scale to far above it.
            let s = 2f32.powi((k % 48) as i32 - 40) * (1.0 + u().abs());
            let (dx, dy) = (Vec3::new(u(), u(), u()) * s, Vec3::new(u(), 0.0, u()) * s);
            let omega = [0.5, 0.6, -0.7, 1e30][k % 4];
            for max in [-3, 0, 1, 6, 8, 61, 62, 200] {
                let (f, t) = pbrt_fbm_turbulence(p, dx, dy, omega, max);
                // The same bits, or NaN for NaN (whose sign the compiler may
                // change by swapping an addition's operands).
                let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || a.is_nan() && b.is_nan();
                let (f2, t2) = (fbm(p, dx, dy, omega, max), turbulence(p, dx, dy, omega, max));
                let args = format!("{p} {dx} {dy} {omega} {max}");
                assert!(same(f2, f), "fbm {args}: {f2} against {f}");
                assert!(same(t2, t), "turbulence {args}: {t2} against {t}");
            }
        }
        let nan = Vec3::splat(f32::NAN);
        assert!(fbm(Vec3::ONE, nan, nan, 0.5, 8).is_nan());
        assert_eq!(fbm(Vec3::splat(0.3), Vec3::ZERO, Vec3::ZERO, 0.5, -1), 0.0);
    }

    /// `noise` against pbrt-v3's formula as written (`noise_scalar`): the
    /// same bits, or NaN for NaN, in and around the cells of every
    /// gradient index, on and near lattice points (where zeros' signs
    /// matter), far out and at non-finite points.
    #[test]
    fn noise_gives_the_scalar_bits() {
        let mut rng = farm_common::rng::Rng::new(9);
        let mut u = || rng.uniform_f32();
        let mut points = Vec::new();
        for k in 0..200_000 {
            let scale = [1.0, 8.0, 300.0, 1e5, 1e7, 3e9][k % 6];
            points.push([u(), u(), u()].map(|v| (v * 2.0 - 1.0) * scale));
        }
        for k in 0..20_000 {
            // Lattice points and their neighbours, with either zero.
            let i = [u(), u(), u()].map(|v| ((v * 40.0) as i32 - 20) as f32);
            let j = [u(), u(), u()].map(|v| (v * 3.0) as usize);
            let at = |c: usize| [i[c], i[c].next_up(), i[c].next_down(), -0.0, 0.0][(j[c] + k) % 5];
            points.push([at(0), at(1), at(2)]);
        }
        let odd = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 0.5];
        for a in odd {
            for b in odd {
                points.push([a, b, 0.25]);
                points.push([0.75, a, b]);
            }
        }
        for [x, y, z] in points {
            let (got, want) = (noise(x, y, z), noise_scalar(x, y, z));
            let same = got.to_bits() == want.to_bits() || got.is_nan() && want.is_nan();
            assert!(same, "noise({x}, {y}, {z}) = {got:e}, pbrt-v3's formula {want:e}");
        }
    }

    #[test]
    fn noise_vanishes_on_lattice_and_is_bounded() {
        assert_eq!(noise(3.0, 4.0, 5.0), 0.0);
        let mut x = 0.1f32;
        for _ in 0..1000 {
            x += 0.137;
            let v = noise(x, x * 0.7, -x * 1.3);
            assert!(v.abs() <= 1.5, "{v}");
        }
    }
}
