use super::*;
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::Spectrum;

fn film() -> FilmGeometry {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
    FilmGeometry::new(
        Point2i::new(40, 20),
        b,
        Vec2::splat(1.5),
        1.0,
        f32::INFINITY,
        "x.exr".into(),
        35.0,
    )
}

fn tile(g: &FilmGeometry, id: u32) -> FilmTile {
    let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
    for p in t.pixel_bounds.iter() {
        let v = 0.1 + (p.x * 7 + p.y * 3 + id as i32) as f32 * 1e-3;
        t.add(p, Spectrum::new(v, 2.0 * v, 1.0 / 3.0), 0.7, p.x % 2 == 1);
    }
    t
}

#[test]
fn arrival_order_does_not_change_a_bit() {
    let g = film();
    let n = g.tile_count();
    let mut a = Film::new(g.clone());
    for i in 0..n {
        a.accept(TileId(i), tile(&g, i)).unwrap();
    }
    let mut b = Film::new(g.clone());
    for i in (0..n).rev() {
        assert_eq!(b.accept(TileId(i), tile(&g, i)).unwrap(), Accepted::New);
        assert_eq!(b.accept(TileId(i), tile(&g, i)).unwrap(), Accepted::Duplicate);
    }
    assert!(a.is_complete() && b.is_complete());
    assert_eq!(a.image(), b.image());
}

#[test]
fn the_preview_shows_early_tiles_and_ends_as_the_image() {
    let g = film();
    let n = g.tile_count();
    let mut f = Film::new(g.clone());
    let all = g.cropped_pixel_bounds;
    // Tile 1 arrives first: it waits for tile 0, but the preview shows it.
    f.accept(TileId(1), tile(&g, 1)).unwrap();
    assert_eq!(f.merged(), 0);
    let (changed, cursor) = f.changes_since(0);
    assert_eq!(changed, [g.tile_interior_pixels(TileId(1))]);
    let p = f.preview(all);
    let inside = changed[0].min;
    let offset = all.offset(inside);
    assert!(p.pixels[offset][0] > 0.0, "an early tile is shown");
    let t0 = g.tile_pixel_bounds(TileId(0));
    assert_eq!(p.pixels[all.offset(t0.min)], [0.0; 3], "a missing tile is black");
    for i in (0..n).filter(|&i| i != 1) {
        f.accept(TileId(i), tile(&g, i)).unwrap();
    }
    let (changed, end) = f.changes_since(cursor);
    assert_eq!(end, cursor + changed.len());
    assert!(f.changes_since(end).0.is_empty());
    // Once complete, the preview is the image.
    assert_eq!(f.preview(all), f.image());
    let corner = Bounds2i::new(Point2i::new(30, 10), Point2i::new(99, 99));
    let part = f.preview(corner);
    assert_eq!((part.width, part.height), (10, 10));
    assert_eq!(part.pixels[0], f.image().pixels[all.offset(Point2i::new(30, 10))]);
}

#[test]
fn watchers_are_shown_each_pixel_once_when_its_sums_are_complete() {
    let g = film();
    let n = g.tile_count();
    let all = g.cropped_pixel_bounds;
    let mut whole = Film::new(g.clone());
    for i in 0..n {
        whole.accept(TileId(i), tile(&g, i)).unwrap();
    }
    // In order, backwards, and shuffled (a fixed multiplicative walk).
    let orders: [Vec<u32>; 3] =
        [(0..n).collect(), (0..n).rev().collect(), (0..n).map(|i| (i * 5 + 3) % n).collect()];
    assert!(!n.is_multiple_of(5), "the walk visits every tile");
    for order in orders {
        let mut f = Film::new(g.clone());
        let (mut cursor, mut times) = (0, vec![0u32; all.area()]);
        for i in order {
            f.accept(TileId(i), tile(&g, i)).unwrap();
            let (changed, next) = f.changes_since(cursor);
            for r in changed {
                // Shown as they will be in the image, to the bit.
                assert_eq!(f.region_sums(*r), whole.region_sums(*r), "{r:?} after {i}");
                for p in r.iter() {
                    times[all.offset(p)] += 1;
                }
            }
            cursor = next;
        }
        assert!(times.iter().all(|&t| t == 1), "each pixel shown once");
    }
}

