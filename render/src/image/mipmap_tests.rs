//! The MIP map's tests.

use super::*;
use farm_common::rng::Rng;
use farm_common::Spectrum;
use std::cell::Cell;

thread_local! {
    /// Lookups that took one level ([`MipMap::lookup_ewa_with`]).
    pub(super) static ONE_LEVEL: Cell<usize> = const { Cell::new(0) };
}

#[test]
fn repeat_wraps_with_a_mask_as_with_a_division() {
    for n in [1usize, 2, 8, 64, 3, 12] {
        for i in -300i64..300 {
            let want = Some(i.rem_euclid(n as i64) as usize);
            assert_eq!(wrap_index(i, n, WrapMode::Repeat), want, "{i} mod {n}");
        }
    }
}

#[test]
fn constant_image_gives_constant_lookups() {
    let c = Spectrum::new(0.25, 0.5, 0.75);
    let mut rng = Rng::new(1);
    for (w, h) in [(5usize, 3usize), (8, 8), (1, 7), (16, 4)] {
        for wrap in [WrapMode::Repeat, WrapMode::Clamp] {
            for tri in [false, true] {
                let m = MipMap::new(w, h, vec![c; w * h], tri, 8.0, wrap);
                assert!(m.level_size(0).0.is_power_of_two());
                for _ in 0..200 {
                    let st =
                        Vec2::new(rng.uniform_f32() * 3.0 - 1.0, rng.uniform_f32() * 3.0 - 1.0);
                    let d0 = Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * 0.3;
                    let d1 = Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * 0.01;
                    for v in [
                        m.lookup_ewa(st, d0, d1),
                        m.lookup(st, rng.uniform_f32()),
                        m.lookup_ewa(st, Vec2::ZERO, Vec2::ZERO),
                    ] {
                        for k in 0..3 {
                            assert!((v[k] - c[k]).abs() < 1e-4, "{w}x{h} {wrap:?} {v:?}");
                        }
                    }
                }
            }
        }
    }
}

/// Visiting each row's span gives the same bits as the whole box, for
/// every wrap mode, square and oblong maps, footprints from a twentieth
/// of a texel to 64 texels with anisotropy up to 16, centres near and
/// far from the origin (up to 6.4e6 texels); then thin footprints with
/// anisotropy up to 1000 at every angle, whose coefficients nearly
/// satisfy `b² = 4ac`; and the spans are used in over a tenth of the
/// lookups. (The margins for a rounded `ss` and boxes past 2^20 texels
/// wide are not reached: `ss` is exact in every case here.)
#[test]
fn row_spans_sum_the_same_bits_as_the_whole_box() {
    let mut rng = Rng::new(23);
    let mut spanned = 0;
    let mut lookups = 0;
    for (w, h, wrap) in [
        (64usize, 64usize, WrapMode::Repeat),
        (48, 20, WrapMode::Clamp),
        (32, 128, WrapMode::Black),
    ] {
        let texels = (0..w * h)
            .map(|_| Spectrum::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()))
            .collect();
        let m = MipMap::new(w, h, texels, false, 8.0, wrap);
        for i in 0..4000 {
            let far = [1.0, 100.0, 1e4, 1e5][i % 4];
            let st = Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * far;
            let level = (rng.uniform_u32() % m.levels() as u32) as usize;
            let side = m.pyramid[level].w.max(m.pyramid[level].h) as f32;
            // The minor axis in this level's texels, then in [0, 1]²;
            // every fifth footprint thin (major axis up to 160 texels).
            let thin = i % 5 == 4;
            let (small, range, most) = if thin { (0.02, 8.0, 1000.0) } else { (0.05, 80.0, 16.0) };
            let minor = small * math::powf(range, rng.uniform_f32()) / side;
            let aniso = math::powf(most, rng.uniform_f32());
            let phi = 2.0 * std::f32::consts::PI * rng.uniform_f32();
            let (s, c) = math::sin_cos(phi);
            let d0 = Vec2::new(c, s) * minor * aniso;
            let d1 = Vec2::new(-s, c) * minor;
            let whole = m.ewa(level, st, d0, d1, false);
            let spans = m.ewa(level, st, d0, d1, true);
            for k in 0..3 {
                assert_eq!(whole[k].to_bits(), spans[k].to_bits(), "{st:?} {d0:?} {d1:?}");
            }
            spanned += usize::from(Spans::new(&m.ellipse(level, st, d0, d1)).is_some());
            lookups += 1;
        }
    }
    assert!(spanned * 10 > lookups, "{spanned} of {lookups} lookups used spans");
}

