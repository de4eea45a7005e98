//! The scenes in `scenes/parity/` (one per pbrt-v3 feature added after the
//! shared scenes) render within 2× C++ pbrt-v3's own error against its
//! ground truth, as the shared scenes are checked. The table of pbrt-v3's
//! errors is `scenes/parity/README.md`, written by `scripts/parity-reference`.

use farm_cli::embedded::{self, SubmitOptions};
use farm_common::image::{compare, read_file};
use std::path::Path;

struct Row {
    scene: String,
    ground_truth: String,
    pbrt_rel_mse: f64,
}

fn rows(dir: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(dir.join("README.md")).expect("scenes/parity/README.md");
    text.lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| scene"))
        .map(|l| {
            let f: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            assert_eq!(f.len(), 4, "bad row {l:?}");
            Row {
                scene: f[0].to_string(),
                ground_truth: f[2].to_string(),
                pbrt_rel_mse: f[3].parse().expect("relMSE"),
            }
        })
        .collect()
}

#[test]
fn parity_scenes_match_pbrt_v3_within_twice_its_error() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/parity");
    let only = std::env::var("FARM_SCENE").ok();
    let rows = rows(&dir);
    assert!(rows.len() >= 3, "the parity table lists {} scenes", rows.len());
    let mut failures = Vec::new();
    println!("{:<16} {:>11} {:>11} {:>6}", "scene", "relMSE", "pbrt-v3", "ratio");
    for r in &rows {
        if only.as_deref().is_some_and(|o| o != r.scene) {
            continue;
        }
        let path = dir.join(format!("{}.pbrt", r.scene));
        let gt = dir.join("reference").join(format!("{}-{}.exr", r.scene, "gt"));
        assert!(r.ground_truth.starts_with("gt"), "{}: ground truth {}", r.scene, r.ground_truth);
        let image = match embedded::render(&path, &SubmitOptions::default(), |_| {}) {
            Ok(s) => {
                // Each scene uses its feature as pbrt-v3 reads it.
                for w in s.warnings.iter().filter(|w| w.message.contains("not used")) {
                    failures.push(format!("{}: {w}", r.scene));
                }
                s.image
            }
            Err(e) => {
                failures.push(format!("{}: {e}", r.scene));
                continue;
            }
        };
        let reference = read_file(&gt).expect("ground truth");
        let Some(d) = compare(&image, &reference) else {
            failures.push(format!("{}: size differs from the ground truth", r.scene));
            continue;
        };
        let ratio = d.rel_mse / r.pbrt_rel_mse;
        println!("{:<16} {:>11.3e} {:>11.3e} {:>6.2}", r.scene, d.rel_mse, r.pbrt_rel_mse, ratio);
        if d.non_finite > 0 || ratio > 2.0 {
            failures.push(format!(
                "{}: relMSE {:.3e} is {ratio:.2}× pbrt-v3's {:.3e} ({} non-finite pixels)",
                r.scene, d.rel_mse, r.pbrt_rel_mse, d.non_finite
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The share of pixels where `image` and `reference` differ by more than
/// 1% (of the reference's value plus 0.01) in some channel.
fn share_of_pixels_off(
    image: &farm_common::image::RgbImage,
    reference: &farm_common::image::RgbImage,
) -> f64 {
    let off = image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .filter(|(a, r)| {
            // A NaN on either side counts as off.
            (0..3).any(|c| {
                let d = (a[c] - r[c]).abs();
                d.is_nan() || d > 0.01 * (r[c].abs() + 0.01)
            })
        })
        .count();
    off as f64 / reference.pixels.len().max(1) as f64
}

/// Each scene of `scenes/parity/twins/` (small probes of pbrt-v3's
/// features and parameters) renders pbrt-v3's own image of it, sample for
/// sample: farm and pbrt-v3 take the same samples, so the two images
/// differ only where float rounding moves a sample across an edge. A
/// parameter read differently shows as a large share of pixels off, well
/// above noise; the 1% rule sees a half-float reference's rounding
/// (pbrt-v3 writes EXR in half) as nothing. `scripts/twin-reference`
/// renders the references.
#[test]
fn twins_render_pbrt_v3s_image() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/parity/twins");
    let only = std::env::var("FARM_SCENE").ok();
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("scenes/parity/twins")
        .filter_map(|e| e.ok()?.file_name().to_str()?.strip_suffix(".pbrt").map(String::from))
        .filter(|n| only.as_deref().is_none_or(|o| o == n))
        .collect();
    names.sort();
    assert!(only.is_some() || names.len() >= 20, "{} twin scenes", names.len());
    let mut failures = Vec::new();
    println!("{:<22} {:>11} {:>10}", "scene", "relMSE", "pixels off");
    for name in &names {
        let image = match embedded::render(
            &dir.join(format!("{name}.pbrt")),
            &SubmitOptions::default(),
            |_| {},
        ) {
            Ok(s) => s.image,
            Err(e) => {
                failures.push(format!("{name}: {e}"));
                continue;
            }
        };
        let reference = match read_file(&dir.join("reference").join(format!("{name}-pbrt.exr"))) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{name}: pbrt-v3's image: {e} (scripts/twin-reference)"));
                continue;
            }
        };
        let Some(d) = compare(&image, &reference) else {
            failures.push(format!("{name}: size differs from pbrt-v3's"));
            continue;
        };
        let off = share_of_pixels_off(&image, &reference);
        println!("{name:<22} {:>11.3e} {:>9.2}%", d.rel_mse, off * 100.0);
        if d.non_finite > 0 || off > 0.005 {
            failures.push(format!(
                "{name}: {:.2}% of pixels differ from pbrt-v3's by over 1% (relMSE {:.3e}, {} non-finite)",
                off * 100.0,
                d.rel_mse,
                d.non_finite
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