#[test]
fn bad_tiles_are_refused() {
    let g = film();
    let mut f = Film::new(g.clone());
    let n = g.tile_count();
    assert!(
        matches!(f.accept(TileId(999), tile(&g, 0)), Err(Error::UnknownTile(999, c)) if c == n)
    );
    assert!(matches!(f.accept(TileId(1), tile(&g, 0)), Err(Error::WrongDimensions(1))));
    let mut t = tile(&g, 0);
    t.pixels.pop();
    assert!(matches!(f.accept(TileId(0), t), Err(Error::WrongDimensions(0))));
    for (k, v) in [(0, f32::NAN), (3, f32::INFINITY), (5, f32::NEG_INFINITY), (3, -0.5), (7, -0.5)]
    {
        let mut t = tile(&g, 2);
        let mut a = t.pixels[7].to_array();
        a[k] = v;
        t.pixels[7] = farm_common::film::Pixel::from_array(a);
        let e = f.accept(TileId(2), t).unwrap_err();
        assert!(matches!(e, Error::BadPixels(2, _)), "{e}");
    }
    assert!(!f.has(TileId(2)), "no bad tile is kept");
    // With a filter that has negative lobes, a negative weight is real.
    let mut signed = g.clone();
    signed.signed_weights = true;
    let mut f = Film::new(signed);
    let mut t = tile(&g, 2);
    t.pixels[7].weight = -0.5;
    assert_eq!(f.accept(TileId(2), t).unwrap(), Accepted::New);
}

#[test]
fn the_running_estimate_follows_the_merge_and_ends_on_the_final_one() {
    let g = film();
    let mut f = Film::new(g.clone());
    let mut unwatched = Film::new(g.clone());
    assert_eq!(f.running_estimate(), None, "nothing merged");
    let n = g.tile_count();
    let halves = |id: u32| {
        let mut t = tile(&g, id);
        for p in t.pixel_bounds.iter() {
            let v = 0.2 + ((p.x * 13 + p.y * 5) % 11) as f32 * 0.03;
            t.add(p, Spectrum::new(v, v, 2.0 * v), 0.5, p.x % 2 == 0);
        }
        t
    };
    let b = g.cropped_pixel_bounds;
    let samples = g.half_images;
    for id in 0..n {
        f.accept(TileId(id), halves(id)).unwrap();
        unwatched.accept(TileId(id), halves(id)).unwrap();
        if id == n / 2 || id == 2 {
            // Mid-render: the mean error of the pixels no later tile reaches.
            let later: Vec<Bounds2i> =
                (id + 1..n).map(|t| g.tile_pixel_bounds(TileId(t))).collect();
            let done = |p: Point2i| later.iter().all(|l| l.intersect(&single(p)).is_empty());
            let errors: Vec<f64> = b
                .iter()
                .filter(|&p| done(p))
                .filter_map(|p| pixel_error(&f.sums.pixel(b.offset(p)), g.scale, samples))
                .collect();
            let direct = errors.iter().sum::<f64>() / errors.len() as f64;
            let running = f.running_estimate().unwrap();
            assert!((running - direct).abs() <= 1e-12 * direct, "{running} vs {direct}");
            let mut map = Vec::new();
            assert!(f.write_error_map(b, &mut map));
            let shown = map.chunks_exact(4).filter(|c| c != &[0; 4]).count();
            assert_eq!(shown, errors.len(), "the map shows the complete pixels");
        }
    }
    // While tiles come in, each pixel counts against its own value; the
    // finished estimate counts it against its neighbourhood's level too,
    // which here (a pattern of 11 values) is lower for some pixels.
    let running = f.running_estimate().unwrap();
    let watched = f.error_estimate(2).unwrap();
    let plain = unwatched.error_estimate(2).unwrap();
    assert_eq!(watched.rel_mse.to_bits(), plain.rel_mse.to_bits(), "the same bits");
    assert_eq!(watched, plain);
    assert!(running < plain.rel_mse, "{running} vs {}", plain.rel_mse);
    // From then on the running estimate is the finished one.
    assert_eq!(f.running_estimate().unwrap().to_bits(), plain.rel_mse.to_bits());
    let mut map = Vec::new();
    assert!(f.write_error_map(b, &mut map));
    let shown: Vec<f32> =
        map.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(shown, plain.per_pixel);
    // The estimate of the whole film at once: the same per-pixel values
    // and mean (no pixel here is a firefly).
    let pixels: Vec<_> = (0..b.area()).map(|i| f.sums.pixel(i)).collect();
    let direct = ErrorEstimate::from_pixels(b, &pixels, g.scale, samples).unwrap();
    let bits = |e: &ErrorEstimate| e.per_pixel.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&plain), bits(&direct));
    assert_eq!((plain.width, plain.height), (direct.width, direct.height));
    assert_eq!(direct.rel_mse.to_bits(), plain.rel_mse.to_bits());
    // One sample per pixel: no estimate.
    let mut one = Film::new(g.clone());
    for id in 0..n {
        let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
        for p in t.pixel_bounds.iter() {
            t.add(p, Spectrum::new(0.5, 0.5, 0.5), 1.0, false);
        }
        one.accept(TileId(id), t).unwrap();
    }
    assert!(one.error_estimate(1).is_none());
}

