//! Every scene in `../shared/scenes/` renders at its file's settings within
//! 2× pbrt-v3's own error against the ground truth, with no non-finite pixel.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::image as metrics;
use farm_common::image::read_file;
use farm_tests::{reference_scenes, shared_dir};

#[test]
fn shared_scenes_match_pbrt_v3_within_twice_its_error() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes and references) is not present");
        return;
    };
    let only = std::env::var("FARM_SCENE").ok();
    let scenes = reference_scenes(&shared);
    assert!(!scenes.is_empty(), "no scenes found in the reference README table");
    let mut failures = Vec::new();
    println!(
        "{:<32} {:>10} {:>10} {:>7} {:>8} {:>9}",
        "scene", "relMSE", "bound", "ratio", "seconds", "Mrays/s"
    );
    for s in &scenes {
        if only.as_deref().is_some_and(|o| o != s.scene) {
            continue;
        }
        let path = shared.join("scenes").join(&s.scene).join(&s.file);
        let reference =
            shared.join("reference").join(&s.scene).join(format!("whitted-{}.exr", s.ground_truth));
        let summary = match submit::render(&path, &SubmitOptions::default(), |_| {}) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{}: render failed: {e}", s.scene));
                continue;
            }
        };
        let gt = read_file(&reference).expect("reference image");
        let Some(err) = metrics::compare(&summary.image, &gt) else {
            failures.push(format!(
                "{}: size {}×{} differs from the reference",
                s.scene, summary.image.width, summary.image.height
            ));
            continue;
        };
        let bound = 2.0 * s.pbrt_rel_mse;
        // How far we are from pbrt-v3's own render at the same settings (for information).
        let pbrt16 = read_file(&shared.join("reference").join(&s.scene).join("whitted.exr"))
            .ok()
            .and_then(|p| metrics::compare(&summary.image, &p))
            .map_or(f64::NAN, |e| e.rel_mse);
        let rays = summary.stats.total_rays() as f64;
        println!(
            "{:<32} {:>10.3e} {:>10.3e} {:>7.2} {:>12.2e} {:>8.2} {:>9.2}",
            s.scene,
            err.rel_mse,
            bound,
            err.rel_mse / s.pbrt_rel_mse,
            pbrt16,
            summary.render_seconds,
            rays / summary.render_seconds / 1e6
        );
        if err.non_finite > 0 {
            failures.push(format!("{}: {} non-finite values", s.scene, err.non_finite));
        }
        if err.rel_mse.is_nan() || err.rel_mse > bound {
            failures.push(format!(
                "{}: relMSE {:.3e} exceeds the bound {:.3e}",
                s.scene, err.rel_mse, bound
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
