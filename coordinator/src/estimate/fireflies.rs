//! Pixels whose error the halves cannot measure: fireflies and the edges
//! of small lights that few samples found.
//!
//! A **firefly** is a pixel whose value rests on one rare, bright sample.
//! Its error is relative to the pixel's true value, which such a pixel's
//! own value overstates many times, so the estimate divides by too much.
//! (On veach-mis, pixels brighter than the reference hold 97% of the true
//! error at 16 spp, and the estimate sees 3% of it.) Here a firefly is a
//! pixel whose brighter half is more than [`apart`] times its darker half,
//! whose value is more than as many times the median of its eight
//! neighbours, and which is brighter than all of them but one (another
//! firefly). Its error is counted against its darker half instead of its
//! value: what the error comes to if the darker half is near the pixel's
//! true value, as it is for a rare sample.
//!
//! An **edge** pixel's halves are as far apart, but a light beside it is
//! brighter: the pixel lies on the edge of a light that covers a little of
//! it, and one of its few samples found the light. At a few samples per
//! pixel, along an edge that covers each pixel by a few percent, most
//! pixels miss the light (their halves agree, so the estimate counts no
//! error there, though the light's share of them is missing), and those
//! that hit it are several times their true value (so the estimate
//! divides by too much). On a room lit by small ceiling lights at 8 spp,
//! such pixels held nearly all the true error, and the estimate saw a
//! fifth of it. Along the edge, the mean of a run of pixels is near their
//! true level: the run is the pixel and two neighbours each way, across
//! the row or down the column, whichever is more even (the edge's own
//! direction). An edge pixel's error is counted against that level, and
//! each pixel of the run far below it (one that missed the light) gets
//! the error of its difference from the level.
//!
//! [`Fireflies::rel_mse`] is the estimate with those errors counted: the
//! upper value a render reports beside its lower bound and decides its
//! passes by. It is not a bound: it counts what the samples show, and
//! where a light was found by few samples or none, more is missing (on
//! veach-mis at 64 spp the true error is 1.1 to 2.3 times it). When
//! counting them makes the estimate more than [`MATERIAL`] times what it
//! is, the estimate is a lower bound; when they add less, it already
//! holds what they could add, to within the 2× it claims. (Fewer than
//! [`MIN_PIXELS`] fireflies are counted as edge pixels: a lone one is
//! usually the corner of a light.)

use super::{counted_error, each, half_weights, pixel_error_against, Against, EPSILON, LANES};
use farm_common::film::{HalfImages, Pixel};
use std::collections::btree_map::{BTreeMap, Entry};

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

/// The fewest fireflies a render counts as fireflies (fewer are counted as
/// edge pixels): a lone one is usually the corner of a light.
pub const MIN_PIXELS: usize = 10;
/// How many times the estimate the fireflies' count must make it for the
/// render to report them.
pub const MATERIAL: f64 = 2.0;

/// What a render's fireflies and edge pixels do to its estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Fireflies {
    /// How many pixels are fireflies or edge pixels.
    pub pixels: usize,
    /// The estimate with their errors counted as the module documentation
    /// says: the render's upper value (not a bound; see the module
    /// documentation).
    pub rel_mse: f64,
    /// The brightest of them (image coordinates).
    pub brightest: (u32, u32),
}

/// A pixel's value (the mean of its channels) and its halves'.
pub(super) fn levels(p: &Pixel, scale: f64) -> Option<(f64, f64, f64)> {
    let (w, w_a, w_b) = half_weights(p)?;
    let all = channels(p.contrib);
    let second = channels(p.second_contrib);
    let full = (all * (1.0 / (3.0 * w))).max(0.0) * scale;
    let a = ((all - second) * (1.0 / (3.0 * w_a))).max(0.0) * scale;
    let b = (second * (1.0 / (3.0 * w_b))).max(0.0) * scale;
    Some((full, a.min(b), a.max(b)))
}

/// The sum of a pixel's three channels, whose mean is its value: the
/// division by 3 is folded into the one by its weight.
#[inline(always)]
fn channels(v: [f32; 3]) -> f64 {
    v.iter().map(|&x| f64::from(x)).sum::<f64>()
}

/// A pixel's value (the mean of its channels), or `None` where a half has
/// no samples.
fn value(p: &Pixel, scale: f32) -> Option<f64> {
    levels(p, f64::from(scale)).map(|l| l.0)
}

