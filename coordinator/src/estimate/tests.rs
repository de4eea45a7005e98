//! The estimate's tests.

use super::*;
use farm_common::film::FilmTile;
use farm_common::geometry::Point2i;
use farm_common::rng::Rng;
use farm_common::Spectrum;

/// The totals the estimate passes on are the ones summed apart, bit
/// for bit, with errors left out (NaN) among them.
#[test]
fn the_totals_are_the_sum_and_count_of_the_counted_errors() {
    let mut rng = Rng::new(5);
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(37, 23));
    let errors: Vec<f64> = (0..b.area())
        .map(|i| if i % 7 == 3 { f64::NAN } else { f64::from(rng.uniform_f32()) * 1e-3 })
        .collect();
    let (e, (sum, counted)) = ErrorEstimate::with_totals(b, &errors).unwrap();
    let (s, k) = sum_counted(&errors);
    assert_eq!((sum.to_bits(), counted), (s.to_bits(), k));
    assert_eq!(e.rel_mse.to_bits(), (s / k as f64).to_bits());
    assert!(ErrorEstimate::with_totals(b, &vec![f64::NAN; b.area()]).is_none());
}

/// Renders a synthetic film whose pixels average `n` noisy samples of a
/// known value, and returns the estimate and the true relMSE.
fn synthetic(n: u32, sigma: f32) -> (Option<ErrorEstimate>, f64) {
    split(n, n / 2, sigma)
}

/// As [`synthetic`], with the second half's samples from `second_from` on.
fn split(n: u32, second_from: u32, sigma: f32) -> (Option<ErrorEstimate>, f64) {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(64, 48));
    let mut t = FilmTile::new(b);
    let mut rng = Rng::new(7);
    let truth = |p: Point2i| 0.2 + 0.01 * (p.x + p.y) as f32;
    for p in b.iter() {
        for i in 0..n {
            // Uniform noise of standard deviation sigma.
            let u = (rng.uniform_f32() - 0.5) * sigma * 12f32.sqrt();
            let v = truth(p) + u;
            t.add(p, Spectrum::new(v, v, v), 1.0, i >= second_from);
        }
    }
    let est = ErrorEstimate::from_pixels(b, &t.pixels, 1.0, HalfImages::Independent);
    let mut truth_err = 0.0;
    for (p, px) in b.iter().zip(&t.pixels) {
        let r = f64::from(truth(p));
        let a = f64::from(px.contrib[0] / px.weight);
        truth_err += (a - r).powi(2) / (r * r + EPSILON);
    }
    (est, truth_err / b.area() as f64)
}

#[test]
fn the_estimate_tracks_the_true_error_of_noisy_pixels() {
    for (n, sigma) in [(2, 0.05), (4, 0.1), (16, 0.1), (64, 0.3)] {
        let (est, truth) = synthetic(n, sigma);
        let est = est.expect("two or more samples give an estimate").rel_mse;
        let ratio = est / truth;
        assert!((0.8..1.25).contains(&ratio), "n={n} σ={sigma}: {est:e} vs true {truth:e}");
    }
}

#[test]
fn unequal_independent_halves_still_track_the_true_error() {
    // A pass of 12 samples after 4 (or of 2 after 14).
    for (n, from) in [(16, 4), (16, 14), (48, 16)] {
        let (est, truth) = split(n, from, 0.1);
        let ratio = est.unwrap().rel_mse / truth;
        assert!((0.8..1.25).contains(&ratio), "n={n} from {from}: ratio {ratio}");
    }
}

#[test]
fn the_halves_of_a_sequence_count_their_difference_as_sqrt3_times_the_error() {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(2, 1));
    let mut t = FilmTile::new(b);
    for (i, v) in [0.2f32, 0.4, 0.5, 0.3].into_iter().enumerate() {
        t.add(Point2i::new(i as i32 % 2, 0), Spectrum::new(v, v, v), 1.0, i >= 2);
    }
    let at = |s| ErrorEstimate::from_pixels(b, &t.pixels, 1.0, s).unwrap().rel_mse;
    // Pixel 0: halves 0.2 and 0.5, so D = 0.15 around F = 0.35.
    let d0 = 0.15f64.powi(2) / (0.35f64.powi(2) + EPSILON);
    let d1 = 0.05f64.powi(2) / (0.35f64.powi(2) + EPSILON);
    let independent = at(HalfImages::Independent);
    assert!((independent - (d0 + d1) / 2.0).abs() < 1e-6, "{independent}");
    let sequence = at(HalfImages::Sequence);
    assert!((independent / sequence - 3f64.sqrt()).abs() < 1e-9, "{sequence}");
    let spread = at(HalfImages::Spread);
    assert!((independent / spread - 5f64.sqrt()).abs() < 1e-9, "{spread}");
}

