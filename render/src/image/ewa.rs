//! pbrt-v3's EWA filter region: the ellipse a footprint covers on one MIP
//! level, its texel box, and the part of each of the box's rows that can
//! be inside it.

use farm_common::geometry::Vec2;
use farm_common::math;

/// An EWA lookup's ellipse on one level: centre `st` in texel coordinates,
/// inside where `a·ss² + b·ss·tt + c·tt² < 1`, within the texel box
/// `s` × `t`.
pub(super) struct Ellipse {
    pub(super) st: Vec2,
    pub(super) a: f32,
    pub(super) b: f32,
    pub(super) c: f32,
    pub(super) s: (i64, i64),
    pub(super) t: (i64, i64),
}

/// Largest distance from the centre, in texels, for which the row spans
/// are used: the rounding of `ss` stays below 2^-4 texel.
const SPAN_LIMIT: f64 = (1u64 << 20) as f64;

/// How far past its first column a box's last must be (9 columns) for its
/// rows to be cut to their spans: in a narrower box the span costs more
/// than the texels it passes over.
const SPAN_MIN_WIDTH: i64 = 8;

impl Ellipse {
    /// pbrt-v3's ellipse for a footprint `dst0`, `dst1` around `st`, all in
    /// one level's texel units, and its texel box.
    #[inline]
    pub(super) fn new(st: Vec2, dst0: Vec2, dst1: Vec2) -> Ellipse {
        // Ellipse coefficients.
        let mut a = dst0.y * dst0.y + dst1.y * dst1.y + 1.0;
        let mut b = -2.0 * (dst0.x * dst0.y + dst1.x * dst1.y);
        let mut c = dst0.x * dst0.x + dst1.x * dst1.x + 1.0;
        let inv_f = 1.0 / (a * c - b * b * 0.25);
        a *= inv_f;
        b *= inv_f;
        c *= inv_f;
        // Bounding box of the ellipse.
        let det = -b * b + 4.0 * a * c;
        let inv_det = 1.0 / det;
        let u_sqrt = (det * c).sqrt();
        let v_sqrt = (a * det).sqrt();
        let s0 = math::ceil(st.x - 2.0 * inv_det * u_sqrt) as i64;
        let s1 = math::floor(st.x + 2.0 * inv_det * u_sqrt) as i64;
        let t0 = math::ceil(st.y - 2.0 * inv_det * v_sqrt) as i64;
        let t1 = math::floor(st.y + 2.0 * inv_det * v_sqrt) as i64;
        Ellipse { st, a, b, c, s: (s0, s1), t: (t0, t1) }
    }

    /// Whether every column index of the box is exact as an `f32`.
    #[inline]
    pub(super) fn counted(&self) -> bool {
        self.s.0.unsigned_abs() < 1 << 24 && self.s.1.unsigned_abs() < 1 << 24
    }
}

/// The columns of each row of an [`Ellipse`]'s box that can pass the
/// loop's test `r2 < 1`: the real chord of the ellipse through the row,
/// widened by a margin on each side.
pub(super) struct Spans {
    /// The chord's centre is `x − slope·tt`.
    x: f64,
    slope: f64,
    /// The chord's half-width is `√(k0 − k1·tt²)·inv_2a + margin`.
    k0: f64,
    k1: f64,
    inv_2a: f64,
    margin: f64,
    /// The box's columns.
    lo: f64,
    hi: f64,
}

impl Spans {
    /// The spans of `e`, or `None` where they would not pay (a narrow box)
    /// or cannot be trusted (a degenerate ellipse, a box far from its
    /// centre or past 2^24).
    ///
    /// Why the texels outside a span fail the loop's `r2 < 1`: the loop
    /// evaluates `q(ss) = a·ss² + b·tt·ss + c·tt²` in `f32` at `ss`, the
    /// rounded `is − st.x` (off by at most 2^-24·W, W the box's largest
    /// |ss|, so below 2^-4 here), with an error of at most
    /// `E = 8·2^-24·(a·W² + |b|·W·H + c·H²)` (H the largest |tt|; the two
    /// products and two sums behind each term need about 4·2^-24). The
    /// exact `q − 1` is at least `a·d²` at a distance `d` outside the real
    /// chord (its product form `a(ss − r₀)(ss − r₁)`, or `a(ss − centre)²`
    /// plus something positive when the row misses the ellipse). The
    /// margin is `1/8 + √(E/a)`, and the chord is computed in `f64` with an
    /// allowance where its discriminant `b²tt² − 4a(c·tt² − 1)` nearly
    /// cancels, so a texel outside has `d > √(E/a)`: `q > 1 + E`, and the
    /// computed value is above 1.
    #[inline]
    pub(super) fn new(e: &Ellipse) -> Option<Spans> {
        let (a, b, c) = (e.a as f64, e.b as f64, e.c as f64);
        let (x, y) = (e.st.x as f64, e.st.y as f64);
        let (lo, hi) = (e.s.0 as f64, e.s.1 as f64);
        let w = (lo - x).abs().max((hi - x).abs());
        let h = (e.t.0 as f64 - y).abs().max((e.t.1 as f64 - y).abs());
        let sound = e.s.1.saturating_sub(e.s.0) >= SPAN_MIN_WIDTH
            && e.counted()
            && a > 0.0
            && (a + b.abs() + c).is_finite()
            && w <= SPAN_LIMIT
            && h <= SPAN_LIMIT;
        if !sound {
            return None;
        }
        let err = 8.0 * f64::from(f32::EPSILON) * 0.5 * (a * w * w + b.abs() * w * h + c * h * h);
        let (b2, ac4) = (b * b, 4.0 * a * c);
        let inv_2a = 0.5 / a;
        Some(Spans {
            x,
            slope: b * inv_2a,
            k0: 4.0 * a * (1.0 + 1e-12),
            k1: (ac4 - b2) - 1e-12 * (ac4 + b2),
            inv_2a,
            margin: 0.125 + (err / a).sqrt(),
            lo,
            hi,
        })
    }

    /// The columns of the row at `tt` to visit (none when the first
    /// exceeds the second).
    #[inline(always)]
    pub(super) fn row(&self, tt: f32) -> (i64, i64) {
        let tt = tt as f64;
        let centre = self.x - self.slope * tt;
        let half = (self.k0 - self.k1 * tt * tt).max(0.0).sqrt() * self.inv_2a + self.margin;
        (
            math::ceil_i64((centre - half).clamp(self.lo, self.hi + 1.0)),
            math::floor_i64((centre + half).clamp(self.lo - 1.0, self.hi)),
        )
    }
}
