//! Tests of the embedded engine: retries, failures, and how many tiles are
//! on the render pool at once.

use super::*;
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::Spectrum;
use std::sync::atomic::{AtomicU32, Ordering};

fn geometry() -> FilmGeometry {
    sized(40, 30)
}

fn sized(w: i32, h: i32) -> FilmGeometry {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
    FilmGeometry::new(b.max, b, Vec2::splat(1.5), 1.0, f32::INFINITY, "x.exr".into(), 35.0)
}

/// What a worker renders for a tile: depends only on the tile.
fn tile(id: TileId) -> (FilmTile, RayStats) {
    tile_of(&geometry(), id)
}

fn tile_of(g: &FilmGeometry, id: TileId) -> (FilmTile, RayStats) {
    let mut t = FilmTile::new(g.tile_pixel_bounds(id));
    for p in t.pixel_bounds.iter() {
        let v = ((p.x * 13 + p.y * 7 + id.0 as i32) % 31) as f32 / 31.0;
        t.add(p, Spectrum::new(v, 1.0 - v, 0.5), 0.5 + v, p.x % 2 == 0);
    }
    (t, RayStats { camera_rays: 1, ..Default::default() })
}

fn run(
    render: impl Fn(TileId) -> (FilmTile, RayStats) + Send + Sync + 'static,
) -> Result<Arc<FinishedJob>, Error> {
    run_on(geometry(), render)
}

fn run_on(
    geometry: FilmGeometry,
    render: impl Fn(TileId) -> (FilmTile, RayStats) + Send + Sync + 'static,
) -> Result<Arc<FinishedJob>, Error> {
    let job = LocalJob { geometry, spp: 4, name: "test".into(), passes: None };
    run_job(move |id, _| render(id), job, 2, None, |_| {})
}

#[test]
fn a_tile_that_fails_once_is_retried_and_the_image_is_unchanged() {
    let reference = run(tile).expect("clean render");
    assert_eq!(reference.stats.camera_rays, u64::from(geometry().tile_count()));
    let failures = AtomicU32::new(0);
    let flaky = move |id: TileId| {
        if id == TileId(3) && failures.fetch_add(1, Ordering::Relaxed) == 0 {
            panic!("injected failure");
        }
        tile(id)
    };
    let retried = run(flaky).expect("a retry saves the render");
    assert_eq!(retried.image, reference.image);
    assert_eq!(retried.error, reference.error);
}

/// Tiles whose pixels are traced on every thread, as a stateless
/// sampler's are: a thread waiting for the rest of its tile takes other
/// work meanwhile, but never more tiles than the outbox lets onto the
/// pool (twice its threads), so the image's tiles end nearly in order.
#[test]
fn tiles_traced_on_every_thread_stay_few_on_the_pool() {
    use rayon::prelude::*;
    use std::sync::atomic::AtomicUsize;
    let (now, most) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let (n, m) = (now.clone(), most.clone());
    // 60 tiles, 10 assigned at a time (the worker's slots on 2 threads).
    let g = sized(160, 96);
    let g2 = g.clone();
    let nested = move |id: TileId| {
        m.fetch_max(n.fetch_add(1, Ordering::SeqCst) + 1, Ordering::SeqCst);
        // Pixels of uneven cost on both threads, so one waits for the other.
        (0..8u64).into_par_iter().for_each(|i| {
            std::thread::sleep(std::time::Duration::from_micros(100 + 400 * (i % 3)))
        });
        n.fetch_sub(1, Ordering::SeqCst);
        tile_of(&g2, id)
    };
    let g3 = g.clone();
    let reference = run_on(g.clone(), move |id| tile_of(&g3, id)).expect("clean render");
    let nested = run_on(g, nested).expect("nested render");
    assert_eq!(nested.image, reference.image);
    let most = most.load(Ordering::SeqCst);
    assert!((2..=4).contains(&most), "{most} tiles were being rendered at once on 2 threads");
}

#[test]
fn a_tile_that_always_fails_fails_the_render_with_its_message() {
    let broken = |id: TileId| {
        if id == TileId(5) {
            panic!("tile five is cursed");
        }
        tile(id)
    };
    let Err(Error::JobFailed(message)) = run(broken) else { panic!("the render should fail") };
    assert!(message.contains("tile 5"), "{message}");
    assert!(message.contains("tile five is cursed"), "{message}");
}