#[test]
fn speckle_counts_against_its_neighbourhoods_level() {
    // Every pixel's 64 samples are 0.1 but for a rare one of 50 (one
    // in 96): a speckled film, each pixel's true value the same.
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(64, 48));
    let mut t = FilmTile::new(b);
    let mut rng = Rng::new(11);
    let (p, bright, dim) = (1.0 / 96.0, 50.0, 0.1);
    for q in b.iter() {
        for i in 0..64 {
            let v = if rng.uniform_f32() < p { bright } else { dim };
            t.add(q, Spectrum::new(v, v, v), 1.0, i >= 32);
        }
    }
    let truth_value = f64::from(dim) + f64::from(p * (bright - dim));
    let truth = t
        .pixels
        .iter()
        .map(|px| {
            let a = f64::from(px.contrib[0] / px.weight);
            (a - truth_value).powi(2) / (truth_value * truth_value + EPSILON)
        })
        .sum::<f64>()
        / b.area() as f64;
    let own: f64 =
        t.pixels.iter().filter_map(|px| pixel_error(px, 1.0, HalfImages::Independent)).sum::<f64>()
            / b.area() as f64;
    let levelled =
        ErrorEstimate::from_pixels(b, &t.pixels, 1.0, HalfImages::Independent).unwrap().rel_mse;
    // Against its own value, a pixel that caught a bright sample
    // divides its difference by that sample's brightness.
    assert!(own < 0.5 * truth, "own value: {own} vs true {truth}");
    let ratio = levelled / truth;
    assert!((0.5..2.0).contains(&ratio), "levelled: {levelled} vs true {truth}");
}

#[test]
fn one_sample_per_pixel_gives_no_estimate() {
    assert_eq!(synthetic(1, 0.1).0, None);
}

#[test]
fn a_noiseless_render_estimates_zero_and_tiles_average_pixels() {
    let (est, truth) = synthetic(8, 0.0);
    let mut est = est.unwrap();
    // Only f32 rounding of the sums remains.
    assert!(est.rel_mse < 1e-12 && truth < 1e-12, "{} {truth}", est.rel_mse);
    est.per_pixel.fill(0.0);
    est.per_pixel[0] = 256.0;
    est.per_pixel[17] = 16.0;
    let (tw, th, tiles) = est.per_tile();
    assert_eq!((tw, th), (4, 3));
    assert_eq!(tiles[0], 1.0);
    assert_eq!(tiles[1], 0.0625);
    assert!(tiles[2..].iter().all(|&v| v == 0.0));
}

/// A film of `width` × `height` pixels whose sums are drawn to reach every
/// case the estimate has: halves without samples, negative filter weights
/// and sums, values from 1e-30 to 1e30 and infinite sums, fireflies (one
/// bright sample in the second half) and a bright stripe (light edges).
fn awkward_film(rng: &mut Rng, width: usize, height: usize) -> Vec<Pixel> {
    let mut u = || rng.uniform_f32();
    (0..width * height)
        .map(|i| {
            let w = match (u() * 20.0) as u32 {
                0 => 0.0,
                1 => -0.5 * u(),
                _ => 1.0 + 8.0 * u(),
            };
            let w_b = match (u() * 20.0) as u32 {
                0 => 0.0,
                1 => w,
                _ => w * (0.3 + 0.4 * u()),
            };
            let level = match (u() * 30.0) as u32 {
                0 => 1e-30,
                1 => 1e30,
                2 => -1.0,
                _ => 0.1 + u(),
            };
            let stripe = if i % width == width / 2 { 50.0 } else { 1.0 };
            // Lone fireflies, and blocks of them whose pixels have bright
            // neighbours (edges, not fireflies).
            let (x, y) = (i % width, i / width);
            let block = (x / 3) % 7 == 0 && (y / 2) % 5 == 0;
            let fire = if block || u() < 0.03 { 300.0 } else { 1.0 };
            let second = [0; 3].map(|_| w_b * level * stripe * fire * (0.5 + u()));
            let mut contrib: [f32; 3] =
                std::array::from_fn(|c| (w - w_b) * level * stripe * (0.5 + u()) + second[c]);
            if u() < 0.002 {
                contrib[0] = f32::INFINITY;
            }
            Pixel { contrib, weight: w, second_contrib: second, second_weight: w_b }
        })
        .collect()
}