/// How far each way along an edge the run of pixels whose mean is an
/// edge pixel's level reaches.
const RUN: usize = 2;

/// The pixels of a film whose halves are too far apart for their
/// difference to measure their error: the candidates for fireflies and
/// edge pixels, before [`find`] weighs them.
///
/// It holds no per-pixel buffer: a pixel's value is worked out again from
/// its sums where it is needed, since only the suspects' neighbours need it.
#[derive(Clone, Debug, PartialEq)]
pub struct Suspects {
    /// The pixels that pass the firefly test (row-major order): their
    /// error is counted against their own value in the estimate, not
    /// against their neighbourhood's level (`levelled_errors`), which a
    /// lone bright pixel would set.
    pub fireflies: Vec<usize>,
    /// The others whose halves are as far apart (row-major order).
    pub edges: Vec<usize>,
}

/// Whether each of `LANES` pixels has samples in both halves whose values
/// lie further apart than [`apart`] allows: the first test of
/// [`suspects`], each line the same operation on every pixel, in the order
/// [`levels`] and that test do them.
#[inline(always)]
fn far_apart(p: &[Pixel; LANES], scale: f64, spp: f64) -> [bool; LANES] {
    let w = each(|k| f64::from(p[k].weight));
    let w_b = each(|k| f64::from(p[k].second_weight));
    let w_a = each(|k| w[k] - w_b[k]);
    let all = each(|k| channels(p[k].contrib));
    let second = each(|k| channels(p[k].second_contrib));
    let a = each(|k| ((all[k] - second[k]) * (1.0 / (3.0 * w_a[k]))).max(0.0) * scale);
    let b = each(|k| (second[k] * (1.0 / (3.0 * w_b[k]))).max(0.0) * scale);
    let smaller =
        each(|k| f64::from(p[k].second_weight.min(p[k].weight - p[k].second_weight)) / w[k]);
    let apart = each(|k| apart(spp * smaller[k]));
    std::array::from_fn(|k| {
        let (dark, bright) = (a[k].min(b[k]), a[k].max(b[k]));
        // A NaN is not close: a suspect, as one pixel at a time had it.
        let close = bright <= apart[k] * (dark + 0.01);
        half_weights(&p[k]).is_some() && !close
    })
}

/// The [`Suspects`] of a `width` × `height` film whose pixels (row-major)
/// are `pixel(i)`, at `spp` samples per pixel.
pub fn suspects(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    spp: u32,
) -> Suspects {
    let n = width * height;
    let (mut fireflies, mut edges) = (Vec::new(), Vec::new());
    let mut around = Vec::with_capacity(8);
    // Pixels are tested [`LANES`] at a time (the last ones again at the
    // film's end), and only the few that are far apart looked at further.
    let mut first = 0;
    while first < n {
        let mut pixels = [Pixel::default(); LANES];
        for (k, p) in pixels.iter_mut().enumerate() {
            *p = pixel((first + k).min(n - 1));
        }
        let far = far_apart(&pixels, f64::from(scale), f64::from(spp));
        for (k, &far) in far.iter().enumerate() {
            let i = first + k;
            if !far || i >= n {
                continue;
            }
            match stands_out(i, (width, height), &pixel, scale, spp, &mut around) {
                Some(true) => fireflies.push(i),
                Some(false) => edges.push(i),
                None => {}
            }
        }
        first += LANES;
    }
    Suspects { fireflies, edges }
}

/// Whether suspect `i`, whose halves lie far apart, stands out of its 3 × 3
/// neighbourhood as a firefly does (`Some(true)`) or not, as an edge pixel
/// (`Some(false)`); `None` where a half has no samples. `around` is room
/// for its neighbours' values.
pub(super) fn stands_out(
    i: usize,
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    spp: u32,
    around: &mut Vec<f64>,
) -> Option<bool> {
    let p = pixel(i);
    let (full, _, _) = levels(&p, f64::from(scale))?;
    let smaller = f64::from(p.second_weight.min(p.weight - p.second_weight)) / f64::from(p.weight);
    let apart = apart(f64::from(spp) * smaller);
    let (x, y) = (i % width, i / width);
    around.clear();
    for ny in y.saturating_sub(1)..(y + 2).min(height) {
        for nx in x.saturating_sub(1)..(x + 2).min(width) {
            if (nx, ny) != (x, y) {
                around.push(value(&pixel(ny * width + nx), scale).unwrap_or(0.0));
            }
        }
    }
    around.sort_by(f64::total_cmp);
    let median = around.get(around.len() / 2).copied().unwrap_or(0.0);
    let second = around.len().checked_sub(2).map_or(0.0, |j| around[j]);
    Some(full > apart * (median + 0.01) && full > second)
}