fn single(p: Point2i) -> Bounds2i {
    Bounds2i::new(p, Point2i::new(p.x + 1, p.y + 1))
}

#[test]
fn sums_for_a_watcher_resolve_to_the_preview() {
    let g = film();
    let mut f = Film::new(g.clone());
    // Tile 0 merged, tiles 2 and 3 early: all show.
    f.accept(TileId(0), tile(&g, 0)).unwrap();
    f.accept(TileId(2), tile(&g, 2)).unwrap();
    f.accept(TileId(3), tile(&g, 3)).unwrap();
    // The whole film, and regions beside the early tiles (rows in
    // common, no pixel in common).
    let beside = [TileId(0), TileId(2)].map(|t| g.tile_pixel_bounds(t));
    for b in [g.cropped_pixel_bounds, beside[0], beside[1]] {
        let bytes = f.region_sums(b);
        assert_eq!(bytes.len(), b.area() * 16);
        let v: Vec<f32> =
            bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        let resolved: Vec<[f32; 3]> = v
            .chunks_exact(4)
            .map(|s| farm_common::film::resolve([s[0], s[1], s[2]], s[3], g.scale))
            .collect();
        assert_eq!(resolved, f.preview(b).pixels);
    }
    let all = f.preview(g.cropped_pixel_bounds).pixels;
    let early = g.tile_pixel_bounds(TileId(3));
    assert!(
        all[g.cropped_pixel_bounds.offset(Point2i::new(early.max.x - 1, early.max.y - 1))][0] > 0.0
    );
}

#[test]
fn a_finished_pass_keeps_its_estimate_until_the_next_pass_begins() {
    // Halves spread over one set's strata, as a sampler with state's first
    // pass has them, and a row of pixels that found a small light with
    // one sample: the estimate is a lower bound whose upper value depends
    // on how the halves relate.
    let mut g = film();
    g.half_images = HalfImages::Spread;
    let mut f = Film::new(g.clone());
    for id in 0..g.tile_count() {
        let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
        for p in t.pixel_bounds.iter() {
            for i in 0..4 {
                let v = if p.y == 10 && p.x % 5 == 0 && i == 3 { 50.0 } else { 0.1 };
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 2);
            }
        }
        f.accept(TileId(id), t).unwrap();
    }
    let finished = f.error_estimate(4).unwrap();
    assert!(finished.fireflies.is_some(), "{finished:?}");
    assert_eq!(f.error_estimate(4).unwrap(), finished, "asked again");
    f.next_pass();
    assert_eq!(f.error_estimate(4).unwrap(), finished, "read between the passes");
    // The next pass's tiles make a new estimate, not the one kept.
    for id in 0..g.tile_count() {
        let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
        for p in t.pixel_bounds.iter() {
            for i in 0..4 {
                let v = 0.1 + 0.01 * i as f32;
                t.add(p, Spectrum::new(v, v, v), 1.0, i >= 2);
            }
        }
        f.accept(TileId(id), t).unwrap();
    }
    let next = f.error_estimate(4).unwrap();
    assert_ne!(next.rel_mse, finished.rel_mse);
    assert_eq!(f.error_estimate(4).unwrap(), next);
}
