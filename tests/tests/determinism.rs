//! The same scene and seed give the same bits whatever the thread count.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::image::{write_image, ImageMetadata};
use farm_common::math;
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
    let tmp = tempfile::Builder::new().prefix("farm-det-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let (a, b) = (dir.join("a.pfm"), dir.join("b.pfm"));
    write_image(&a, &one.image, &ImageMetadata::default()).expect("write");
    write_image(&b, &again.image, &ImageMetadata::default()).expect("write");
    assert_eq!(std::fs::read(&a).expect("read"), std::fs::read(&b).expect("read"));
}

/// `--cropwindow` renders exactly the full render's pixels there, for every
/// sampler: tiles lie on the full film's grid and keep its seeds, and the
/// low-discrepancy sequences are laid over the whole film (pbrt-v3 lays
/// them over the crop, which gives other, equally good, samples).
#[test]
fn a_crop_is_bit_identical_to_the_same_pixels_of_the_full_render() {
    let tmp = tempfile::Builder::new().prefix("farm-crop-").tempdir().unwrap();
    let dir = tmp.path();
    for sampler in ["halton", "sobol", "random", "stratified", "02sequence", "maxmindist"] {
        // A small film, a wide filter, a crop across tile edges.
        let scene = farm_tests::small_example(150, 100, sampler).replace(
            "PixelFilter \"gaussian\"",
            "PixelFilter \"mitchell\" \"float xwidth\" [ 2.5 ]",
        );
        let path = dir.join(format!("{sampler}.pbrt"));
        std::fs::write(&path, scene).unwrap();
        let render = |crop: Option<[f32; 4]>| {
            let mut opts = SubmitOptions { spp: Some(4), ..Default::default() };
            opts.overrides.crop_window = crop;
            submit::render(&path, &opts, |_| {}).expect("render").image
        };
        let full = render(None);
        let crop = render(Some([0.25, 0.75, 0.3, 0.8]));
        // pbrt-v3's rounding: pixels from ceil(res × fraction), in f32.
        let edge = |res: f32, f: f32| math::ceil(res * f) as usize;
        let (x0, y0) = (edge(150.0, 0.25), edge(100.0, 0.3));
        assert_eq!(crop.width, edge(150.0, 0.75) - x0, "{sampler}");
        assert_eq!(crop.height, edge(100.0, 0.8) - y0, "{sampler}");
        for y in 0..crop.height {
            for x in 0..crop.width {
                let a = crop.pixels[y * crop.width + x].map(f32::to_bits);
                let b = full.pixels[(y + y0) * full.width + x + x0].map(f32::to_bits);
                assert_eq!(a, b, "{sampler}: pixel ({}, {})", x + x0, y + y0);
            }
        }
    }
}
