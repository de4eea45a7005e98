//! pbrt-v3's `MIPMap`: non-power-of-two images are resampled up with
//! Lanczos weights, then box-filtered into a pyramid; lookups are trilinear
//! or EWA (elliptically weighted average with a Gaussian weight table).

use super::ewa::{Ellipse, Spans};
use farm_common::geometry::Vec2;
use farm_common::math;

pub use super::texel::Texel;

/// How lookups outside [0, 1]² behave (pbrt-v3 `ImageWrap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum WrapMode {
    /// Tile the image.
    #[default]
    Repeat,
    /// Black outside.
    Black,
    /// Extend the edge texels.
    Clamp,
}

impl WrapMode {
    /// pbrt-v3's parsing of `"string wrap"`: anything unknown is repeat.
    pub fn from_name(s: &str) -> WrapMode {
        match s {
            "black" => WrapMode::Black,
            "clamp" => WrapMode::Clamp,
            _ => WrapMode::Repeat,
        }
    }
}

const WEIGHT_LUT_SIZE: usize = 128;

/// One pyramid level.
#[derive(Clone, Debug)]
struct Level<T> {
    w: usize,
    h: usize,
    texels: Vec<T>,
    /// Every texel is [`Texel::tame`].
    tame: bool,
}

impl<T: Texel> Level<T> {
    fn new(w: usize, h: usize, texels: Vec<T>) -> Self {
        let tame = texels.iter().all(|t| t.tame());
        Level { w, h, texels, tame }
    }
}

/// An image pyramid with pbrt-v3's filtered lookups.
#[derive(Clone, Debug)]
pub struct MipMap<T: Texel> {
    trilinear: bool,
    max_aniso: f32,
    wrap: WrapMode,
    pyramid: Vec<Level<T>>,
    weight_lut: [f32; WEIGHT_LUT_SIZE],
}

/// pbrt-v3's windowed sinc with τ = 2.
fn lanczos(x: f32) -> f32 {
    let tau = 2.0;
    let x = x.abs();
    if x < 1e-5 {
        return 1.0;
    }
    if x > 1.0 {
        return 0.0;
    }
    let x = x * std::f32::consts::PI;
    (math::sin(x * tau) / (x * tau)) * (math::sin(x) / x)
}

/// For each texel of the new resolution, the first source texel and four weights.
fn resample_weights(old_res: usize, new_res: usize) -> Vec<(i64, [f32; 4])> {
    let filter_width = 2.0f32;
    (0..new_res)
        .map(|i| {
            let center = (i as f32 + 0.5) * old_res as f32 / new_res as f32;
            let first = math::floor((center - filter_width) + 0.5) as i64;
            let mut w = [0.0f32; 4];
            for (j, wj) in w.iter_mut().enumerate() {
                let pos = first as f32 + j as f32 + 0.5;
                *wj = lanczos((pos - center) / filter_width);
            }
            let inv = 1.0 / (w[0] + w[1] + w[2] + w[3]);
            for wj in &mut w {
                *wj *= inv;
            }
            (first, w)
        })
        .collect()
}

fn wrap_index(i: i64, n: usize, wrap: WrapMode) -> Option<usize> {
    let n = n as i64;
    let i = match wrap {
        // The pyramid's sides are powers of two: a mask, not a division.
        WrapMode::Repeat if n & (n - 1) == 0 => i & (n - 1),
        WrapMode::Repeat => i.rem_euclid(n),
        WrapMode::Clamp => i.clamp(0, n - 1),
        WrapMode::Black => i,
    };
    (0..n).contains(&i).then_some(i as usize)
}

