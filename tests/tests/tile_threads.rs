//! A tile whose sampler is stateless (Halton, Sobol') renders its pixels on
//! every thread of the pool it runs on (`Renderer::render_tile_parallel`),
//! with the bits of the same tile rendered on one thread: whole, or one
//! pass's samples, under a wide filter whose splats cross pixels, a crop
//! window and textures filtered with ray differentials. A sampler with
//! state renders its tiles on one thread, as before. At many samples a
//! pixel the traced samples are held a run of pixels at a time.

use farm_common::film::SampleRange;
use farm_common::ids::TileId;
use farm_render::{RenderOptions, Renderer};

const SCENE: &str = "LookAt 0 1.5 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n\
    Sampler \"SAMPLER\" \"integer pixelsamples\" 8\n\
    PixelFilter \"gaussian\" \"float xwidth\" 2 \"float ywidth\" 2\n\
    Film \"image\" \"integer xresolution\" 70 \"integer yresolution\" 45 \
    \"float cropwindow\" [0.05 0.95 0.1 1]\nWorldBegin\n\
    LightSource \"point\" \"point from\" [1 3 -3] \"rgb I\" [10 10 10]\n\
    LightSource \"spot\" \"point from\" [-2 4 -1] \"point to\" [0 0 0] \"rgb I\" [30 20 10]\n\
    Texture \"checks\" \"spectrum\" \"checkerboard\" \"float uscale\" 16 \"float vscale\" 16 \
    \"rgb tex1\" [0.8 0.8 0.8] \"rgb tex2\" [0.1 0.2 0.4]\n\
    Material \"glass\"\nShape \"sphere\" \"float radius\" 0.7\n\
    AttributeBegin\nTranslate 1.2 0 0.5\nMaterial \"metal\" \"float roughness\" 0.05\n\
    Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n\
    Material \"matte\" \"texture Kd\" \"checks\"\n\
    Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \
    \"point P\" [-5 -1 -5  5 -1 -5  5 -1 5  -5 -1 5] \"float uv\" [0 0 1 0 1 1 0 1]\nWorldEnd\n";

fn renderer(sampler: &str) -> Renderer {
    renderer_with(sampler, &RenderOptions::default())
}

fn renderer_with(sampler: &str, opts: &RenderOptions) -> Renderer {
    // A folder per call: the tests run at once and each removes its own.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("farm-tile-threads-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("{sampler}.pbrt"));
    std::fs::write(&path, SCENE.replace("SAMPLER", sampler)).expect("write");
    let parsed = farm_scene::parse_file(&path);
    let _ = std::fs::remove_dir_all(&dir);
    let (desc, _) = parsed.expect("parses");
    Renderer::new(desc, opts).expect("builds").0
}

fn bits(t: &farm_common::film::FilmTile) -> Vec<u32> {
    t.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn a_stateless_samplers_tile_renders_on_every_thread_with_one_threads_bits() {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().expect("pool");
    for sampler in ["halton", "sobol", "stratified", "random"] {
        let r = renderer(sampler);
        assert_eq!(r.tiles_parallel(), matches!(sampler, "halton" | "sobol"), "{sampler}");
        let pass = SampleRange { first: 3, end: 7, second_from: 5, own_halves: false };
        let mut lit = 0;
        for tile in 0..r.film.tile_count() {
            let id = TileId(tile);
            let (one, one_stats) = r.render_tile(id);
            let (many, many_stats) = pool.install(|| r.render_tile_parallel(id, None));
            assert_eq!(bits(&one), bits(&many), "{sampler}, tile {tile}");
            assert_eq!(one.pixel_bounds, many.pixel_bounds);
            assert_eq!(one_stats, many_stats, "{sampler}, tile {tile}");
            lit += usize::from(one.pixels.iter().any(|p| p.contrib[0] > 0.0));
            if r.tiles_parallel() {
                let (one, _) = r.render_tile_samples(id, pass);
                let (many, _) = pool.install(|| r.render_tile_parallel(id, Some(pass)));
                assert_eq!(bits(&one), bits(&many), "{sampler}, tile {tile}, samples 3..7");
            }
        }
        assert!(lit > 6, "{sampler}: only {lit} tiles have light");
    }
}

/// A stateless sampler's tile rendered as its parts, each on its own (as
/// idle workers render them at the end of a frame) and added in part
/// order into a zero film, has the tile's bits, under the wide filter
/// whose splats cross the parts' edges: whole or one pass's samples.
#[test]
fn a_tiles_parts_added_in_order_have_the_tiles_bits() {
    use farm_common::film::{FilmTile, TILE_PARTS};
    let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().expect("pool");
    let pass = SampleRange { first: 2, end: 6, second_from: 4, own_halves: false };
    for sampler in ["halton", "sobol"] {
        let r = renderer(sampler);
        for tile in 0..r.film.tile_count() {
            let id = TileId(tile);
            for range in [None, Some(pass)] {
                let (whole, whole_stats) = match range {
                    None => r.render_tile(id),
                    Some(p) => r.render_tile_samples(id, p),
                };
                let mut sum = FilmTile::new(whole.pixel_bounds);
                let mut stats = farm_common::stats::RayStats::default();
                for k in 0..TILE_PARTS {
                    let (part, s) =
                        pool.install(|| r.render_part(id, range, k)).expect("a stateless sampler");
                    assert_eq!(part.pixel_bounds, whole.pixel_bounds);
                    sum.merge(&part);
                    stats.add(&s);
                }
                assert_eq!(bits(&sum), bits(&whole), "{sampler}, tile {tile}, {range:?}");
                assert_eq!(stats, whole_stats, "{sampler}, tile {tile}");
            }
        }
    }
    assert!(renderer("random").render_part(TileId(0), None, 0).is_none());
    assert!(renderer("halton").render_part(TileId(0), None, TILE_PARTS).is_none());
}

#[test]
fn at_many_samples_a_tile_is_traced_a_run_of_pixels_at_a_time_with_the_same_bits() {
    // 1024 samples a pixel: a tile's 256 pixels are traced and splatted in
    // runs of 64, so what is held stays bounded; the bits do not change.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().expect("pool");
    let r = renderer_with("halton", &RenderOptions { spp: Some(1024), ..Default::default() });
    let middle = r.film.tile_count() / 2;
    for tile in [0, middle] {
        let id = TileId(tile);
        let (one, one_stats) = r.render_tile(id);
        let (many, many_stats) = pool.install(|| r.render_tile_parallel(id, None));
        assert_eq!(bits(&one), bits(&many), "tile {tile}");
        assert_eq!(one_stats, many_stats, "tile {tile}");
        assert!(one_stats.camera_rays >= 1024 * 64, "tile {tile}: {one_stats:?}");
    }
}
