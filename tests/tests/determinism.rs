//! The same scene and seed give the same bits whatever the thread count.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::image::{write_image, ImageMetadata};
use std::path::Path;

fn example() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

#[test]
fn renders_are_bit_identical_across_runs_and_thread_counts() {
    let render = |threads| {
        let opts = SubmitOptions { threads, spp: Some(2), ..Default::default() };
        submit::render(&example(), &opts, |_| {}).expect("render")
    };
    let one = render(1);
    let two = render(2);
    let again = render(2);
    let bits = |img: &farm_common::image::RgbImage| -> Vec<u32> {
        img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
    };
    assert_eq!(bits(&one.image), bits(&two.image), "1 vs 2 threads");
    assert_eq!(bits(&two.image), bits(&again.image), "two runs");
    assert!(one.image.pixels.iter().any(|p| p[0] > 0.0), "image is not black");

    // The files written are byte-identical too (PFM carries no timing metadata).
    let dir = std::env::temp_dir().join(format!("farm-det-{}", std::process::id()));
    let (a, b) = (dir.join("a.pfm"), dir.join("b.pfm"));
    write_image(&a, &one.image, &ImageMetadata::default()).expect("write");
    write_image(&b, &again.image, &ImageMetadata::default()).expect("write");
    assert_eq!(std::fs::read(&a).expect("read"), std::fs::read(&b).expect("read"));
}
