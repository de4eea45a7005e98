//! EWA lookups in a 1024² RGB MIP map (pbrt-v3's default image-texture
//! filter), at random points with footprints of random size and
//! orientation and the given anisotropy (major ÷ minor axis; pbrt-v3
//! clamps it at 8). The counter counts lookups.

use super::*;
use farm_common::Spectrum;
use farm_render::image::{MipMap, WrapMode};

const SIDE: usize = 1024;

#[divan::bench(args = [1.0, 4.0, 8.0])]
fn lookup_ewa(bencher: Bencher, anisotropy: f32) {
    let mut rng = Rng::new(17);
    let texels = (0..SIDE * SIDE)
        .map(|_| Spectrum::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()))
        .collect();
    let map = MipMap::new(SIDE, SIDE, texels, false, 8.0, WrapMode::Repeat);
    let lookups: Vec<_> = (0..N)
        .map(|_| {
            let st = Vec2::new(rng.uniform_f32() * 4.0, rng.uniform_f32() * 4.0);
            // Minor axis from a tenth of a texel to 64 texels of level 0.
            let minor = 0.1 * math::powf(640f32, rng.uniform_f32()) / SIDE as f32;
            let phi = 2.0 * std::f32::consts::PI * rng.uniform_f32();
            let (s, c) = math::sin_cos(phi);
            let major = Vec2::new(c, s) * minor * anisotropy;
            (st, major, Vec2::new(-s, c) * minor)
        })
        .collect();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for &(st, d0, d1) in black_box(&lookups) {
            black_box(map.lookup_ewa(st, d0, d1));
        }
    });
}
