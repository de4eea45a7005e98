//! A scene far from the origin renders like the same scene at it: the
//! transforms are read and composed in f64, and rendering happens in
//! camera-centred space. Coordinates near 1e6 with fractional parts that
//! round differently in f32 (the camera's 999993.27 and the world's
//! 1000000.3 err by -0.02 and +0.0125) would otherwise move the camera by
//! a few hundredths of a unit against the world.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::image::compare;
use std::path::Path;

#[test]
fn a_scene_offset_by_a_million_renders_like_the_original() {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt");
    let text = std::fs::read_to_string(&example).unwrap();
    let (dx, dz) = (1_000_000.6, 1_000_000.3);
    let look = "LookAt 0 2.2 -7   0 0.8 0   0 1 0";
    assert!(text.contains(look), "the example's camera moved; update this test");
    let (ex, ez) = (0.11, -7.03);
    let text = text.replace(look, &format!("LookAt {ex} 2.2 {ez}   0 0.8 0   0 1 0"));
    let far = text
        .replace(
            &format!("LookAt {ex} 2.2 {ez}"),
            &format!("LookAt {:.2} 2.2 {:.2}", dx + ex, dz + ez),
        )
        .replace("0 0.8 0   0 1 0", &format!("{dx} 0.8 {dz}   0 1 0"))
        .replace("WorldBegin", &format!("WorldBegin\nTranslate {dx} 0 {dz}"));
    assert!(far.contains("LookAt 1000000.71 2.2 999993.27   1000000.6 0.8 1000000.3"), "{far}");
    let dir = std::env::temp_dir().join(format!("farm-far-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (near_path, far_path) = (dir.join("near.pbrt"), dir.join("far.pbrt"));
    std::fs::write(&near_path, &text).unwrap();
    std::fs::write(&far_path, &far).unwrap();
    let opts = SubmitOptions { spp: Some(4), ..Default::default() };
    let near = submit::render(&near_path, &opts, |_| {}).expect("near").image;
    let far = submit::render(&far_path, &opts, |_| {}).expect("far").image;
    let d = compare(&far, &near).expect("same size");
    println!("relMSE {:.3e}, non-finite {}", d.rel_mse, d.non_finite);
    assert_eq!(d.non_finite, 0);
    assert!(d.rel_mse < 1e-4, "relMSE {:.3e} between the offset scene and the original", d.rel_mse);
    std::fs::remove_dir_all(&dir).ok();
}