/// What the [`Suspects`] of a `width` × `height` film whose pixels
/// (row-major) are `pixel(i)`, with `halves`, do to its estimate, which
/// counts `errors[i]` for pixel `i` (NaN: not counted), whose sum and
/// count the caller passes beside them (worked out once, in order);
/// `None` when counting their error does not make the estimate more than
/// [`MATERIAL`] times what it is.
pub fn find(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    halves: HalfImages,
    Suspects { mut fireflies, mut edges }: Suspects,
    errors: &[f64],
    (sum, counted): (f64, usize),
) -> Option<Fireflies> {
    let sampled = |j: usize| value(&pixel(j), scale);
    let value = |j: usize| sampled(j).unwrap_or(0.0);
    if fireflies.len() < MIN_PIXELS {
        edges.append(&mut fireflies);
        edges.sort_unstable();
    }
    // Each counted pixel's error in the estimate and as counted here (a
    // BTreeMap, so the sum's order, and so its bits, never vary).
    let mut counted_as: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    let mut count = |i: usize, e: f64| {
        let entry = match counted_as.entry(i) {
            Entry::Occupied(o) => Some(o.into_mut()),
            Entry::Vacant(v) => counted_error(errors[i]).map(|plain| v.insert((plain, plain))),
        };
        if let Some((_, c)) = entry {
            *c = c.max(e);
        }
    };
    for &i in &fireflies {
        if let Some(e) = pixel_error_against(&pixel(i), scale, halves, Against::DarkerHalf) {
            count(i, e);
        }
    }
    let rgb = |i: usize| pixel(i).resolve(scale).map(f64::from);
    for &i in &edges {
        let run = edge_run(i, (width, height), sampled);
        let mut lev = rgb(i);
        for &j in &run {
            let c = rgb(j);
            (0..3).for_each(|k| lev[k] += c[k]);
        }
        let lev = lev.map(|v| v / (run.len() + 1) as f64);
        if let Some(e) = pixel_error_against(&pixel(i), scale, halves, Against::Level(lev)) {
            count(i, e);
        }
        let mean = lev.iter().sum::<f64>() / 3.0;
        for &j in run.iter().filter(|&&j| value(j) < 0.5 * mean) {
            let c = rgb(j);
            let e = (0..3).map(|k| (lev[k] - c[k]).powi(2) / (lev[k] * lev[k] + EPSILON));
            count(j, e.sum::<f64>() / 3.0);
        }
    }
    let extra: f64 = counted_as.values().map(|&(plain, e)| e - plain).sum();
    let upper = (sum + extra) / counted.max(1) as f64;
    let material = upper > MATERIAL * sum / counted.max(1) as f64;
    let brightest = fireflies
        .iter()
        .chain(&edges)
        .copied()
        .max_by(|&a, &b| value(a).total_cmp(&value(b)).then(b.cmp(&a)));
    (counted > 0 && material).then(|| Fireflies {
        pixels: fireflies.len() + edges.len(),
        rel_mse: upper,
        brightest: brightest.map_or((0, 0), |i| ((i % width) as u32, (i / width) as u32)),
    })
}

