//! Fireflies: pixels whose value rests on one rare, bright sample. The
//! halves cannot measure their error: it is relative to the pixel's true
//! value, which such a pixel's own value overstates many times, so the
//! estimate divides by too much. (On veach-mis, pixels brighter than the
//! reference hold 97% of the true error at 16 spp, and the estimate sees
//! 3% of it.)
//!
//! A firefly here is a pixel whose brighter half is more than
//! [`apart`] times its darker half, whose value is more than as many times
//! the median of its eight neighbours, and which is brighter than all of
//! them but one (another firefly). The neighbour tests tell it from a
//! pixel on the edge of a bright light at a few samples per pixel, whose
//! halves differ as much but which is no brighter than the light beside
//! it, even where most of its neighbours missed the light too.
//!
//! [`Fireflies::rel_mse`] is the estimate with each firefly's error
//! measured against its darker half instead of its value: what the error
//! comes to if the darker half is near the pixel's true value, as it is
//! for a rare sample. When a render has at least [`MIN_PIXELS`] fireflies
//! and counting them so makes the estimate more than [`MATERIAL`] times
//! what it is, the estimate is a lower bound; when they add less, it
//! already holds what they could add, to within the 2× it claims.

use super::{pixel_error_against, Against};
use farm_common::film::{HalfImages, Pixel};

/// How many times its darker half a pixel's brighter half must be, and
/// its value its neighbours' median, for it to count as a firefly, when
/// the smaller half holds `samples` samples: 20 / `samples`, at least 4.
///
/// The fewer samples a half holds, the further apart plain noise puts the
/// halves. Measured against pbrt-v3's references (halves of one sequence,
/// 32 samples each at 64 spp, 8 at 16): at 4 in both tests, veach-mis at
/// 64 spp had hundreds of fireflies holding about half its true error,
/// where 10 found 13 holding 4%; cornell-box and killeroo-simple from 16
/// spp had at most one. At 4 spp (halves of 2), 4 took plain noise in most
/// scenes for fireflies.
pub fn apart(samples: f64) -> f64 {
    (20.0 / samples.max(1.0)).max(4.0)
}

/// The fewest fireflies a render reports: a lone one is usually the corner
/// of a light.
pub const MIN_PIXELS: usize = 10;
/// How many times the estimate the fireflies' count must make it for the
/// render to report them.
pub const MATERIAL: f64 = 2.0;

/// What a render's fireflies do to its estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Fireflies {
    /// How many pixels are fireflies.
    pub pixels: usize,
    /// The estimate with each firefly's error measured against its darker
    /// half: an upper value of the render's relMSE.
    pub rel_mse: f64,
    /// The brightest firefly (image coordinates).
    pub brightest: (u32, u32),
}

/// A pixel's value (the mean of its channels) and its halves'.
fn levels(p: &Pixel, scale: f64) -> Option<(f64, f64, f64)> {
    let w = f64::from(p.weight);
    let w_b = f64::from(p.second_weight);
    let w_a = w - w_b;
    if w == 0.0 || w_a == 0.0 || w_b == 0.0 {
        return None;
    }
    let mean = |v: [f32; 3]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / 3.0;
    let all = mean(p.contrib);
    let second = mean(p.second_contrib);
    let full = (all / w).max(0.0) * scale;
    let a = ((all - second) / w_a).max(0.0) * scale;
    let b = (second / w_b).max(0.0) * scale;
    Some((full, a.min(b), a.max(b)))
}

