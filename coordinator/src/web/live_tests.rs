//! Tests of the live image answers' layout.

use super::*;
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::geometry::Vec2;
use farm_common::ids::TileId;

fn words(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect()
}

/// A film lent out answers as a running film with nothing new: the
/// page keeps its cursor and looks again.
#[test]
fn an_unchanged_answer_keeps_the_pages_cursor() {
    let b = Bounds2i::new(Point2i::new(3, 4), Point2i::new(40, 20));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 2.0, f32::INFINITY, "x".into(), 35.0);
    let u = words(&unchanged(&g, 17, 5));
    assert_eq!(u, [37, 16, 17, 5, RUNNING, 2.0f32.to_bits(), 0]);
}

#[test]
fn a_running_answer_has_the_documented_layout() {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 2.0, f32::INFINITY, "x".into(), 35.0);
    let mut film = Film::new(g.clone());
    let tb = g.tile_pixel_bounds(TileId(0));
    let mut t = FilmTile::new(tb);
    for p in t.pixel_bounds.iter() {
        t.add(p, farm_common::Spectrum::new(3.0, 0.0, 1.0), 0.5, false);
        t.add(p, farm_common::Spectrum::new(1.0, 0.0, 1.0), 0.5, true);
    }
    film.accept(TileId(0), t).unwrap();
    film.running_estimate();
    let u = words(&running(&film, 0, 0, usize::MAX));
    assert_eq!(&u[..7], &[40, 20, 1, 1, RUNNING, 2.0f32.to_bits(), 2]);
    let fb = g.tile_final_pixels(TileId(0));
    let (w, h, n) = (fb.width() as u32, fb.height() as u32, fb.area());
    assert_eq!(&u[7..12], &[0, 0, w, h, PIXELS], "tile 0's final pixels");
    let f = |i: usize| f32::from_bits(u[i]);
    assert_eq!([f(12), f(13), f(14), f(15)], [2.0, 0.0, 1.0, 1.0], "the first pixel's sums");
    let e = 12 + n * 4;
    assert_eq!(&u[e..e + 5], &[0, 0, w, h, ERROR], "then their error map");
    assert_eq!(u.len(), e + 5 + n);
    assert!(f(e + 5) > 0.0, "an error estimate");
    let again = words(&running(&film, 1, 1, usize::MAX));
    assert_eq!(&again[..7], &[40, 20, 1, 1, RUNNING, 2.0f32.to_bits(), 0], "nothing new");
    // A page that missed the error map sees it again; one from the future sees nothing.
    assert_eq!(words(&running(&film, 1, 0, usize::MAX))[6], 1);
    assert_eq!(words(&running(&film, 9, 99, usize::MAX))[..7], again[..7]);
}

#[test]
fn a_finished_answer_is_one_piece_of_pixel_values() {
    let image = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.0, 0.5], [0.0; 3]] };
    let u = words(&finished(&image, Some(&[0.25, 0.0])));
    let one = 1f32.to_bits();
    assert_eq!(&u[..12], &[2, 1, 0, 0, DONE, one, 1, 0, 0, 2, 1, PIXELS_AND_ERROR]);
    let f: Vec<f32> = u[12..].iter().map(|&v| f32::from_bits(v)).collect();
    assert_eq!(f, [1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.25, 0.0]);
}

#[test]
fn a_page_that_was_looking_is_sent_only_the_tiles_it_had_not_seen() {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(1.5), 1.0, f32::INFINITY, "x".into(), 35.0);
    let pixels = (0..b.area()).map(|i| [i as f32, 1.0, 2.0]).collect();
    let image = RgbImage { width: 40, height: 20, pixels };
    let error: Vec<f32> = (0..b.area()).map(|i| i as f32 * 1e-3).collect();
    let n = g.tile_count();
    for seen in 1..n {
        let u = words(&finished_since(&image, Some(&error), &g, seen));
        assert_eq!(&u[..5], &[40, 20, 0, n, DONE]);
        let mut drawn = vec![0; b.area()];
        let mut at = 7;
        for _ in 0..u[6] - 1 {
            let (x, y, w, h, kind) = (u[at], u[at + 1], u[at + 2], u[at + 3], u[at + 4]);
            assert_eq!(kind, PIXELS);
            at += 5;
            let r = Bounds2i::new(
                Point2i::new(x as i32, y as i32),
                Point2i::new((x + w) as i32, (y + h) as i32),
            );
            for (k, p) in r.iter().enumerate() {
                let i = b.offset(p);
                assert_eq!(f32::from_bits(u[at + 3 * k]), i as f32, "the written value");
                drawn[i] += 1;
            }
            at += 3 * r.area();
        }
        // Then the whole error map.
        assert_eq!(&u[at..at + 5], &[0, 0, 40, 20, ERROR]);
        let sent: Vec<f32> = u[at + 5..].iter().map(|&v| f32::from_bits(v)).collect();
        assert_eq!(sent, error);
        let unseen = |p: Point2i| (seen..n).any(|t| g.tile_final_pixels(TileId(t)).contains(p));
        for p in b.iter() {
            assert_eq!(drawn[b.offset(p)], i32::from(unseen(p)), "{p:?} after {seen}");
        }
    }
    // A page that never looked gets the whole image.
    let whole = finished(&image, Some(&error));
    assert_eq!(finished_since(&image, Some(&error), &g, 0), whole);
}