impl<T: Texel> MipMap<T> {
    /// Builds the pyramid for a `width × height` image (row-major, row 0 at t = 0).
    /// An empty image becomes a single black texel.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<T>,
        trilinear: bool,
        max_aniso: f32,
        wrap: WrapMode,
    ) -> MipMap<T> {
        let (mut w, mut h, mut img) = (width, height, texels);
        if w == 0 || h == 0 || img.len() < w * h {
            (w, h, img) = (1, 1, vec![T::default()]);
        }
        if !w.is_power_of_two() || !h.is_power_of_two() {
            let (w2, h2) = (w.next_power_of_two(), h.next_power_of_two());
            // Zoom in s.
            let sw = resample_weights(w, w2);
            let mut res = vec![T::default(); w2 * h2];
            for t in 0..h {
                for (s, (first, wt)) in sw.iter().enumerate() {
                    let mut acc = T::default();
                    for (j, wj) in wt.iter().enumerate() {
                        if let Some(os) = wrap_index(first + j as i64, w, wrap) {
                            acc = acc + img[t * w + os] * *wj;
                        }
                    }
                    res[t * w2 + s] = acc;
                }
            }
            // Zoom in t, clamping negative lobes away.
            let tw = resample_weights(h, h2);
            let mut column = vec![T::default(); h2];
            for s in 0..w2 {
                for (t, (first, wt)) in tw.iter().enumerate() {
                    let mut acc = T::default();
                    for (j, wj) in wt.iter().enumerate() {
                        if let Some(ot) = wrap_index(first + j as i64, h, wrap) {
                            acc = acc + res[ot * w2 + s] * *wj;
                        }
                    }
                    column[t] = acc;
                }
                for (t, c) in column.iter().enumerate() {
                    res[t * w2 + s] = c.clamp_non_negative();
                }
            }
            (w, h, img) = (w2, h2, res);
        }
        let n_levels = 1 + w.max(h).ilog2() as usize;
        let mut mip = MipMap {
            trilinear,
            max_aniso,
            wrap,
            pyramid: Vec::with_capacity(n_levels),
            weight_lut: [0.0; WEIGHT_LUT_SIZE],
        };
        mip.pyramid.push(Level::new(w, h, img));
        for i in 1..n_levels {
            let (pw, ph) = (mip.pyramid[i - 1].w, mip.pyramid[i - 1].h);
            let (sw, sh) = ((pw / 2).max(1), (ph / 2).max(1));
            let mut texels = Vec::with_capacity(sw * sh);
            for t in 0..sh as i64 {
                for s in 0..sw as i64 {
                    let l = i - 1;
                    let v = (mip.texel(l, 2 * s, 2 * t)
                        + mip.texel(l, 2 * s + 1, 2 * t)
                        + mip.texel(l, 2 * s, 2 * t + 1)
                        + mip.texel(l, 2 * s + 1, 2 * t + 1))
                        * 0.25;
                    texels.push(v);
                }
            }
            mip.pyramid.push(Level::new(sw, sh, texels));
        }
        for (i, w) in mip.weight_lut.iter_mut().enumerate() {
            let alpha = 2.0f32;
            let r2 = i as f32 / (WEIGHT_LUT_SIZE - 1) as f32;
            *w = math::exp(-alpha * r2) - math::exp(-alpha);
        }
        mip
    }

    /// Number of pyramid levels.
    pub fn levels(&self) -> usize {
        self.pyramid.len()
    }

    /// Resolution of level `i` (level 0 is the power-of-two base).
    pub fn level_size(&self, i: usize) -> (usize, usize) {
        self.pyramid.get(i).map_or((0, 0), |l| (l.w, l.h))
    }

    /// The texel at integer coordinates, after the wrap mode.
    pub fn texel(&self, level: usize, s: i64, t: i64) -> T {
        let l = &self.pyramid[level];
        match (wrap_index(s, l.w, self.wrap), wrap_index(t, l.h, self.wrap)) {
            (Some(s), Some(t)) => l.texels[t * l.w + s],
            _ => T::default(),
        }
    }

    /// Bilinear interpolation on one level.
    fn triangle(&self, level: usize, st: Vec2) -> T {
        let level = level.min(self.levels() - 1);
        let l = &self.pyramid[level];
        let s = st.x * l.w as f32 - 0.5;
        let t = st.y * l.h as f32 - 0.5;
        let (s0, t0) = (math::floor(s), math::floor(t));
        let (ds, dt) = (s - s0, t - t0);
        let (s0, t0) = (s0 as i64, t0 as i64);
        self.texel(level, s0, t0) * ((1.0 - ds) * (1.0 - dt))
            + self.texel(level, s0, t0 + 1) * ((1.0 - ds) * dt)
            + self.texel(level, s0 + 1, t0) * (ds * (1.0 - dt))
            + self.texel(level, s0 + 1, t0 + 1) * (ds * dt)
    }

    /// Trilinear lookup for a square filter of `width` in [0, 1] texture space.
    pub fn lookup(&self, st: Vec2, width: f32) -> T {
        let n = self.levels();
        let level = (n - 1) as f32 + math::log2(width.max(1e-8));
        if level < 0.0 {
            self.triangle(0, st)
        } else if level >= (n - 1) as f32 {
            self.texel(n - 1, 0, 0)
        } else {
            let il = math::floor(level);
            let delta = level - il;
            let il = il as usize;
            self.triangle(il, st) * (1.0 - delta) + self.triangle(il + 1, st) * delta
        }
    }

    /// Filtered lookup for the footprint spanned by the differentials
    /// `dst0`, `dst1` (pbrt-v3 `Lookup(st, dstdx, dstdy)`): trilinear when
    /// the map was built with `trilinear`, EWA otherwise.
    pub fn lookup_ewa(&self, st: Vec2, dst0: Vec2, dst1: Vec2) -> T {
        self.lookup_ewa_with(st, dst0, dst1, true)
    }

    /// [`MipMap::lookup_ewa`], taking one level where that gives the same
    /// bits if `one_level` (the tests compare both ways).
    fn lookup_ewa_with(&self, st: Vec2, dst0: Vec2, dst1: Vec2, one_level: bool) -> T {
        let (mut dst0, mut dst1) = (dst0, dst1);
        if self.trilinear {
            let width = dst0.x.abs().max(dst0.y.abs()).max(dst1.x.abs().max(dst1.y.abs()));
            // pbrt-v3's code passes the width itself (the book prints 2 × it).
            return self.lookup(st, width);
        }
        if dst0.length_squared() < dst1.length_squared() {
            std::mem::swap(&mut dst0, &mut dst1);
        }
        let major = dst0.length();
        let mut minor = dst1.length();
        if minor * self.max_aniso < major && minor > 0.0 {
            let scale = major / (minor * self.max_aniso);
            dst1 *= scale;
            minor *= scale;
        }
        if minor == 0.0 {
            return self.triangle(0, st);
        }
        let lod = ((self.levels() as f32 - 1.0) + math::log2(minor)).max(0.0);
        let il = math::floor(lod);
        let d = lod - il;
        let il = il as usize;
        let near = self.ewa(il, st, dst0, dst1, true) * (1.0 - d);
        if one_level && d == 0.0 && self.next_is_finite(il, st) && !near.has_negative_zero() {
            #[cfg(test)]
            tests::ONE_LEVEL.with(|n| n.set(n.get() + 1));
            // The next level's term is a finite value times 0: ±0, which
            // adding leaves `near` as it is. A magnified texture (two
            // thirds of spheres-differentials' lookups) takes only one
            // level.
            return near;
        }
        near + self.ewa(il + 1, st, dst0, dst1, true) * d
    }

    /// Whether [`MipMap::ewa`] on the level after `il` is sure to be
    /// finite at `st`, when the lookup's level is `il` exactly. There the
    /// footprint's minor axis is at most half a texel, and its major at
    /// most `max_aniso` times that (32 texels at most, as the gate below
    /// has it). Its ellipse holds the unit disk around the centre (its
    /// matrix is the inverse of the identity plus a positive semi-definite
    /// footprint): `Ellipse::new`'s `a·c − b²/4` cancels, but for such a
    /// thin footprint its rounding is a few 10⁻⁵ of it, no more. So the
    /// texel nearest the centre passes the test, with a margin while
    /// coordinates are below 2²⁰ texels, and the weights' sum is positive.
    /// The box holds a few thousand texels at most, whose weighted sum
    /// stays finite if they are tame. (A larger or non-positive `max_aniso`
    /// from a scene takes both levels: past a few thousand the ellipse's
    /// determinant can round to zero or below.)
    fn next_is_finite(&self, il: usize, st: Vec2) -> bool {
        const FAR: f32 = (1 << 20) as f32;
        let (l0, next) = (&self.pyramid[0], self.pyramid.get(il + 1));
        next.or(self.pyramid.last()).is_some_and(|l| l.tame)
            && self.max_aniso > 0.0
            && self.max_aniso <= 64.0
            && st.x.abs() * (l0.w as f32) < FAR
            && st.y.abs() * (l0.h as f32) < FAR
    }

    /// pbrt-v3's `EWA` on one level; `spans` visits each row's span only
    /// (the same bits; off in tests, to compare with the whole box).
    fn ewa(&self, level: usize, st: Vec2, dst0: Vec2, dst1: Vec2, spans: bool) -> T {
        if level >= self.levels() {
            return self.texel(self.levels() - 1, 0, 0);
        }
        let l = &self.pyramid[level];
        let e = self.ellipse(level, st, dst0, dst1);
        // A repeating power-of-two level (every level of a repeating map)
        // wraps a column with a mask alone; the others as `texel` does.
        let (sum, sum_wts) = if self.wrap == WrapMode::Repeat && l.w.is_power_of_two() {
            let mask = l.w - 1;
            self.ewa_sum(l, &e, spans, |is| Some(is as usize & mask))
        } else {
            self.ewa_sum(l, &e, spans, |is| wrap_index(is, l.w, self.wrap))
        };
        sum * (1.0 / sum_wts)
    }

    /// The ellipse of a footprint on level `level`, in its texel units.
    #[inline]
    fn ellipse(&self, level: usize, st: Vec2, dst0: Vec2, dst1: Vec2) -> Ellipse {
        let l = &self.pyramid[level];
        let (fw, fh) = (l.w as f32, l.h as f32);
        Ellipse::new(
            Vec2::new(st.x * fw - 0.5, st.y * fh - 0.5),
            Vec2::new(dst0.x * fw, dst0.y * fh),
            Vec2::new(dst1.x * fw, dst1.y * fh),
        )
    }

    /// The weighted sum of the texels inside `e` and the sum of their
    /// weights (pbrt-v3's loop, in its order), `column` wrapping a column.
    /// Each row of a wide box visits only its [`Spans`]: the rest of the
    /// box fails the test `r2 < 1` anyway, so the sums keep their bits.
    #[inline(always)]
    fn ewa_sum(
        &self,
        l: &Level<T>,
        e: &Ellipse,
        spans: bool,
        column: impl Fn(i64) -> Option<usize>,
    ) -> (T, f32) {
        let (st, a, b, c) = (e.st, e.a, e.b, e.c);
        let mut sum = T::default();
        let mut sum_wts = 0.0f32;
        let counted = e.counted();
        let spans = if spans { Spans::new(e) } else { None };
        for it in e.t.0..=e.t.1 {
            let tt = it as f32 - st.y;
            // The row's wrapped index, once a row (`texel`'s, inlined).
            let row = wrap_index(it, l.h, self.wrap);
            let (s0, s1) = spans.as_ref().map_or(e.s, |sp| sp.row(tt));
            // `is as f32`, counted in floats where that is exact (integers
            // below 2^24): the conversion from an integer writes only the
            // low lane of its register, so it waited for the last
            // iteration's use of that register, which made the texel and
            // weight loads one chain.
            let mut is_f = s0 as f32;
            for is in s0..=s1 {
                let ss = if counted { is_f } else { is as f32 } - st.x;
                is_f += 1.0;
                let r2 = a * ss * ss + b * ss * tt + c * tt * tt;
                if r2 < 1.0 {
                    // `as usize` of the product, saturating at 0, as a
                    // 32-bit conversion: the product is below 128 here.
                    let index = ((r2 * WEIGHT_LUT_SIZE as f32) as i32)
                        .clamp(0, WEIGHT_LUT_SIZE as i32 - 1)
                        as usize;
                    let weight = self.weight_lut[index];
                    let texel = match (row, column(is)) {
                        (Some(t), Some(s)) => l.texels[t * l.w + s],
                        _ => T::default(),
                    };
                    sum = sum + texel * weight;
                    sum_wts += weight;
                }
            }
        }
        (sum, sum_wts)
    }
}

#[cfg(test)]
#[path = "mipmap_tests.rs"]
mod tests;