/// The fireflies of a `width` × `height` film whose pixels (row-major) are
/// `pixel(i)`, and whose estimate sums to `sum` over `counted` pixels with
/// `halves` at `spp` samples per pixel; `None` when there are fewer than
/// [`MIN_PIXELS`] or they do not matter ([`MATERIAL`]).
pub fn find(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    (halves, spp): (HalfImages, u32),
    (sum, counted): (f64, usize),
) -> Option<Fireflies> {
    let scale = f64::from(scale);
    let n = width * height;
    let value: Vec<f64> = (0..n).map(|i| levels(&pixel(i), scale).map_or(0.0, |l| l.0)).collect();
    let (mut pixels, mut extra, mut brightest) = (0usize, 0.0f64, (0.0f64, 0usize));
    let mut around = Vec::with_capacity(8);
    for i in 0..n {
        let p = pixel(i);
        let Some((full, dark, bright)) = levels(&p, scale) else { continue };
        let smaller =
            f64::from(p.second_weight.min(p.weight - p.second_weight)) / f64::from(p.weight);
        let apart = apart(f64::from(spp) * smaller);
        if bright <= apart * (dark + 0.01) {
            continue;
        }
        let (x, y) = (i % width, i / width);
        around.clear();
        for ny in y.saturating_sub(1)..(y + 2).min(height) {
            for nx in x.saturating_sub(1)..(x + 2).min(width) {
                if (nx, ny) != (x, y) {
                    around.push(value[ny * width + nx]);
                }
            }
        }
        around.sort_by(f64::total_cmp);
        let median = around.get(around.len() / 2).copied().unwrap_or(0.0);
        let second = around.len().checked_sub(2).map_or(0.0, |j| around[j]);
        if full <= apart * (median + 0.01) || full <= second {
            continue;
        }
        let plain = pixel_error_against(&p, scale as f32, halves, Against::Value);
        let dark = pixel_error_against(&p, scale as f32, halves, Against::DarkerHalf);
        if let (Some(plain), Some(dark)) = (plain, dark) {
            pixels += 1;
            extra += dark - plain;
            if full > brightest.0 {
                brightest = (full, i);
            }
        }
    }
    let upper = (sum + extra) / counted.max(1) as f64;
    let material = upper > MATERIAL * sum / counted.max(1) as f64;
    (pixels >= MIN_PIXELS && counted > 0 && material).then(|| Fireflies {
        pixels,
        rel_mse: upper,
        brightest: ((brightest.1 % width) as u32, (brightest.1 / width) as u32),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::film::FilmTile;
    use farm_common::geometry::{Bounds2i, Point2i};
    use farm_common::Spectrum;

    /// A 40 × 30 film of 0.1 everywhere, 8 samples a pixel, where `hot`
    /// pixels got one sample of `spike` in their second half, and the
    /// pixels from row `edge` on are a light of 50.
    fn film(hot: &[(i32, i32)], spike: f32, edge: i32) -> FilmTile {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 30));
        let mut t = FilmTile::new(b);
        for p in b.iter() {
            for i in 0..8 {
                let mut v = if p.y >= edge { 50.0 } else { 0.1 };
                if i == 7 && hot.contains(&(p.x, p.y)) {
                    v = spike;
                }
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 4);
            }
        }
        t
    }

    /// The estimate's sum and count over `t`.
    fn estimate(t: &FilmTile) -> (f64, usize) {
        let (mut sum, mut counted) = (0.0, 0);
        for p in &t.pixels {
            if let Some(e) = pixel_error_against(p, 1.0, HalfImages::Independent, Against::Value) {
                sum += e;
                counted += 1;
            }
        }
        (sum, counted)
    }

    fn run(t: &FilmTile, spp: u32) -> Option<Fireflies> {
        let (sum, counted) = estimate(t);
        find((40, 30), |i| t.pixels[i], 1.0, (HalfImages::Independent, spp), (sum, counted))
    }

    #[test]
    fn rare_bright_samples_make_the_estimate_a_lower_bound() {
        let hot: Vec<(i32, i32)> = (0..12).map(|k| (3 * k + 1, 5 + k % 3 * 7)).collect();
        let t = film(&hot, 200.0, 30);
        let f = run(&t, 8).expect("twelve fireflies are reported");
        assert_eq!(f.pixels, 12);
        // Each firefly's value is 25 against a true 0.1: relMSE about 3·10⁴
        // each, 300 over the image; the upper value is of that order.
        let truth = 12.0 * (25.0f64 - 0.1).powi(2) / (0.01 + 0.01) / 1200.0;
        assert!(f.rel_mse > truth / 4.0 && f.rel_mse < truth * 4.0, "{} vs {truth}", f.rel_mse);
        assert!(hot.contains(&(f.brightest.0 as i32, f.brightest.1 as i32)));
    }

    #[test]
    fn a_few_fireflies_or_a_lights_edge_are_not_reported() {
        let few: Vec<(i32, i32)> = (0..MIN_PIXELS as i32 - 1).map(|k| (2 * k, 3)).collect();
        assert_eq!(run(&film(&few, 200.0, 30), 8), None);
        // Pixels on a light's edge whose halves differ by more than
        // `apart`: as bright as their neighbours in the light.
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 30));
        let mut t = FilmTile::new(b);
        for p in b.iter() {
            for i in 0..4 {
                let lit = p.y > 15 || (p.y == 15 && i >= 2);
                let v = if lit { 50.0 } else { 0.0 };
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 2);
            }
        }
        assert_eq!(run(&t, 4), None);
        // A light's edge where most pixels missed it: the pixels that hit
        // it have mostly dark neighbours, but the light beside them is
        // brighter still.
        let mut t = FilmTile::new(b);
        for p in b.iter() {
            for i in 0..4 {
                let lit = p.y > 15 || (p.y == 15 && p.x % 3 == 0 && i >= 2);
                let v = if lit { 50.0 } else { 0.0 };
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 2);
            }
        }
        assert_eq!(run(&t, 4), None);
    }

    #[test]
    fn fireflies_that_add_little_to_the_estimate_are_not_reported() {
        let hot: Vec<(i32, i32)> = (0..12).map(|k| (3 * k + 1, 5 + k % 3 * 7)).collect();
        let t = film(&hot, 200.0, 30);
        let (sum, counted) = estimate(&t);
        let f = run(&t, 8).expect("alone, they are most of the error");
        // The rest of the image as noisy as the fireflies at their worst.
        let noisy = f.rel_mse * counted as f64;
        let halves = (HalfImages::Independent, 8);
        assert!(find((40, 30), |i| t.pixels[i], 1.0, halves, (sum + noisy, counted)).is_none());
    }

    #[test]
    fn halves_of_few_samples_must_be_further_apart() {
        // Twelve pixels of 0.1 whose second half is 1: ten times the first
        // half, 5.5 times their neighbours.
        let hot: Vec<(i32, i32)> = (0..12).map(|k| (3 * k + 1, 5 + k % 3 * 7)).collect();
        let film = |spp: i32| {
            let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 30));
            let mut t = FilmTile::new(b);
            for p in b.iter() {
                for i in 0..spp {
                    let second = i >= spp / 2;
                    let v = if second && hot.contains(&(p.x, p.y)) { 1.0 } else { 0.1 };
                    t.add(p, Spectrum::new(v, v, v), 1.0, second);
                }
            }
            t
        };
        // Halves of two samples each are that far apart by plain noise.
        assert_eq!(run(&film(4), 4), None);
        // Halves of eight are not.
        assert_eq!(run(&film(16), 16).map(|f| f.pixels), Some(12));
        assert_eq!(apart(2.0), 10.0);
        assert_eq!(apart(8.0), 4.0);
    }
}