/// [`suspects`] as it was written before its first test took pixels two
/// at a time: one pixel after the other.
fn suspects_one_by_one(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    spp: u32,
) -> Suspects {
    let (mut fireflies, mut edges, mut around) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..width * height {
        let p = pixel(i);
        let Some((_, dark, bright)) = fireflies::levels(&p, f64::from(scale)) else {
            continue;
        };
        let smaller =
            f64::from(p.second_weight.min(p.weight - p.second_weight)) / f64::from(p.weight);
        let apart = fireflies::apart(f64::from(spp) * smaller);
        if bright <= apart * (dark + 0.01) {
            continue;
        }
        match fireflies::stands_out(i, (width, height), &pixel, scale, spp, &mut around) {
            Some(true) => fireflies.push(i),
            Some(false) => edges.push(i),
            None => {}
        }
    }
    Suspects { fireflies, edges }
}

/// [`levelled_errors`] as it was written before it took pixels two at a
/// time (with the arithmetic of now: the level's mean a product by
/// `1 / n`): each pixel's value, its 3 × 3 sums (across, then the rows
/// above and below) and its error, one pixel after the other.
fn levelled_one_by_one(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    halves: HalfImages,
    own: &[usize],
) -> Vec<f64> {
    let value = |x: usize, y: usize| {
        sampled_value(&pixel(y * width + x), scale).map_or([0.0; 4], |v| [v[0], v[1], v[2], 1.0])
    };
    let add = |a: &mut [f64; 4], b: [f64; 4]| (0..4).for_each(|c| a[c] += b[c]);
    let across = |x: usize, y: usize| {
        let mut a = value(x, y);
        if x > 0 {
            add(&mut a, value(x - 1, y));
        }
        if x + 1 < width {
            add(&mut a, value(x + 1, y));
        }
        a
    };
    let mut errors = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let (i, v) = (y * width + x, value(x, y));
            let e = if v[3] == 0.0 {
                None
            } else if own.contains(&i) {
                pixel_error(&pixel(i), scale, halves)
            } else {
                let mut sum = across(x, y);
                for ny in
                    [y.checked_sub(1), Some(y + 1).filter(|&b| b < height)].into_iter().flatten()
                {
                    add(&mut sum, across(x, ny));
                }
                let level = std::array::from_fn(|c| v[c].min(sum[c] * (1.0 / sum[3])));
                pixel_error_against(&pixel(i), scale, halves, Against::Level(level))
            };
            errors.push(e.unwrap_or(f64::NAN));
        }
    }
    errors
}

/// Pixels taken two at a time give the suspects and the errors, bit for
/// bit, that one at a time gave: on awkward films of odd and even widths
/// (a last pixel alone), for every kind of halves, scales and sample
/// counts, with the fireflies found and with other pixels counted as
/// their own.
#[test]
fn pixels_taken_together_give_the_bits_of_one_at_a_time() {
    let mut rng = Rng::new(17);
    let (mut fireflies, mut edges, mut counted) = (0, 0, 0);
    for (width, height) in [(37, 23), (16, 16), (1, 9), (9, 1), (2, 2)] {
        for halves in [HalfImages::Independent, HalfImages::Sequence, HalfImages::Spread] {
            for (scale, spp) in [(1.0, 16), (0.25, 4), (1e3, 256)] {
                let film = awkward_film(&mut rng, width, height);
                let pixel = |i: usize| film[i];
                let size = (width, height);
                let s = suspects(size, pixel, scale, spp);
                assert_eq!(s, suspects_one_by_one(size, pixel, scale, spp), "{size:?}");
                let some: Vec<usize> = (0..width * height).filter(|i| i % 5 == 1).collect();
                for own in [&s.fireflies[..], &some[..], &[]] {
                    let fast = levelled_errors(size, pixel, scale, halves, own);
                    let slow = levelled_one_by_one(size, pixel, scale, halves, own);
                    for (i, (f, s)) in fast.iter().zip(&slow).enumerate() {
                        let same = f.to_bits() == s.to_bits() || (f.is_nan() && s.is_nan());
                        assert!(same, "{size:?} {halves:?} pixel {i}: {f:e} against {s:e}");
                    }
                    assert_eq!(fast.len(), slow.len());
                    counted += fast.iter().filter(|e| e.is_finite()).count();
                }
                fireflies += s.fireflies.len();
                edges += s.edges.len();
            }
        }
    }
    // The films reach every path.
    assert!(fireflies > 100 && edges > 100 && counted > 10_000, "{fireflies} {edges} {counted}");
}
