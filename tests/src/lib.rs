//! Helpers for the farm's integration tests: where the shared pbrt-v3
//! scenes and reference images are, and how to render a scene given as text.
#![warn(missing_docs)]

/// An in-process farm.
pub mod cluster;
/// A worker driven by hand.
pub mod fake;
/// A stand-in for the tev display server.
pub mod fake_tev;
/// The bodies of the fuzz targets.
pub mod fuzz;
/// Plain HTTP/1.1 requests and the Prometheus text format.
pub mod http;

use farm_cli::embedded::{self as submit, RenderSummary, SubmitOptions};
use farm_common::image::RgbImage;
use std::path::{Path, PathBuf};

/// `../shared` beside the repository (or `$FARM_SHARED`), if present.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("FARM_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared"));
    dir.join("reference/README.md").is_file().then_some(dir)
}

pub use farm_cli::bench::{reference_scenes, ReferenceScene};

/// Writes `source` to a temporary scene file and renders it in-process.
pub fn render_text(name: &str, source: &str, opts: &SubmitOptions) -> RenderSummary {
    // A folder of its own, even for two tests that render the same name.
    static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("farm-test-{}-{n}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("{name}.pbrt"));
    std::fs::write(&path, source).expect("write scene");
    let rendered = submit::render(&path, opts, |_| {});
    // The scene's folder goes once it is read (a test that writes the
    // image beside it names its own path).
    let _ = std::fs::remove_dir_all(&dir);
    match rendered {
        Ok(s) => s,
        Err(e) => panic!("rendering {name} failed: {e}"),
    }
}

/// The project's example scene (`scenes/example.pbrt`).
pub fn example_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

/// The example scene's text at `width` × `height` pixels, with `sampler`
/// in place of its Halton sampler.
pub fn small_example(width: u32, height: u32, sampler: &str) -> String {
    std::fs::read_to_string(example_scene())
        .expect("example scene")
        .replace("\"integer xresolution\" [ 480 ]", &format!("\"integer xresolution\" [ {width} ]"))
        .replace(
            "\"integer yresolution\" [ 320 ]",
            &format!("\"integer yresolution\" [ {height} ]"),
        )
        .replace("Sampler \"halton\"", &format!("Sampler \"{sampler}\""))
}

/// An image's floats as bits, for bit-for-bit comparisons.
pub fn bits(img: &RgbImage) -> Vec<u32> {
    img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

/// The example scene rendered in this process at `spp` on two threads:
/// the reference every farm render must match bit for bit.
pub fn embedded_example(spp: u32) -> RgbImage {
    let opts = SubmitOptions { spp: Some(spp), threads: 2, ..Default::default() };
    submit::render(&example_scene(), &opts, |_| {}).expect("embedded render").image
}

/// The pixel at (x, y).
pub fn pixel(img: &RgbImage, x: usize, y: usize) -> [f32; 3] {
    img.pixels[y * img.width + x]
}
