//! Helpers for the farm's integration tests: where the shared pbrt-v3
//! scenes and reference images are, and how to render a scene given as text.
#![warn(missing_docs)]

/// An in-process farm.
pub mod cluster;

use farm_coordinator::output::RgbImage;
use farm_coordinator::submit::{self, RenderSummary, SubmitOptions};
use std::path::{Path, PathBuf};

/// `../shared` beside the repository (or `$FARM_SHARED`), if present.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("FARM_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared"));
    dir.join("reference/README.md").is_file().then_some(dir)
}

/// One row of the reference README's table.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceScene {
    /// Folder under `scenes/` and `reference/`.
    pub scene: String,
    /// The Whitted scene file in that folder.
    pub file: String,
    /// pbrt-v3's own relMSE of its 16-spp render against the ground truth.
    pub pbrt_rel_mse: f64,
    /// Ground truth image name, e.g. `gt256`.
    pub ground_truth: String,
}

/// The scenes listed in `reference/README.md`'s measurement table.
pub fn reference_scenes(shared: &Path) -> Vec<ReferenceScene> {
    let text = std::fs::read_to_string(shared.join("reference/README.md")).unwrap_or_default();
    text.lines()
        .filter_map(|line| {
            let cols: Vec<&str> = line.split('|').map(str::trim).collect();
            // | scene | file | res | sampler | relMSE | ground truth | ...
            if cols.len() < 8 || !cols[2].ends_with(".pbrt") {
                return None;
            }
            Some(ReferenceScene {
                scene: cols[1].to_string(),
                file: cols[2].to_string(),
                pbrt_rel_mse: cols[5].parse().ok()?,
                ground_truth: cols[6].to_string(),
            })
        })
        .collect()
}

/// Writes `source` to a temporary scene file and renders it in-process.
pub fn render_text(name: &str, source: &str, opts: &SubmitOptions) -> RenderSummary {
    let dir = std::env::temp_dir().join(format!("farm-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("{name}.pbrt"));
    std::fs::write(&path, source).expect("write scene");
    match submit::render(&path, opts, |_| {}) {
        Ok(s) => s,
        Err(e) => panic!("rendering {name} failed: {e}"),
    }
}

/// The pixel at (x, y).
pub fn pixel(img: &RgbImage, x: usize, y: usize) -> [f32; 3] {
    img.pixels[y * img.width + x]
}