#[test]
fn lookups_at_coordinates_past_the_integers_do_not_panic() {
    // Texel boxes whose corners saturate at i64::MIN or MAX (a planar
    // mapping far from its origin), with overflow checks on in tests.
    let m = MipMap::new(4, 4, vec![0.5f32; 16], false, 8.0, WrapMode::Repeat);
    for x in [-1e19f32, 1e19, -3e38, 3e38, f32::NEG_INFINITY] {
        for d in [1e-6f32, 0.01] {
            let v = m.lookup_ewa(Vec2::new(x, 0.25), Vec2::new(d, 0.0), Vec2::new(0.0, d));
            assert!(v.is_nan() || v == 0.5 || v == 0.0, "{x} {d}: {v}");
        }
    }
}

#[test]
fn pyramid_averages_and_wraps() {
    let m = MipMap::new(2, 2, vec![0.0f32, 1.0, 2.0, 3.0], false, 8.0, WrapMode::Black);
    assert_eq!(m.levels(), 2);
    assert_eq!(m.level_size(1), (1, 1));
    assert_eq!(m.texel(1, 0, 0), 1.5);
    assert_eq!(m.texel(0, -1, 0), 0.0);
    // Bilinear at a texel centre returns the texel; a huge width returns the top level.
    assert_eq!(m.lookup(Vec2::new(0.75, 0.25), 0.0), 1.0);
    assert_eq!(m.lookup(Vec2::new(0.3, 0.3), 10.0), 1.5);
    let r = MipMap::new(2, 1, vec![1.0f32, 3.0], false, 8.0, WrapMode::Repeat);
    assert_eq!(r.texel(0, 2, 5), 1.0);
}

/// A trilinear map filters over the largest differential component
/// itself, as pbrt-v3's `MIPMap::Lookup(st, dst0, dst1)` passes it (its
/// book prints twice it), whichever component is largest and whatever
/// its sign.
#[test]
fn trilinear_filters_over_the_largest_differential_itself() {
    let mut rng = Rng::new(7);
    let texels: Vec<f32> = (0..64).map(|_| rng.uniform_f32()).collect();
    let m = MipMap::new(8, 8, texels, true, 8.0, WrapMode::Clamp);
    for _ in 0..500 {
        let st = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
        let c: [f32; 4] = std::array::from_fn(|_| (rng.uniform_f32() - 0.5) * 0.6);
        let width = c.iter().fold(0.0f32, |w, x| w.max(x.abs()));
        let got = m.lookup_ewa(st, Vec2::new(c[0], c[1]), Vec2::new(c[2], c[3]));
        assert_eq!(got.to_bits(), m.lookup(st, width).to_bits(), "{st:?} {c:?}");
    }
    // A width of 1/8 on 8 texels is level 3 − 3 = 0: level 0's bilinear
    // value (twice it would be level 1's).
    let st = Vec2::new(0.3, 0.6);
    assert_eq!(m.lookup_ewa(st, Vec2::new(0.0, -1.0 / 8.0), Vec2::ZERO), m.lookup(st, 0.0));
    assert_ne!(m.lookup(st, 0.0), m.lookup(st, 0.25));
}

/// Taking one level where the next one's weight is 0 gives the bits both
/// levels give: on maps of random texels, of texels with a −0 channel, and
/// of texels past 10²⁸ or infinite (where it must not: an infinite texel
/// times the weight 0 is NaN); magnified footprints (their level 0),
/// footprints on a whole level and others, near and far from the origin.
#[test]
fn one_level_where_the_next_weighs_nothing_gives_the_same_bits() {
    let mut rng = Rng::new(5);
    for case in 0..4 {
        let (w, h) = [(64usize, 64usize), (48, 20), (16, 16), (16, 16)][case];
        let mut texels: Vec<Spectrum> = (0..w * h)
            .map(|_| Spectrum::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()))
            .collect();
        for t in texels.iter_mut().step_by(5) {
            match case {
                1 => t.g = -0.0,
                2 => t.r = 1e29,
                3 => t.b = f32::INFINITY,
                _ => {}
            }
        }
        let wrap = [WrapMode::Repeat, WrapMode::Clamp, WrapMode::Black, WrapMode::Repeat][case];
        let m = MipMap::new(w, h, texels, false, 8.0, wrap);
        let side = w.max(h) as f32;
        let before = ONE_LEVEL.with(Cell::get);
        for i in 0..3000 {
            let far = [1.0, 30.0, 1e4][i % 3];
            let st = Vec2::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5) * far;
            // Magnified (a hundredth of a texel), a whole level's size or
            // anything between.
            let k = rng.uniform_f32();
            let minor = match i % 3 {
                0 => 0.01,
                1 => math::powf(2.0, math::floor(k * 6.0)),
                _ => math::powf(64.0, k),
            } / side;
            let (s, c) = math::sin_cos(6.3 * rng.uniform_f32());
            let stretch = 1.0 + 3.0 * rng.uniform_f32();
            let (d0, d1) = (Vec2::new(c, s) * minor * stretch, Vec2::new(-s, c) * minor);
            let one = m.lookup_ewa_with(st, d0, d1, true);
            let both = m.lookup_ewa_with(st, d0, d1, false);
            for k in 0..3 {
                let (a, b) = (one[k].to_bits(), both[k].to_bits());
                assert_eq!(a, b, "case {case}: {st:?} {d0:?} {d1:?}");
            }
        }
        let taken = ONE_LEVEL.with(Cell::get) - before;
        if case < 2 {
            // At least every magnified lookup (a third of them).
            assert!(taken >= 1000, "case {case}: {taken} lookups took one level");
        } else {
            assert_eq!(taken, 0, "case {case}: no level is tame");
        }
    }
}