/// The pixels beside edge pixel `i` along its edge: up to [`RUN`] each way
/// across its row or down its column, whichever have the smaller variance
/// of `value` (`None` where a pixel has no samples, and is left out).
fn edge_run(
    i: usize,
    (width, height): (usize, usize),
    value: impl Fn(usize) -> Option<f64>,
) -> Vec<usize> {
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    let along = |dx: isize, dy: isize| -> Vec<usize> {
        (1..=RUN as isize)
            .flat_map(|k| [-k, k])
            .map(|k| (x + k * dx, y + k * dy))
            .filter(|&(nx, ny)| nx >= 0 && ny >= 0 && nx < width as isize && ny < height as isize)
            .map(|(nx, ny)| ny as usize * width + nx as usize)
            .filter(|&j| value(j).is_some())
            .collect()
    };
    let variance = |run: &[usize]| {
        if run.is_empty() {
            return f64::INFINITY;
        }
        let v = |&j: &usize| value(j).unwrap_or(0.0);
        let mean = run.iter().map(v).sum::<f64>() / run.len() as f64;
        run.iter().map(|j| (v(j) - mean).powi(2)).sum::<f64>() / run.len() as f64
    };
    let (row, column) = (along(1, 0), along(0, 1));
    if variance(&row) <= variance(&column) {
        row
    } else {
        column
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::{levelled_errors, sum_counted};
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

    const SIZE: (usize, usize) = (40, 30);

    /// The suspects of `t` at `spp`, and each pixel's error in its estimate.
    fn errors(t: &FilmTile, spp: u32) -> (Suspects, Vec<f64>) {
        let s = suspects(SIZE, |i| t.pixels[i], 1.0, spp);
        let e = levelled_errors(SIZE, |i| t.pixels[i], 1.0, HalfImages::Independent, &s.fireflies);
        (s, e)
    }

    /// The estimate's sum and count over `t`.
    fn estimate(t: &FilmTile, spp: u32) -> (f64, usize) {
        sum_counted(&errors(t, spp).1)
    }

    fn run(t: &FilmTile, spp: u32) -> Option<Fireflies> {
        let (s, e) = errors(t, spp);
        find(SIZE, |i| t.pixels[i], 1.0, HalfImages::Independent, s, &e, sum_counted(&e))
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
    fn a_few_fireflies_count_as_edge_pixels() {
        // Nine rare spikes of 200 (each pixel 25 against a true 0.1): too
        // few to be fireflies, but counted as edge pixels, they still hold
        // nearly all the error.
        let few: Vec<(i32, i32)> = (0..MIN_PIXELS as i32 - 1).map(|k| (4 * k + 2, 3)).collect();
        let t = film(&few, 200.0, 30);
        let (sum, counted) = estimate(&t, 8);
        let f = run(&t, 8).expect("reported");
        assert_eq!(f.pixels, few.len());
        assert!(f.rel_mse > 10.0 * sum / counted as f64, "{} vs {}", f.rel_mse, sum);
    }

    #[test]
    fn a_lights_edge_that_every_pixel_found_is_not_reported() {
        // Pixels on a light's edge whose halves differ by more than
        // `apart`, all alike along the edge: their value is their level.
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
    }

    #[test]
    fn a_small_lights_edge_that_most_pixels_missed_is_reported_near_its_true_error() {
        // A light of 50 over rows 16 on covers row 15 by 1/16: its true
        // level there is 50/16. At 4 spp one pixel in four found the light
        // with one sample (worth 12.5, four times the truth); the others
        // found none (0, missing the light's share). The halves see only
        // the hits, measured against their too-bright value.
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 30));
        let mut t = FilmTile::new(b);
        let hit = |p: Point2i, i: i32| p.y > 15 || (p.y == 15 && p.x % 4 == 1 && i == 3);
        for p in b.iter() {
            for i in 0..4 {
                let v = if hit(p, i) { 50.0 } else { 0.0 };
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 2);
            }
        }
        let truth_level = 50.0f64 / 16.0;
        let row: f64 = (0..40)
            .map(|x| {
                let v = if x % 4 == 1 { 12.5 } else { 0.0 };
                (v - truth_level).powi(2) / (truth_level * truth_level + EPSILON)
            })
            .sum();
        let truth = row / 1200.0;
        let (sum, counted) = estimate(&t, 4);
        let plain = sum / counted as f64;
        assert!(plain < truth / 4.0, "the halves alone see {plain} of {truth}");
        let f = run(&t, 4).expect("the edge is reported");
        assert_eq!(f.pixels, 10);
        assert!(f.rel_mse >= truth && f.rel_mse <= 3.0 * truth, "{} vs {truth}", f.rel_mse);
        assert_eq!(f.brightest, (1, 15));
    }

    #[test]
    fn fireflies_that_add_little_to_the_estimate_are_not_reported() {
        let hot: Vec<(i32, i32)> = (0..12).map(|k| (3 * k + 1, 5 + k % 3 * 7)).collect();
        let t = film(&hot, 200.0, 30);
        let f = run(&t, 8).expect("alone, they are most of the error");
        // The rest of the image as noisy as the fireflies at their worst.
        let (s, e) = errors(&t, 8);
        let noisy: Vec<f64> = e.iter().map(|e| e + f.rel_mse).collect();
        assert!(find(
            SIZE,
            |i| t.pixels[i],
            1.0,
            HalfImages::Independent,
            s,
            &noisy,
            sum_counted(&noisy)
        )
        .is_none());
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