#[test]
fn a_stored_image_is_sent_as_the_journal_holds_it_if_it_fits() {
    let image =
        RgbImage { width: 3, height: 4, pixels: (0..12).map(|i| [i as f32, 0.5, 2.0]).collect() };
    let error: Vec<f32> = (0..12).map(|i| i as f32 * 0.01).collect();
    let direct = finished(&image, Some(&error));
    // Two chunks of rows, as the journal stores them.
    let chunk = |rows: std::ops::Range<usize>, with_error: bool| {
        let px = &image.pixels[rows.start * 3..rows.end * 3];
        let e = &error[rows.start * 3..rows.end * 3];
        let img = v1::JobImage {
            width: 3,
            height: 4,
            first_row: rows.start as u32,
            rgb: px.iter().flatten().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>().into(),
            error_map: if with_error {
                e.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>().into()
            } else {
                Default::default()
            },
            ..Default::default()
        };
        v1::JobEvent { kind: Some(v1::job_event::Kind::Image(img)) }.encode_to_vec()
    };
    let events = [chunk(0..1, true), chunk(1..4, true)];
    assert_eq!(finished_from_events(&events).as_deref(), Some(direct.as_slice()));
    // Rows missing, out of order, or an error map for some rows only.
    assert!(finished_from_events(&events[..1]).is_none());
    assert!(finished_from_events(&[chunk(1..4, true), chunk(0..1, true)]).is_none());
    assert!(finished_from_events(&[chunk(0..1, true), chunk(1..4, false)]).is_none());
    assert!(finished_from_events(&[]).is_none());
}

#[test]
fn a_large_film_is_sent_in_parts_each_pixel_once() {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(64, 40));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 1.0, f32::INFINITY, "x".into(), 35.0);
    let mut film = Film::new(g.clone());
    for t in 0..g.tile_count() {
        let mut tile = FilmTile::new(g.tile_pixel_bounds(TileId(t)));
        for p in tile.pixel_bounds.iter() {
            tile.add(p, farm_common::Spectrum::new(1.0, 1.0, 1.0), 0.5, false);
            tile.add(p, farm_common::Spectrum::new(2.0, 1.0, 1.0), 0.5, true);
        }
        film.accept(TileId(t), tile).unwrap();
    }
    film.running_estimate();
    // Parts of at most 300 pixels (or one change or tile, if larger).
    let (mut from, mut merged, mut parts) = (0usize, 0u32, 0);
    let (mut seen, mut errors) = (vec![0u8; b.area()], vec![0u8; b.area()]);
    loop {
        let u = words(&running(&film, from, merged, 300));
        parts += 1;
        let (mut at, mut pixels) = (7, 0);
        for _ in 0..u[6] {
            let (x, y, w, h, kind) = (u[at], u[at + 1], u[at + 2], u[at + 3], u[at + 4]);
            let marks = if kind == ERROR { &mut errors } else { &mut seen };
            for py in y..y + h {
                for px in x..x + w {
                    marks[(py * 64 + px) as usize] += 1;
                }
            }
            pixels += (w * h) as usize;
            at += 5 + (w * h) as usize * if kind == ERROR { 1 } else { 4 };
        }
        assert_eq!(at, u.len(), "the pieces fill the answer");
        assert!(pixels <= 2 * 300, "a part is bounded: {pixels} pixels");
        (from, merged) = (u[2] as usize, u[3]);
        if u[4] == RUNNING {
            break;
        }
        assert_eq!(u[4], MORE);
        assert!(parts < 100, "the parts end");
    }
    assert!(parts > 2, "sent in parts ({parts})");
    assert!(seen.iter().all(|&n| n == 1), "each pixel once");
    assert!(errors.iter().all(|&n| n == 1), "each pixel's error once");
}