/// Both levels where one could give other bits: an anisotropy clamp past
/// the gate (1e4, whose thin diagonal footprints round the ellipse's
/// determinant to zero or below on the next level, so that level's sum is
/// NaN while the first's is not), a negative one, and a first level whose
/// sum is −0 under a next level of positive texels (−0 + 0 is +0).
#[test]
fn one_level_is_not_taken_where_it_would_change_bits() {
    let mut rng = Rng::new(9);
    let side = 1024;
    let texels: Vec<Spectrum> = (0..side * side)
        .map(|_| Spectrum::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()))
        .collect();
    let same = |m: &MipMap<Spectrum>, st: Vec2, d0: Vec2, d1: Vec2| {
        let (one, both) =
            (m.lookup_ewa_with(st, d0, d1, true), m.lookup_ewa_with(st, d0, d1, false));
        for k in 0..3 {
            assert_eq!(
                one[k].to_bits(),
                both[k].to_bits(),
                "{st:?} {d0:?} {d1:?}: {one:?} {both:?}"
            );
        }
        both
    };
    let bits = |x: u32, y: u32| Vec2::new(f32::from_bits(x), f32::from_bits(y));
    let thin = MipMap::new(side, side, texels.clone(), false, 1e4, WrapMode::Repeat);
    // A review's case: minor 0.999/1024, aspect 9999; the second level's
    // determinant is −4.8e-7, its box empty.
    let (st, d0, d1) =
        (bits(1039643178, 1056765017), bits(3238080850, 3232704300), bits(974094316, 3126046911));
    assert!(same(&thin, st, d0, d1).has_nan());
    let negative = MipMap::new(side, side, texels, false, -1.0, WrapMode::Repeat);
    for i in 0..20 {
        // Magnified, thin: level 0, both levels' boxes long and narrow.
        let st = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
        let minor = 0.9 * rng.uniform_f32() / side as f32;
        let (s, c) = math::sin_cos(6.3 * rng.uniform_f32());
        let aspect = 1e3 + 9e3 * rng.uniform_f32();
        let (d0, d1) = (Vec2::new(c, s) * minor * aspect, Vec2::new(-s, c) * minor);
        same(if i % 2 == 0 { &thin } else { &negative }, st, d0, d1);
    }
    // A first level of +0 texels, a few the smallest negative float,
    // sums to −0 in a long footprint (one such texel, weights summing past
    // 2); the levels past it are made positive.
    let texels =
        (0..256).map(|i| Spectrum::new(if i % 11 == 0 { -1e-45 } else { 0.0 }, 0.25, 0.25));
    let mut m = MipMap::new(16, 16, texels.collect(), false, 8.0, WrapMode::Repeat);
    for l in m.pyramid.iter_mut().skip(1) {
        *l = Level::new(l.w, l.h, vec![Spectrum::new(0.5, 0.5, 0.5); l.w * l.h]);
    }
    let mut negative_zeros = 0;
    for _ in 0..2000 {
        let st = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
        let (s, c) = math::sin_cos(6.3 * rng.uniform_f32());
        let (d0, d1) = (Vec2::new(c, s) * 6.0 / 16.0, Vec2::new(-s, c) * 0.9 / 16.0);
        negative_zeros += usize::from(m.ewa(0, st, d0, d1, true).has_negative_zero());
        same(&m, st, d0, d1);
    }
    assert!(negative_zeros > 50, "{negative_zeros} lookups summed to -0");
}

#[test]
fn a_negative_zero_is_told_apart() {
    assert!((-0.0f32).has_negative_zero() && !0.0f32.has_negative_zero());
    assert!(Spectrum::new(0.5, -0.0, 1.0).has_negative_zero());
    assert!(!Spectrum::new(0.0, -1.0, 1.0).has_negative_zero());
    assert!(!f32::NAN.tame() && !f32::INFINITY.tame() && !2e28f32.tame() && (-1e28f32).tame());
}
